// light_common.glsl: what a light delivers to a surface point, and the light uniforms.
//
// Units: I is incident light (cosine-weighted mean radiance), so a white
// diffuse surface facing the light shows radiance I x N.L. A source of radiant intensity
// J (W/sr) at distance d gives I = J x falloff / pi; a sun of irradiance E gives I = E / pi.

struct Incident {
    vec3 L;  // unit vector from the surface point towards the light
    vec3 I;  // incident light, linear RGB
};

uniform int light_count;
uniform int light_kind[MAX_LIGHTS];        // LIGHT_DIRECTIONAL | LIGHT_POINT | LIGHT_SPOT
uniform vec3 light_position[MAX_LIGHTS];   // metres (point, spot)
uniform vec3 light_direction[MAX_LIGHTS];  // unit, the way the light travels (directional, spot)
uniform vec3 light_intensity[MAX_LIGHTS];  // colour x intensity: W/m^2 (directional), W/sr (point, spot)
uniform float light_range[MAX_LIGHTS];     // metres, 0 for none: reach of either falloff
uniform int light_falloff[MAX_LIGHTS];     // FALLOFF_INVERSE_SQUARE | FALLOFF_RANGE
uniform float light_cos_inner[MAX_LIGHTS]; // spot cone, cosines of the half-angles
uniform float light_cos_outer[MAX_LIGHTS];
