// lambert.glsl: Lambert's diffuse term, the cosine between the normal and the light,
// clamped at 0 for light from behind: I max(N.L, 0).
float lambert_diffuse(vec3 N, vec3 L) {
    return saturate(dot(N, L));
}
