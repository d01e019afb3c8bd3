// surface_vertex.glsl: world-space position, normal, tangent and UVs for the fragment
// shader; under PER_VERTEX also the light sum, evaluated here at the vertex and
// interpolated across the triangle (Gouraud).
// The model matrix is the identity: scenes arrive as one world-space triangle soup.
#include "surface.glsl"

in vec4 surface_tangent;  // xyz unit tangent (direction of +u), w = handedness +-1
in vec2 lightmap_uv;      // TEXCOORD_1
in vec4 vertex_color;     // COLOR_0, ones when the file has none

out vec3 v_position;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv0;
out vec2 v_uv1;
out vec4 v_color;
#ifdef PER_VERTEX
out vec3 v_diffuse;
out vec3 v_specular;
out vec3 v_reflected;
out float v_fresnel;
#endif

void main() {
    vec4 world = modelMatrix * vec4(position, 1.0);
    v_position = world.xyz;
    v_normal = normalize(mat3(modelMatrix) * normal);
    v_tangent = vec4(mat3(modelMatrix) * surface_tangent.xyz, surface_tangent.w);
    v_uv0 = uv;
    v_uv1 = lightmap_uv;
    v_color = vertex_color;
#ifdef PER_VERTEX
    vec3 V = normalize(cameraPosition - world.xyz);
    Lighting lit = light_surface(world.xyz, v_normal, V, 1.0, shininess, reflectivity);
    v_diffuse = lit.diffuse;
    v_specular = lit.specular;
    v_reflected = lit.reflected;
    v_fresnel = lit.fresnel;
#endif
    gl_Position = projectionMatrix * viewMatrix * world;
}
