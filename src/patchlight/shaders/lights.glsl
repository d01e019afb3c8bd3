// lights.glsl: light number i of the uniform arrays, seen from surface point P.
Incident incident_light(int i, vec3 P) {
    if (light_kind[i] == LIGHT_DIRECTIONAL) {
        return directional_light(light_direction[i], light_intensity[i]);
    }
    if (light_kind[i] == LIGHT_POINT) {
        return point_light(light_position[i], light_intensity[i], light_range[i], light_falloff[i], P);
    }
    return spot_light(light_position[i], light_direction[i], light_intensity[i], light_range[i],
                      light_falloff[i], light_cos_inner[i], light_cos_outer[i], P);
}
