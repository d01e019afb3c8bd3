// hemisphere.glsl: hemisphere lighting (docs/architecture.md, "The runtime models"): sky
// above, ground below, blended by the normal's up component; 0.5 + 0.5 N.y maps N.y in
// [-1, 1] to a blend weight in [0, 1]. +Y is up.
vec3 hemisphere_light(vec3 N, vec3 sky, vec3 ground) {
    return mix(ground, sky, 0.5 + 0.5 * N.y);
}
