// material.glsl: one material's uniforms. Textures hold linear values (sRGB colour maps are
// decoded before upload) and are sampled bilinearly without mipmaps, as the CPU reference does.
uniform vec4 base_color;        // linear RGBA factor
uniform sampler2D color_map;    // RGBA; alpha is the gloss map when normal mapping
uniform vec3 emissive;          // radiance factor
uniform sampler2D emissive_map;
uniform sampler2D normal_map;   // tangent-space normals encoded in [0, 1]
uniform float shininess;        // specular exponent n
uniform float reflectivity;     // envmap strength in [0, 1]

vec4 surface_color(vec2 uv0, vec4 vertex_color) {
    return base_color * texture(color_map, uv0) * vertex_color;
}

vec3 surface_emission(vec2 uv0) {
    return emissive * texture(emissive_map, uv0).rgb;
}
