// compose.glsl: the surface's radiance from its colour, emission and light sum (each model's
// composition and why: docs/architecture.md, "The runtime models").
//   unlit      the colour map alone
//   lightmap, lightmap-directional   colour x baked I + specular (a diffuse surface shows albedo x I)
//   envmap     mix(colour x diffuse, env, fresnel) + env.a x reflectivity (envmap.glsl)
//   hemisphere-radiosity  Listing 1's composition, `baked` = the radiosity R (hemisphere_radiosity.glsl)
//   the rest   colour x diffuse + specular
// Every model but unlit adds the material's own emission.
vec3 compose_surface(vec4 color, vec3 emission, Lighting lit, vec3 baked, vec4 env, float reflectivity) {
#if MODEL == MODEL_UNLIT
    return color.rgb;
#elif MODEL == MODEL_LIGHTMAP || MODEL == MODEL_LIGHTMAP_DIRECTIONAL
    return color.rgb * baked + lit.specular + emission;
#elif MODEL == MODEL_ENVMAP
    return envmap_color(color.rgb * lit.diffuse, env, lit.fresnel, reflectivity) + emission;
#elif MODEL == MODEL_HEMISPHERE_RADIOSITY
    return hemisphere_radiosity_color(color.rgb, env, lit, baked, reflectivity) + emission;
#else
    return color.rgb * lit.diffuse + lit.specular + emission;
#endif
}
