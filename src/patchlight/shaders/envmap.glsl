// envmap.glsl (docs/architecture.md, "The runtime models"): the Fresnel environment term: the
// view direction mirrored about the normal
// looks up a cube map; a 1 - cos Fresnel approximation scaled by the surface's reflectivity
// tweens between the lit surface and the reflection; the map's alpha adds a specular
// highlight, scaled by the reflectivity alone.
// The classic form tweens the bare base texture towards its cube map (an LDR picture) and
// then multiplies the sum by the light; here the cube holds radiance already (the sky, or
// the scene rendered lit), so the light multiplies the colour alone:
// mix(colour x diffuse, env.rgb, F) + env.a x k, lerp(colour, env, k (1 - N.V)) with the
// colour lit, and its highlight from the alpha.

float fresnel_term(vec3 N, vec3 V, float reflectivity) {
    return reflectivity * (1.0 - saturate(dot(N, V)));
}

// V points from the surface to the eye; the result points away from the surface.
vec3 reflect_view(vec3 N, vec3 V) {
    return reflect(-V, N);
}

vec3 envmap_color(vec3 lit_color, vec4 env, float fresnel, float reflectivity) {
    return mix(lit_color, env.rgb, fresnel) + env.a * reflectivity;
}
