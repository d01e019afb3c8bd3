// hemisphere_radiosity.glsl: hemisphere lighting with a radiosity ground map. The ground map is a
// top-down picture of the lit level (`patchlight groundmap`, patchlight.ground); moving
// objects look up the ground below and beside them in it, and the sky above.
//
// Vertex stage of the listing, evaluated here from the interpolated position and (not
// renormalised) normal: every step is affine in P and N, so this equals interpolating
// the listing's per-vertex results.
//   1. sample point  S = P + offset N (normal), P + offset (N.side) side (side: only the
//      left-right part of the normal, the listing's compromise for objects moving forward,
//      whose front and back then sample their exact position), or P (none)
//   2. planar map    uv = (U . (S, 1), V . (S, 1))   (VS_RADIOSITY_U, VS_RADIOSITY_V)
//   3. tween         t = (0, -0.5, 0, 0.5) . (N, 1) = 0.5 - 0.5 N.y: the ground's weight,
//                    1 facing down, 0 facing up (VS_RADIOSITY_SAT with lrp's operand order)
// Pixel stage:
//   4. ground and sky from where the encoding keeps the shadow (patchlight.ground.encode):
//        separate  ground = map.rgb x shadow.r   sky = shadow.r x sky_scale
//        alpha     ground = map.rgb x map.a      sky = map.a x sky_scale
//        hsv       ground = map.rgb              sky = dot(map.rgb, 1/3) x sky_scale
//      so static shadows darken the sky term as they darken the ground
//   5. radiosity  R = mix(sky, ground, t)                         (lrp r1, v1, t1, r1)
//   6. surface    C = mix(base, env.rgb, fresnel) + env.a x refl  (lrp r0 + mad: envmap.glsl)
//   7. C = 2 C R                                                  (mul_x2 r0, r0, r1)
//   8. C = 2 C v0, v0 = dot3 sun + ambient                         (mul_x2 r0, r0, v0)
//   9. fog        mix(fog colour, C, f), f linear in the distance from the eye
//
// Units. Map texels are linear, value 1 = map_scale (radiance). The listing's registers
// hold light where 0.5 is neutral for mul_x2, so a white surface under a neutral map value
// 0.5 and a neutral v0 = 0.5 comes out as 1: radiance = radiosity_neutral x C with
// radiosity_neutral = 0.5 map_scale. v0 = 0.5 x lit.diffuse / ambient: the lambert sum
// A + sum I N.L (lighting.glsl) relative to the ambient light, so unlit sides get the
// neutral 0.5 and the sun raises it by 0.5 I N.L / A; it multiplies the radiosity, so the
// map's shadows shadow the sun on moving objects too (world-to-object shadowing). The
// cube map is radiance, divided by radiosity_neutral to enter the listing's units. The
// listing's per-vertex reflectivity (iDiffuse.x) is the material's reflectivity; its sun,
// Fresnel term and reflection vector are per vertex under PER_VERTEX. Fog follows the
// listing's linear fog, measured as distance from the eye per pixel; fog_range.y <= .x is off.

#define RADIOSITY_SEPARATE 0
#define RADIOSITY_ALPHA 1
#define RADIOSITY_HSV 2

#define OFFSET_NONE 0
#define OFFSET_NORMAL 1
#define OFFSET_SIDE 2

uniform sampler2D radiosity_map;         // RGB(A) ground map, linear, clamped at its edges
uniform sampler2D radiosity_shadow_map;  // separate encoding: shadow amount in R (else white)
uniform vec4 radiosity_u;                // world (x, y, z, 1) -> u
uniform vec4 radiosity_v;                // world (x, y, z, 1) -> v (row 0 at v = 0)
uniform int radiosity_encoding;          // RADIOSITY_SEPARATE | RADIOSITY_ALPHA | RADIOSITY_HSV
uniform int radiosity_offset_mode;       // OFFSET_NONE | OFFSET_NORMAL | OFFSET_SIDE
uniform float radiosity_offset;          // metres
uniform vec3 radiosity_side;             // the object's unit left-right axis, world space
uniform vec3 radiosity_sky_scale;        // the map's sky constant (groundmap.json sky_scale)
uniform float radiosity_neutral;         // radiance of the listing's neutral 0.5: 0.5 map_scale
uniform vec3 fog_color;                  // radiance
uniform vec2 fog_range;                  // metres: no fog before .x, all fog from .y

vec3 radiosity_sample_point(vec3 P, vec3 N) {
    if (radiosity_offset_mode == OFFSET_NORMAL) return P + radiosity_offset * N;
    if (radiosity_offset_mode == OFFSET_SIDE) return P + radiosity_offset * dot(N, radiosity_side) * radiosity_side;
    return P;
}

vec2 radiosity_map_uv(vec3 S) {
    vec4 h = vec4(S, 1.0);
    return vec2(dot(radiosity_u, h), dot(radiosity_v, h));
}

float radiosity_tween(vec3 N) {
    return 0.5 - 0.5 * N.y;
}

// How much of the sky reaches the texel: the shadow, wherever the encoding keeps it.
float radiosity_shade(vec4 texel, float shadow) {
    if (radiosity_encoding == RADIOSITY_HSV) return dot(texel.rgb, vec3(1.0 / 3.0));
    return radiosity_encoding == RADIOSITY_ALPHA ? texel.a : shadow;
}

vec3 radiosity_ground(vec4 texel, float shadow) {
    if (radiosity_encoding == RADIOSITY_HSV) return texel.rgb;
    return texel.rgb * (radiosity_encoding == RADIOSITY_ALPHA ? texel.a : shadow);
}

vec3 radiosity_sky(vec4 texel, float shadow) {
    return radiosity_shade(texel, shadow) * radiosity_sky_scale;
}

vec3 radiosity_light(vec3 ground, vec3 sky, float tween) {
    return mix(sky, ground, tween);
}

// Steps 1-5 at a surface point P with the interpolated normal N: R in map units.
vec3 hemisphere_radiosity(vec3 P, vec3 N) {
    vec2 uv = radiosity_map_uv(radiosity_sample_point(P, N));
    vec4 texel = texture(radiosity_map, uv);
    float shadow = texture(radiosity_shadow_map, uv).r;
    return radiosity_light(radiosity_ground(texel, shadow), radiosity_sky(texel, shadow), radiosity_tween(N));
}

// v0 of the listing from the lambert sum A + sum I N.L.
vec3 radiosity_sun(vec3 diffuse) {
    return 0.5 * diffuse / max(ambient_color, vec3(1e-6));
}

// Steps 6-8: radiance from the base colour, cube map texel, light sum and R.
vec3 hemisphere_radiosity_color(vec3 base, vec4 env, Lighting lit, vec3 radiosity, float reflectivity) {
    vec3 c = envmap_color(base, env / radiosity_neutral, lit.fresnel, reflectivity);
    c = 2.0 * c * radiosity;
    c = 2.0 * c * radiosity_sun(lit.diffuse);
    return radiosity_neutral * c;
}

float fog_factor(vec3 P, vec3 eye) {
    if (fog_range.y <= fog_range.x) return 1.0;
    return saturate((fog_range.y - distance(P, eye)) / (fog_range.y - fog_range.x));
}

vec3 apply_fog(vec3 radiance, float f) {
    return mix(fog_color, radiance, f);
}
