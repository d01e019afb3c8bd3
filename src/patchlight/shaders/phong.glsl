// phong.glsl: Phong's specular term (R.V)^n, R the light direction mirrored about the
// normal (hlsl-lighting-models.txt: R = 2 (N.L) N - L, specular = pow(saturate(R.V), n)).
// It is white: the caller multiplies by the light, never by the colour map.
float phong_specular(vec3 N, vec3 L, vec3 V, float shininess) {
    vec3 R = reflect(-L, N);
    return pow(saturate(dot(R, V)), shininess);
}
