// The sky behind the scene: a cube map of the scene's sky model (the environment cube when
// that is the sky) seen along each view ray, exposed as the surfaces are (display.glsl), so
// windows show the sky that lit the bake. The CPU renderer fills its background from the same
// sky model.
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
uniform samplerCube sky_map;
uniform float exposure;
varying vec3 v_direction;
void main() {
    gl_FragColor = vec4(display_encode(texture(sky_map, v_direction).rgb, exposure), 1.0);
}`;
}

// A unit box around the camera, drawn first, showing the cube texture `sky` (none: an empty
// box); `exposure` is the viewer's shared uniform.
export function skyDome(sky, exposure, displayGlsl) {
  const material = new THREE.ShaderMaterial({
    uniforms: { sky_map: { value: sky }, exposure },
    vertexShader: VERTEX, fragmentShader: fragment(displayGlsl), side: THREE.BackSide, depthWrite: false,
    toneMapped: false,
  });
  const dome = new THREE.Mesh(new THREE.BoxGeometry(2, 2, 2), material);
  dome.frustumCulled = false;
  dome.renderOrder = -1;
  return dome;
}
