// lightmap_directional.glsl: the lightmap-directional model's baked light for a normal-mapped
// normal (formats, units and the L1 bound: patchlight.shading.directional). DIRECTIONAL_SH
// selects L1 spherical harmonics (directional_map0..3 = L0, L1x, L1y, L1z per colour
// channel), else directional_map0 holds the dominant direction times its share. Either way
// the plain lightmap I is kept at the surface's own normal N0 and redistributed elsewhere.
// Needs blinn_phong.glsl before it. The three.js plugin (viewer/static/patchlight_gltf.js)
// puts these two chunks into three.js's own materials and calls directional_light().
uniform sampler2D directional_map0;
uniform sampler2D directional_map1;
uniform sampler2D directional_map2;
uniform sampler2D directional_map3;

#define SH_Y00 0.28209479177387814
#define SH_Y1 0.4886025119029199
#define DIRECTIONAL_FLOOR 1e-6

vec3 sh_light(vec3 c0, vec3 cx, vec3 cy, vec3 cz, vec3 n) {
    return SH_Y00 * c0 + (2.0 / 3.0) * SH_Y1 * (cx * n.x + cy * n.y + cz * n.z);
}

vec3 directional_light(vec2 uv1, vec3 baked, vec3 N, vec3 N0) {
#ifdef DIRECTIONAL_SH
    vec3 c0 = texture(directional_map0, uv1).rgb;
    vec3 cx = texture(directional_map1, uv1).rgb;
    vec3 cy = texture(directional_map2, uv1).rgb;
    vec3 cz = texture(directional_map3, uv1).rgb;
    vec3 at_n0 = sh_light(c0, cx, cy, cz, N0);
    vec3 ratio = max(sh_light(c0, cx, cy, cz, N), 0.0) / max(at_n0, DIRECTIONAL_FLOOR);
    return baked * mix(vec3(1.0), ratio, greaterThan(at_n0, vec3(DIRECTIONAL_FLOOR)));  // no L1 light: I as it is
#else
    vec3 d = texture(directional_map0, uv1).rgb;
    return baked * (0.5 + 0.5 * dot(N, d)) / max(0.5 + 0.5 * dot(N0, d), DIRECTIONAL_FLOOR);
#endif
}

// The light's main direction (xyz, unit) and its share (w, 0..1).
vec4 dominant_direction(vec2 uv1) {
#ifdef DIRECTIONAL_SH
    const vec3 luminance = vec3(0.2126, 0.7152, 0.0722);
    vec3 v = vec3(dot(texture(directional_map1, uv1).rgb, luminance), dot(texture(directional_map2, uv1).rgb, luminance),
                  dot(texture(directional_map3, uv1).rgb, luminance));
    float total = sqrt(3.0) * dot(texture(directional_map0, uv1).rgb, luminance);
#else
    vec3 v = texture(directional_map0, uv1).rgb;
    float total = 1.0;
#endif
    float len = length(v);
    return vec4(v / max(len, DIRECTIONAL_FLOOR), clamp(len / max(total, DIRECTIONAL_FLOOR), 0.0, 1.0));
}

vec3 directional_specular(vec2 uv1, vec3 baked, vec3 N, vec3 V, float gloss, float shininess) {
    vec4 L = dominant_direction(uv1);
    return min(blinn_phong_specular(N, L.xyz, V, shininess), gloss) * L.w * baked;
}
