// patchlight's GLTFLoader plugin: a baked scene.glb shows its lightmap in three.js as it is.
//
//   import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
//   import { PatchlightPlugin } from './patchlight_gltf.js';
//   const loader = new GLTFLoader().register((parser) => new PatchlightPlugin(parser));
//   scene.add((await loader.loadAsync('out/room/scene.glb')).scene);
//
// What it reads (all written by `patchlight bake`):
// - MOZ_lightmap {index, texCoord, intensity} on a material: material.lightMap = that texture,
//   read through TEXCOORD_1 (texture.channel = texCoord), lightMapIntensity = intensity.
// - MOZ_texture_rgbe {source} on a texture: the HDR image (Radiance RGBE), decoded by three.js's
//   own HDRLoader to half floats (options.float: to floats, which need OES_texture_float_linear);
//   without this plugin a viewer takes the texture's 8-bit PNG source instead.
// - occlusionTexture {index: the lightmap, strength: 0} (written so that validators see the
//   lightmap and TEXCOORD_1 used): glTF's no-op, so the material's aoMap is dropped, never sampled.
// - KHR_lights_punctual lights whose extras say {"baked": true}: their light is in the lightmap
//   already, so they are turned off (light.visible = false) unless options.keepBakedLights.
import { FloatType, HalfFloatType } from 'three';
import { HDRLoader } from 'three/addons/loaders/HDRLoader.js';

export class PatchlightPlugin {
  constructor(parser, { float = false, keepBakedLights = false } = {}) {
    this.parser = parser;
    this.name = 'MOZ_lightmap';
    this.keepBakedLights = keepBakedLights;
    this.hdrLoader = new HDRLoader(parser.options.manager).setDataType(float ? FloatType : HalfFloatType);
  }

  loadTexture(textureIndex) {
    const rgbe = this.parser.json.textures[textureIndex].extensions?.MOZ_texture_rgbe;
    if (!rgbe) return null;
    return this.parser.loadTextureImage(textureIndex, rgbe.source, this.hdrLoader);
  }

  extendMaterialParams(materialIndex, params) {
    const lightmap = this.parser.json.materials[materialIndex].extensions?.MOZ_lightmap;
    if (!lightmap) return null;
    params.lightMapIntensity = lightmap.intensity ?? 1;
    return this.parser.assignTexture(params, 'lightMap', lightmap);
  }

  afterRoot(gltf) {
    for (const scene of gltf.scenes) {
      scene.traverse((object) => {
        if (object.isLight && object.userData.baked === true && !this.keepBakedLights) object.visible = false;
        for (const material of object.isMesh ? [object.material].flat() : []) {
          if (this.isLightmapOcclusion(material)) material.aoMap = null;
        }
      });
    }
    return null;
  }

  // Whether the material's aoMap comes from an occlusionTexture that is its lightmap at strength 0.
  isLightmapOcclusion(material) {
    const index = this.parser.associations.get(material)?.materials;
    const def = index === undefined ? null : this.parser.json.materials[index];
    const occlusion = def?.occlusionTexture;
    return Boolean(occlusion && occlusion.strength === 0
                   && occlusion.index === def.extensions?.MOZ_lightmap?.index);
  }
}
