// light_point.glsl: a point light shining equally in all directions (KHR_lights_punctual
// "point"), with falloff.glsl's distance falloff.
Incident point_light(vec3 position, vec3 intensity, float range, int falloff, vec3 P) {
    vec3 to_light = position - P;
    float d = length(to_light);
    float f = falloff == FALLOFF_RANGE ? range_falloff(d, range) : inverse_square_falloff(d, range);
    return Incident(to_light / d, intensity * (f / PI));
}
