// light_spot.glsl: a point light limited to a cone, with KHR_lights_punctual's smooth
// edge: t = saturate((cos_angle - cos_outer) / max(0.001, cos_inner - cos_outer)),
// attenuation t^2 (the extension's reference implementation).

float spot_cone(vec3 L, vec3 direction, float cos_inner, float cos_outer) {
    float cos_angle = dot(direction, -L);
    float t = saturate((cos_angle - cos_outer) / max(0.001, cos_inner - cos_outer));
    return t * t;
}

Incident spot_light(vec3 position, vec3 direction, vec3 intensity, float range, int falloff,
                    float cos_inner, float cos_outer, vec3 P) {
    Incident light = point_light(position, intensity, range, falloff, P);
    light.I *= spot_cone(light.L, direction, cos_inner, cos_outer);
    return light;
}
