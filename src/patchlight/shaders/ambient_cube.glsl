// ambient_cube.glsl: light from a baked light volume of ambient cubes. Each probe of a regular grid holds the incident light I
// that a patch facing each of the six axes +X, +Y, +Z, -X, -Y, -Z receives.
// A point finds its grid cell and interpolates each axis trilinearly between the cell's
// eight probes; the normal then weights the axes. Weighting by saturate(n) and saturate(-n)
// (the article's first attempt) sums to |nx| + |ny| + |nz|, from 1 on the axes up to sqrt(3)
// between them, so a uniform volume shades a sphere with bright bands; weighting by the
// squared normal with its sign kept (the article's fix, after Half-Life 2's ambient cube)
// sums to nx^2 + ny^2 + nz^2 = 1, so a uniform volume shades every normal the same.
// AMBIENT_CUBE_NAIVE selects the first weighting, to show the artefact.
//
// Probes inside geometry hold values filled in from their neighbours, which may lie on the
// far side of a wall in the sun; so each corner's trilinear weight is multiplied by the
// probe's validity (0 inside geometry, 1 in the open) and the eight weights renormalised, as
// Unity's adaptive probe volumes weight by probe validity. A point beside a wall then reads
// only the probes on its own side. Where the cell's valid weight falls below
// AMBIENT_CUBE_MIN_VALID_WEIGHT (all eight corners inside geometry, or a point on a plane of
// invalid probes), plain trilinear interpolation of the filled values blends in, so the
// result never divides by zero and never jumps with the last bit of f.
//
// The volume is one 3D texture of NX x NY x 6 NZ texels: axis a's probes occupy the slices
// z in [a NZ, (a + 1) NZ), x fastest, as in the volume file (patchlight.volumes.io); alpha
// is the probe's validity, the same in every axis' slice. Texels are fetched exactly
// (texelFetch) and interpolated here, as the CPU reference does.
uniform highp sampler3D ambient_cube_volume;
uniform vec3 ambient_cube_origin;   // metres, probe (0, 0, 0)
uniform vec3 ambient_cube_spacing;  // metres between probes along X, Y, Z
uniform ivec3 ambient_cube_dims;    // probe counts NX, NY, NZ

// The valid weight below which plain trilinear blends in: small, as a point with even one
// valid corner meets it only 0.9 of a cell or more from that corner along every axis; not
// zero, so that float rounding of a tiny f moves the result by about 1e-4 of the difference
// between filled and valid values, not all of it (patchlight.shading.ambient_cube.
// MIN_VALID_WEIGHT; patchlight.volumes.io, "Sampling").
const float AMBIENT_CUBE_MIN_VALID_WEIGHT = 1e-3;

vec3 ambient_cube_weights(vec3 N) {
#ifdef AMBIENT_CUBE_NAIVE
    return N;
#else
    return N * N * sign(N);
#endif
}

// The cell holding P, clamped to the grid: corners i0, i1 and the fractions f from i0 to i1.
void ambient_cube_cell(vec3 P, out ivec3 i0, out ivec3 i1, out vec3 f) {
    vec3 g = clamp((P - ambient_cube_origin) / ambient_cube_spacing, vec3(0.0), vec3(ambient_cube_dims - 1));
    i0 = min(ivec3(floor(g)), max(ambient_cube_dims - 2, 0));
    i1 = min(i0 + 1, ambient_cube_dims - 1);
    f = g - vec3(i0);
}

vec3 ambient_cube_probe(int x, int y, int z) {
    return texelFetch(ambient_cube_volume, ivec3(x, y, z), 0).rgb;
}

float ambient_cube_validity(int x, int y, int z) {
    return texelFetch(ambient_cube_volume, ivec3(x, y, z), 0).a;
}

// The weights of the cell's eight probes: near at z = i0.z, far at i1.z, each in the order
// (x0, y0), (x1, y0), (x0, y1), (x1, y1): trilinear t times validity v, normalised, with
// plain trilinear blended in where the valid weight s = sum t v is small: t (v + a) / (s + a),
// a = max(AMBIENT_CUBE_MIN_VALID_WEIGHT - s, 0).
void ambient_cube_corners(ivec3 i0, ivec3 i1, vec3 f, out vec4 near, out vec4 far) {
    vec4 tx = vec4(1.0 - f.x, f.x, 1.0 - f.x, f.x);
    vec4 txy = tx * vec4(1.0 - f.y, 1.0 - f.y, f.y, f.y);
    vec4 t_near = txy * (1.0 - f.z);
    vec4 t_far = txy * f.z;
    vec4 v_near = vec4(ambient_cube_validity(i0.x, i0.y, i0.z), ambient_cube_validity(i1.x, i0.y, i0.z),
                       ambient_cube_validity(i0.x, i1.y, i0.z), ambient_cube_validity(i1.x, i1.y, i0.z));
    vec4 v_far = vec4(ambient_cube_validity(i0.x, i0.y, i1.z), ambient_cube_validity(i1.x, i0.y, i1.z),
                      ambient_cube_validity(i0.x, i1.y, i1.z), ambient_cube_validity(i1.x, i1.y, i1.z));
    float valid = dot(t_near, v_near) + dot(t_far, v_far);
    float plain = max(AMBIENT_CUBE_MIN_VALID_WEIGHT - valid, 0.0);
    float total = valid + plain;  // >= the minimum: the trilinear weights sum to 1
    near = t_near * (v_near + plain) / total;
    far = t_far * (v_far + plain) / total;
}

vec3 ambient_cube_axis(int axis, ivec3 i0, ivec3 i1, vec4 near, vec4 far) {
    int z0 = i0.z + axis * ambient_cube_dims.z;
    int z1 = i1.z + axis * ambient_cube_dims.z;
    return near.x * ambient_cube_probe(i0.x, i0.y, z0) + near.y * ambient_cube_probe(i1.x, i0.y, z0)
         + near.z * ambient_cube_probe(i0.x, i1.y, z0) + near.w * ambient_cube_probe(i1.x, i1.y, z0)
         + far.x * ambient_cube_probe(i0.x, i0.y, z1) + far.y * ambient_cube_probe(i1.x, i0.y, z1)
         + far.z * ambient_cube_probe(i0.x, i1.y, z1) + far.w * ambient_cube_probe(i1.x, i1.y, z1);
}

vec3 ambient_cube_light(vec3 P, vec3 N) {
    ivec3 i0, i1;
    vec3 f;
    ambient_cube_cell(P, i0, i1, f);
    vec4 near, far;
    ambient_cube_corners(i0, i1, f, near, far);
    vec3 w = ambient_cube_weights(N);
    vec3 pos = saturate(w);
    vec3 neg = saturate(-w);
    return pos.x * ambient_cube_axis(0, i0, i1, near, far) + pos.y * ambient_cube_axis(1, i0, i1, near, far)
         + pos.z * ambient_cube_axis(2, i0, i1, near, far) + neg.x * ambient_cube_axis(3, i0, i1, near, far)
         + neg.y * ambient_cube_axis(4, i0, i1, near, far) + neg.z * ambient_cube_axis(5, i0, i1, near, far);
}
