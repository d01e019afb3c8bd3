// blinn_phong.glsl: Blinn's specular term (N.H)^n with the half vector H = normalize(L + V)
// (n typically 8 to 32).
float blinn_phong_specular(vec3 N, vec3 L, vec3 V, float shininess) {
    vec3 H = normalize(L + V);
    return pow(saturate(dot(N, H)), shininess);
}
