// phong.glsl: Phong's specular term (R.V)^n, R the light direction mirrored about the
// normal, computed as R = normalize(2 saturate(N.L) N - L), term saturate(R.V)^n.
// Where N.L > 0 this is reflect(-L, N); where the light is behind the surface diff is 0 and
// R = -L, so the term is (-L.V)^n (the self-shadow model's S removes it there).
// It is white: the caller multiplies by the light, never by the colour map.
float phong_specular(vec3 N, vec3 L, vec3 V, float shininess) {
    vec3 R = normalize(2.0 * saturate(dot(N, L)) * N - L);
    return pow(saturate(dot(R, V)), shininess);
}
