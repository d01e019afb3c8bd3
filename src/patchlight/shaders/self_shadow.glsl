// self_shadow.glsl: the geometric self-shadowing term S = saturate(4 N.L) (after
// Frazier). It is 0 exactly where N.L <= 0 and reaches 1 at N.L = 1/4, so
// I = A + S (D N.L + (R.V)^n) fades diffuse and specular out together at the terminator.
float self_shadow(vec3 N, vec3 L) {
    return saturate(4.0 * dot(N, L));
}
