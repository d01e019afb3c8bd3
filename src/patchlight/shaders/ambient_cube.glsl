// ambient_cube.glsl: light from a baked light volume of ambient cubes
// (ambient-cube-light-volumes.txt). Each probe of a regular grid holds the incident light I
// (DESIGN.md units) that a patch facing each of the six axes +X, +Y, +Z, -X, -Y, -Z receives.
// A point finds its grid cell and interpolates each axis trilinearly between the cell's
// eight probes; the normal then weights the axes. Weighting by saturate(n) and saturate(-n)
// (the article's first attempt) sums to |nx| + |ny| + |nz|, from 1 on the axes up to sqrt(3)
// between them, so a uniform volume shades a sphere with bright bands; weighting by the
// squared normal with its sign kept (the article's fix, after Half-Life 2's ambient cube)
// sums to nx^2 + ny^2 + nz^2 = 1, so a uniform volume shades every normal the same.
// AMBIENT_CUBE_NAIVE selects the first weighting, to show the artefact.
//
// The volume is one 3D texture of NX x NY x 6 NZ texels: axis a's probes occupy the slices
// z in [a NZ, (a + 1) NZ), x fastest, as in the volume file (patchlight.volumes.io). Texels
// are fetched exactly (texelFetch) and interpolated here, as the CPU reference does.
uniform highp sampler3D ambient_cube_volume;
uniform vec3 ambient_cube_origin;   // metres, probe (0, 0, 0)
uniform vec3 ambient_cube_spacing;  // metres between probes along X, Y, Z
uniform ivec3 ambient_cube_dims;    // probe counts NX, NY, NZ

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

vec3 ambient_cube_axis(int axis, ivec3 i0, ivec3 i1, vec3 f) {
    int z0 = i0.z + axis * ambient_cube_dims.z;
    int z1 = i1.z + axis * ambient_cube_dims.z;
    vec3 near = mix(mix(ambient_cube_probe(i0.x, i0.y, z0), ambient_cube_probe(i1.x, i0.y, z0), f.x),
                    mix(ambient_cube_probe(i0.x, i1.y, z0), ambient_cube_probe(i1.x, i1.y, z0), f.x), f.y);
    vec3 far = mix(mix(ambient_cube_probe(i0.x, i0.y, z1), ambient_cube_probe(i1.x, i0.y, z1), f.x),
                   mix(ambient_cube_probe(i0.x, i1.y, z1), ambient_cube_probe(i1.x, i1.y, z1), f.x), f.y);
    return mix(near, far, f.z);
}

vec3 ambient_cube_light(vec3 P, vec3 N) {
    ivec3 i0, i1;
    vec3 f;
    ambient_cube_cell(P, i0, i1, f);
    vec3 w = ambient_cube_weights(N);
    vec3 pos = saturate(w);
    vec3 neg = saturate(-w);
    return pos.x * ambient_cube_axis(0, i0, i1, f) + pos.y * ambient_cube_axis(1, i0, i1, f)
         + pos.z * ambient_cube_axis(2, i0, i1, f) + neg.x * ambient_cube_axis(3, i0, i1, f)
         + neg.y * ambient_cube_axis(4, i0, i1, f) + neg.z * ambient_cube_axis(5, i0, i1, f);
}
