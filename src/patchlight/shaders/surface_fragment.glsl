// surface_fragment.glsl: one pixel of a surface. Per pixel (the default) the light sum is
// evaluated here with the interpolated normal, flipped on the back of double-sided
// surfaces (under NORMAL_MAP the perturbed normal flips whole: glTF's back face negates
// tangent, bitangent and normal alike) and, under NORMAL_MAP, perturbed by the normal map with the colour alpha as
// gloss (the specular is limited to min(specular, color.w)). The
// lightmap-directional model redistributes the baked light for that normal.
// OVERLAY shows a lightmap-space debug picture instead: with OVERLAY_LIGHT light values
// (a pass's incident light), exposed like a picture; else display colours as they are
// (texel status, charts). MARKS lays the RGBA marks map (texel checker, chart outlines) over
// either. RADIANCE_OUTPUT writes the linear value before exposure (for automatic exposure).
#include "surface.glsl"

uniform sampler2D overlay_map;
uniform sampler2D marks_map;

in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv0;
in vec2 v_uv1;
in vec4 v_color;
#ifdef PER_VERTEX
in vec3 v_diffuse;
in vec3 v_specular;
in vec3 v_reflected;
in float v_fresnel;
#endif

void main() {
#ifdef OVERLAY
    vec3 radiance = texture(overlay_map, v_uv1).rgb;
#else
    vec4 color = surface_color(v_uv0, v_color);
#ifdef PER_VERTEX
    Lighting lit = Lighting(v_diffuse, v_specular, v_reflected, v_fresnel);
#else
    float facing = gl_FrontFacing ? 1.0 : -1.0;
    vec3 N0 = normalize(v_normal) * facing;
    vec3 N = N0;
    float gloss = 1.0;
#ifdef NORMAL_MAP  // glTF: a back face turns the whole frame (T, B, N), so the mapped normal flips
    N = perturb_normal(normalize(v_normal), v_tangent, decode_normal(texture(normal_map, v_uv0).rgb)) * facing;
    gloss = color.a;
#endif
    vec3 V = normalize(cameraPosition - v_position);
    Lighting lit = light_surface(v_position, N, V, gloss, shininess, reflectivity);
#endif
#if MODEL == MODEL_HEMISPHERE_RADIOSITY
    vec3 baked = hemisphere_radiosity(v_position, v_normal);
#else
    vec3 baked = lightmap_light(v_uv1);
#endif
#if MODEL == MODEL_LIGHTMAP_DIRECTIONAL && !defined(PER_VERTEX)
#ifdef LIGHTMAP_SPECULAR
    lit.specular += directional_specular(v_uv1, baked, N, V, gloss, shininess);
#endif
    baked = directional_light(v_uv1, baked, N, N0);
#endif
    vec4 env = texture(env_map, lit.reflected);
    vec3 radiance = compose_surface(color, surface_emission(v_uv0), lit, baked, env, reflectivity);
#if MODEL == MODEL_HEMISPHERE_RADIOSITY
    radiance = apply_fog(radiance, fog_factor(v_position, cameraPosition));
#endif
#endif
#if defined(RADIANCE_OUTPUT)
    vec3 shown = radiance;
#elif defined(OVERLAY) && !defined(OVERLAY_LIGHT)
    vec3 shown = radiance;
#else
    vec3 shown = display_encode(radiance, exposure);
#endif
#ifdef MARKS
    vec4 mark = texture(marks_map, v_uv1);
    shown = mix(shown, mark.rgb, mark.a);
#endif
    gl_FragColor = vec4(shown, 1.0);
}
