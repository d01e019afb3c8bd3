// lighting.glsl: each model's light sum at one surface point (docs/architecture.md, "The
// runtime models"). The result splits into what
// the colour map multiplies (diffuse) and what it does not (specular), plus the envmap's
// reflection vector and Fresnel weight, so the same sum serves per-pixel lighting (here
// in the fragment shader) and per-vertex lighting (in the vertex shader, interpolated),
// the two classic ways.
//
//   ambient      diffuse = A
//   lambert      diffuse = A + sum I N.L
//   phong        + specular = sum I (R.V)^n            (uncoloured)
//   blinn-phong  + specular = sum I (N.H)^n            (uncoloured)
//   self-shadow  diffuse = A + sum S I N.L, specular = sum S I (R.V)^n, S = saturate(4 N.L)
//   hemisphere   diffuse = mix(ground, sky, 0.5 + 0.5 N.y) alone: no punctual lights (the classic
//                hemisphere light)
//   lightmap     specular = sum I (N.H)^n only with LIGHTMAP_SPECULAR (the lightmap has the diffuse)
//   lightmap-directional  no lights: they are in its maps; with LIGHTMAP_SPECULAR the fragment
//                adds the baked light's highlight from its dominant direction
//   envmap       diffuse as lambert; reflected = reflect(-V, N); fresnel = k (1 - N.V)
//   ambient-cube diffuse = the light volume seen along N, specular = k x the volume along
//                reflect(-V, N) (ambient_cube.glsl); no lights: the volume holds them
// Specular terms are limited by the gloss (colour alpha under normal mapping, else 1).

struct Lighting {
    vec3 diffuse;
    vec3 specular;
    vec3 reflected;
    float fresnel;
};

void add_light(inout Lighting lit, Incident light, vec3 N, vec3 V, float gloss, float shininess) {
    float n_dot_l = lambert_diffuse(N, light.L);
#if MODEL == MODEL_SELF_SHADOW
    float s = self_shadow(N, light.L);
    lit.diffuse += s * n_dot_l * light.I;
    lit.specular += s * min(phong_specular(N, light.L, V, shininess), gloss) * light.I;
#elif MODEL == MODEL_PHONG
    lit.diffuse += n_dot_l * light.I;
    lit.specular += min(phong_specular(N, light.L, V, shininess), gloss) * light.I;
#elif MODEL == MODEL_BLINN_PHONG
    lit.diffuse += n_dot_l * light.I;
    lit.specular += min(blinn_phong_specular(N, light.L, V, shininess), gloss) * light.I;
#elif MODEL == MODEL_LIGHTMAP
#ifdef LIGHTMAP_SPECULAR
    lit.specular += min(blinn_phong_specular(N, light.L, V, shininess), gloss) * light.I;
#endif
#else
    lit.diffuse += n_dot_l * light.I;
#endif
}

Lighting light_surface(vec3 P, vec3 N, vec3 V, float gloss, float shininess, float reflectivity) {
    Lighting lit = Lighting(vec3(0.0), vec3(0.0), reflect_view(N, V), fresnel_term(N, V, reflectivity));
#if MODEL == MODEL_HEMISPHERE
    lit.diffuse = hemisphere_light(N, sky_color, ground_color);
#elif MODEL == MODEL_AMBIENT_CUBE
    lit.diffuse = ambient_cube_light(P, N);
    lit.specular = reflectivity * ambient_cube_light(P, lit.reflected);
#elif MODEL != MODEL_UNLIT && MODEL != MODEL_LIGHTMAP && MODEL != MODEL_LIGHTMAP_DIRECTIONAL
    lit.diffuse = ambient_color;
#endif
#if MODEL != MODEL_UNLIT && MODEL != MODEL_AMBIENT && MODEL != MODEL_AMBIENT_CUBE && MODEL != MODEL_HEMISPHERE && MODEL != MODEL_LIGHTMAP_DIRECTIONAL
    for (int i = 0; i < MAX_LIGHTS; ++i) {
        if (i >= light_count) break;
        add_light(lit, incident_light(i, P), N, V, gloss, shininess);
    }
#endif
    return lit;
}
