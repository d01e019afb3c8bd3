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
// - PATCHLIGHT_lightmap_directional {mode, maps} on a material (bake --directional): the
//   directional lightmap, textures whose PATCHLIGHT_texture_exr {source} is a half-float EXR
//   (three.js's EXRLoader; stored top row first, as glTF images are, so flipY is set). The
//   material's shader is patched so that the baked light the (normal-mapped) normal receives is
//   the lightmap-directional model's: directional_light() of patchlight's GLSL chunk
//   lightmap_directional.glsl, fetched from options.shaders (default: ../../shaders/ beside this
//   file, as in the package and the viewer; copy that file along when you copy this one).
//   With options.specular the baked light also shines: the lightmap-directional model's
//   highlight (`render --specular`): Blinn-Phong towards the dominant direction as a light of
//   share x I, exponent the material's extras.shininess (patchlight's default 16), limited by
//   the gloss (the base colour's alpha when the material has a normal map, else 1). Each such
//   material's material.userData.patchlight = {specular, shininess} holds the uniforms
//   ({value}: 0 or 1, the exponent), to change at run time.
// - KHR_lights_punctual lights whose extras say {"baked": true}: their light is in the lightmap
//   already, so they are turned off (light.visible = false) unless options.keepBakedLights.
import { FloatType, HalfFloatType, ShaderChunk } from 'three';
import { HDRLoader } from 'three/addons/loaders/HDRLoader.js';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';

const DIRECTIONAL = 'PATCHLIGHT_lightmap_directional';
const EXR = 'PATCHLIGHT_texture_exr';
const CHUNKS = ['blinn_phong.glsl', 'lightmap_directional.glsl'];  // the chunk and the one it calls
// three.js's lightmap line (lights_fragment_maps) and what the directional lightmap makes of it:
// the irradiance for the normal-mapped normal, both normals turned from view into world axes.
const LIGHTMAP_LINE = 'vec3 lightMapIrradiance = lightMapTexel.rgb * lightMapIntensity;';
// The highlight goes to the indirect specular light, its I without three.js's pi (MOZ_lightmap's
// intensity holds it) and its gloss as the CPU model's.
const DIRECTIONAL_LINE = `vec3 lightMapIrradiance = directional_light( vLightMapUv, lightMapTexel.rgb * lightMapIntensity,
  inverseTransformDirection( normal, viewMatrix ), inverseTransformDirection( nonPerturbedNormal, viewMatrix ) );
#ifdef USE_NORMALMAP
  float directionalGloss = diffuseColor.a;
#else
  float directionalGloss = 1.0;
#endif
  reflectedLight.indirectSpecular += directional_specular_on * directional_specular( vLightMapUv,
    lightMapTexel.rgb * lightMapIntensity / PI, inverseTransformDirection( normal, viewMatrix ),
    inverseTransformDirection( geometryViewDir, viewMatrix ), directionalGloss, directional_shininess );`;
const DEFAULT_SHININESS = 16;  // patchlight's, for a material without extras.shininess

export class PatchlightPlugin {
  constructor(parser, { float = false, keepBakedLights = false, specular = false,
    shaders = new URL('../../shaders/', import.meta.url) } = {}) {
    this.parser = parser;
    this.name = 'MOZ_lightmap';
    this.keepBakedLights = keepBakedLights;
    this.specular = specular;
    this.shaders = shaders;
    const type = float ? FloatType : HalfFloatType;
    this.hdrLoader = new HDRLoader(parser.options.manager).setDataType(type);
    this.exrLoader = new EXRLoader(parser.options.manager).setDataType(type);
    this.directional = new Map();  // material index -> {mode, maps: [Texture]}
  }

  loadTexture(textureIndex) {
    const extensions = this.parser.json.textures[textureIndex].extensions;
    if (extensions?.MOZ_texture_rgbe) {
      return this.parser.loadTextureImage(textureIndex, extensions.MOZ_texture_rgbe.source, this.hdrLoader);
    }
    if (extensions?.[EXR]) {
      return this.parser.loadTextureImage(textureIndex, extensions[EXR].source, this.exrLoader).then((texture) => {
        texture.flipY = true;  // EXRLoader hands the rows bottom first; glTF's v = 0 is the top row
        return texture;
      });
    }
    return null;
  }

  extendMaterialParams(materialIndex, params) {
    const extensions = this.parser.json.materials[materialIndex].extensions;
    const lightmap = extensions?.MOZ_lightmap;
    if (!lightmap) return null;
    params.lightMapIntensity = lightmap.intensity ?? 1;
    const pending = [this.parser.assignTexture(params, 'lightMap', lightmap)];
    const directional = extensions[DIRECTIONAL];
    if (directional) {
      this.glsl ??= this.loadChunks();
      const maps = directional.maps.map((map) => this.parser.getDependency('texture', map.index));
      pending.push(Promise.all([this.glsl, ...maps]).then(([glsl, ...textures]) => {
        this.directional.set(materialIndex, { mode: directional.mode, maps: textures, glsl });
      }));
    }
    return Promise.all(pending);
  }

  async loadChunks() {
    const texts = await Promise.all(CHUNKS.map(async (name) => {
      const response = await fetch(new URL(name, this.shaders));
      if (!response.ok) throw new Error(`patchlight plugin: ${name}: HTTP ${response.status}`);
      return response.text();
    }));
    return texts.join('\n');
  }

  afterRoot(gltf) {
    for (const scene of gltf.scenes) {
      scene.traverse((object) => {
        if (object.isLight && object.userData.baked === true && !this.keepBakedLights) object.visible = false;
        for (const material of object.isMesh ? [object.material].flat() : []) {
          if (this.isLightmapOcclusion(material)) material.aoMap = null;
          const directional = this.directional.get(this.parser.associations.get(material)?.materials);
          if (directional && material.lightMap) this.applyDirectional(material, directional);
        }
      });
    }
    return null;
  }

  // Whether the material's occlusionTexture is the lightmap's stand-in, by the rule of the
  // description of scene.glb (patchlight.scene.gltf): strength 0 on the texture of its MOZ_lightmap.
  isLightmapOcclusion(material) {
    const index = this.parser.associations.get(material)?.materials;
    const def = index === undefined ? null : this.parser.json.materials[index];
    const occlusion = def?.occlusionTexture;
    const lightmap = def?.extensions?.MOZ_lightmap;
    return Boolean(occlusion && lightmap && occlusion.strength === 0
                   && Number.isInteger(occlusion.index) && occlusion.index === lightmap.index);
  }

  // The material's lightmap read through the directional lightmap: its shader gets the GLSL chunk,
  // the maps as directional_map0..3 and the highlight's uniforms (material.userData.patchlight),
  // and three.js's lightmap line reads directional_light() and adds directional_specular().
  applyDirectional(material, { mode, maps, glsl }) {
    const mapsFragment = ShaderChunk.lights_fragment_maps.replace(LIGHTMAP_LINE, DIRECTIONAL_LINE);
    if (mapsFragment === ShaderChunk.lights_fragment_maps) {
      throw new Error('patchlight plugin: this three.js version reads its lightmap differently');
    }
    const uniforms = {
      specular: { value: this.specular ? 1 : 0 },
      shininess: { value: material.userData.shininess ?? DEFAULT_SHININESS },
    };
    material.userData.patchlight = uniforms;
    material.onBeforeCompile = (shader) => {
      maps.forEach((map, k) => { shader.uniforms[`directional_map${k}`] = { value: map }; });
      shader.uniforms.directional_specular_on = uniforms.specular;
      shader.uniforms.directional_shininess = uniforms.shininess;
      const declarations = 'uniform float directional_specular_on;\nuniform float directional_shininess;\n';
      shader.fragmentShader = shader.fragmentShader
        .replace('void main() {', `${mode === 'sh' ? '#define DIRECTIONAL_SH\n' : ''}${glsl}\n${declarations}void main() {`)
        .replace('#include <lights_fragment_maps>', mapsFragment);
    };
    material.customProgramCacheKey = () => `patchlight-directional-${mode}`;
    material.needsUpdate = true;
  }
}
