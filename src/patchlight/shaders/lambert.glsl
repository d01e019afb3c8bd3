// lambert.glsl: Lambert's diffuse term, the cosine between the normal and the light,
// clamped at 0 for light from behind (lighting-models-for-games.txt, diffuse:
// PixelIntensity = lightIntensity x dot(surfacenormal, lightDirection)).
float lambert_diffuse(vec3 N, vec3 L) {
    return saturate(dot(N, L));
}
