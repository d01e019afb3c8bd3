// normal_map.glsl: tangent-space normal mapping (tangents: patchlight.shading.surface). The map stores n in [0, 1]; 2 t - 1 expands
// it back to [-1, 1]. The frame is the interpolated vertex tangent T made orthogonal to N,
// B = cross(N, T) x sign(w) as glTF defines it, and N; B points up the image (towards -v).
// N is the front face's: on a back face glTF negates T, B and N alike, i.e. the result.

vec3 decode_normal(vec3 t) {
    return 2.0 * t - 1.0;
}

vec3 perturb_normal(vec3 N, vec4 tangent, vec3 n) {
    vec3 T = normalize(tangent.xyz - N * dot(N, tangent.xyz));
    vec3 B = cross(N, T) * (tangent.w < 0.0 ? -1.0 : 1.0);
    return normalize(T * n.x + B * n.y + N * n.z);
}
