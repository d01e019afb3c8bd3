// light_directional.glsl: a light at infinity (the sun): parallel rays, no falloff
// (KHR_lights_punctual "directional"; a sun of irradiance E gives I = E / pi
// on a surface facing it).
Incident directional_light(vec3 direction, vec3 irradiance) {
    return Incident(-direction, irradiance / PI);
}
