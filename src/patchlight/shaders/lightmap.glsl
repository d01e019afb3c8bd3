// lightmap.glsl: the baked incident light I (patchlight.bake) at the lightmap UVs (TEXCOORD_1).
// The shaded colour of a diffuse surface is albedo x I.
uniform sampler2D lightmap;

vec3 lightmap_light(vec2 uv1) {
    return texture(lightmap, uv1).rgb;
}
