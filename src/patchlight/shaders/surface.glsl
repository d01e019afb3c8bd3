// surface.glsl: every chunk the surface shaders need, in dependency order. Included once
// by surface_vertex.glsl and by surface_fragment.glsl; `MODEL` and the option macros
// (PER_VERTEX, NORMAL_MAP, LIGHTMAP_SPECULAR, OVERLAY, OVERLAY_LIGHT, MARKS, RADIANCE_OUTPUT) come from the material's defines.
#include "common.glsl"
#include "falloff.glsl"
#include "light_common.glsl"
#include "light_directional.glsl"
#include "light_point.glsl"
#include "light_spot.glsl"
#include "lights.glsl"
#include "lambert.glsl"
#include "phong.glsl"
#include "blinn_phong.glsl"
#include "self_shadow.glsl"
#include "hemisphere.glsl"
#include "environment.glsl"
#include "envmap.glsl"
#include "lightmap.glsl"
#include "lightmap_directional.glsl"
#include "ambient_cube.glsl"
#include "normal_map.glsl"
#include "material.glsl"
#include "lighting.glsl"
#include "hemisphere_radiosity.glsl"
#include "compose.glsl"
#include "display.glsl"

uniform float exposure;  // k of the film curve 1 - exp(-k x) before the sRGB curve
