// falloff.glsl: how a point or spot light's strength drops with distance d (metres).

// Physical falloff of a point source: 1 / d^2 (lighting-models-for-games.txt,
// "LightIntensity = lightStrength / (DistanceToLight * DistanceToLight)").
float inverse_square_falloff(float d) {
    return 1.0 / (d * d);
}

// Game falloff with a finite reach r: 1 - (d / r)^2, clamped to [0, 1], so it reaches
// exactly 0 at d = r (hlsl-lighting-models.txt, point light, after Ginsburg/Gosselin and
// Dempski: attenuation = 1 - ((x/r)^2 + (y/r)^2 + (z/r)^2)).
float range_falloff(float d, float range) {
    float x = d / range;
    return saturate(1.0 - x * x);
}
