// environment.glsl: light that does not come from the punctual lights, in incident-light
// units: a constant ambient, the hemisphere's sky and ground, and the
// environment cube map (RGB radiance, A the specular highlight) of envmap.glsl.
uniform vec3 ambient_color;
uniform vec3 sky_color;
uniform vec3 ground_color;
uniform samplerCube env_map;
