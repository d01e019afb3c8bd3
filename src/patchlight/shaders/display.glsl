// display.glsl: radiance to display value with patchlight's film exposure 1 - exp(-k x)
// (patchlight.imaging.exposure, the curve the bake's PNGs use), then the sRGB transfer
// curve (IEC 61966-2-1): what the CPU renderer writes to its PNGs.
vec3 display_encode(vec3 radiance, float exposure) {
    vec3 c = 1.0 - exp(-exposure * max(radiance, 0.0));
    vec3 curve = 1.055 * pow(max(c, vec3(0.0031308)), vec3(1.0 / 2.4)) - 0.055;
    return mix(c * 12.92, curve, greaterThan(c, vec3(0.0031308)));
}
