// common.glsl: identifiers and helpers shared by every chunk.
// The model, light-kind and falloff numbers are mirrored by patchlight.shading
// (MODELS, LIGHT_KINDS, FALLOFFS); tests/shading/test_glsl_mirror.py keeps them equal.

#define MODEL_UNLIT 0
#define MODEL_AMBIENT 1
#define MODEL_LAMBERT 2
#define MODEL_PHONG 3
#define MODEL_BLINN_PHONG 4
#define MODEL_SELF_SHADOW 5
#define MODEL_HEMISPHERE 6
#define MODEL_LIGHTMAP 7
#define MODEL_ENVMAP 8
#define MODEL_HEMISPHERE_RADIOSITY 9
#define MODEL_AMBIENT_CUBE 10
#define MODEL_LIGHTMAP_DIRECTIONAL 11

#define LIGHT_DIRECTIONAL 0
#define LIGHT_POINT 1
#define LIGHT_SPOT 2

#define FALLOFF_INVERSE_SQUARE 0
#define FALLOFF_RANGE 1

// The most lights one draw takes; the CPU renderer has no such limit.
#define MAX_LIGHTS 8

#define PI 3.141592653589793

// HLSL's saturate: clamp to [0, 1].
float saturate(float x) { return clamp(x, 0.0, 1.0); }
vec3 saturate(vec3 x) { return clamp(x, 0.0, 1.0); }
