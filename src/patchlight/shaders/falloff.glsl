// falloff.glsl: how a point or spot light's strength drops with distance d (metres).

// Physical falloff of a point source: 1 / d^2. A light with a
// range r > 0 (KHR_lights_punctual: where its intensity reaches zero) is faded out by the
// window saturate(1 - (d / r)^4)^2: within 1 % of 1 up to d = r / 4, exactly 0 from d = r on,
// with a smooth edge (three.js's getDistanceAttenuation, after Frostbite's
// window; KHR's own sample leaves the window unsquared). range <= 0: no range, plain 1 / d^2.
float inverse_square_falloff(float d, float range) {
    float f = 1.0 / (d * d);
    if (range > 0.0) {
        float x = d / range;
        float x2 = x * x;
        float window = saturate(1.0 - x2 * x2);
        f *= window * window;
    }
    return f;
}

// Game falloff with a finite reach r: 1 - (d / r)^2, clamped to [0, 1], so it reaches
// exactly 0 at d = r (after Ginsburg/Gosselin and Dempski: 1 - |d / r|^2 from the light's
// offset (x, y, z)).
float range_falloff(float d, float range) {
    float x = d / range;
    return saturate(1.0 - x * x);
}
