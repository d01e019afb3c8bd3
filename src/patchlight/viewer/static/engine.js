// The bake's scene.glb as a three.js user's engine shows it: GLTFLoader with patchlight's plugin
// (patchlight_gltf.js) and three.js's own materials, none of patchlight's shaders. The page's
// exposure reaches it through three.js's tone mapping, set to the film curve 1 - exp(-k x)
// that display.glsl applies, so both views of a bake compare pixel for pixel.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { PatchlightPlugin } from './patchlight_gltf.js';

THREE.ShaderChunk.tonemapping_pars_fragment = THREE.ShaderChunk.tonemapping_pars_fragment.replace(
  'vec3 CustomToneMapping( vec3 color ) { return color; }',
  'vec3 CustomToneMapping( vec3 color ) { return 1.0 - exp( - toneMappingExposure * max( color, 0.0 ) ); }');

// The glTF scene of /scene/scene.glb, parsed through the plugin (read whole with fetch, not
// through three.js's streaming FileLoader: its piped body left Chromium reporting the
// finished request as aborted now and then).
export async function loadEngineScene() {
  const response = await fetch('/scene/scene.glb');
  if (!response.ok) throw new Error(`/scene/scene.glb: HTTP ${response.status}`);
  const loader = new GLTFLoader().register((parser) => new PatchlightPlugin(parser));
  return (await loader.parseAsync(await response.arrayBuffer(), '/scene/')).scene;
}

// Tone mapping for three.js's materials: the film curve at `exposure` while scene.glb is shown,
// none (null) otherwise, so the page's other three.js materials keep their colours. The
// viewer's ShaderMaterials encode for display themselves (toneMapped: false).
export function engineToneMapping(renderer, exposure) {
  renderer.toneMapping = exposure === null ? THREE.NoToneMapping : THREE.CustomToneMapping;
  renderer.toneMappingExposure = exposure ?? 1;
}

// The page's 'lightmap: add specular' for scene.glb: the plugin's highlight of the directional
// lightmap (material.userData.patchlight) on or off on every material that has one.
export function engineSpecular(scene, on) {
  scene.traverse((object) => {
    for (const material of object.isMesh ? [object.material].flat() : []) {
      if (material.userData.patchlight) material.userData.patchlight.specular.value = on ? 1 : 0;
    }
  });
}
