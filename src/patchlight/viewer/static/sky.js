// The sky behind the scene: the environment cube map (built from the scene's sky model) seen
// along each view ray, exposed as the surfaces are (display.glsl), so windows show the sky
// that lit the bake. The CPU renderer fills its background from the same sky model.
import * as THREE from 'three';

const VERTEX = `
varying vec3 v_direction;
void main() {
    v_direction = position;
    vec4 clip = projectionMatrix * mat4(mat3(viewMatrix)) * vec4(position, 1.0);
    gl_Position = clip.xyww;  // on the far plane, behind every surface
}`;

function fragment(displayGlsl) {
  return `${displayGlsl}
uniform samplerCube env_map;
uniform float exposure;
varying vec3 v_direction;
void main() {
    gl_FragColor = vec4(display_encode(texture(env_map, v_direction).rgb, exposure), 1.0);
}`;
}

// A unit box around the camera, drawn first; shares the viewer's env_map and exposure uniforms.
export function skyDome(uniforms, displayGlsl) {
  const material = new THREE.ShaderMaterial({
    uniforms: { env_map: uniforms.env_map, exposure: uniforms.exposure },
    vertexShader: VERTEX, fragmentShader: fragment(displayGlsl), side: THREE.BackSide, depthWrite: false,
  });
  const dome = new THREE.Mesh(new THREE.BoxGeometry(2, 2, 2), material);
  dome.frustumCulled = false;
  dome.renderOrder = -1;
  return dome;
}
