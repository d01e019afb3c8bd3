// The scene bundle (/scene/manifest.json + /scene/data.bin, patchlight/viewer/bundle.py) as
// three.js objects: one indexed geometry with a group per material, and float textures
// that hold exactly the linear values the CPU reference samples (bilinear, no mipmaps).
import * as THREE from 'three';

export async function loadBundle() {
  const [manifest, data] = await Promise.all([
    fetch('/scene/manifest.json').then((r) => r.json()),
    fetch('/scene/data.bin').then((r) => r.arrayBuffer()),
  ]);
  return new Bundle(manifest, data);
}

export class Bundle {
  constructor(manifest, data) {
    this.manifest = manifest;
    this.data = data;
  }

  array(name) {
    const spec = this.manifest.arrays[name];
    const count = spec.shape.reduce((a, b) => a * b, 1);
    const Type = { uint32: Uint32Array, uint8: Uint8Array, int32: Int32Array, float16: Uint16Array }[spec.dtype]
      ?? Float32Array;  // float16: the raw halves (THREE.DataUtils.fromHalfFloat reads one)
    return new Type(this.data, spec.offset, count);
  }

  // lightmapUvs: (V * 2) float32 lightmap UVs as the page's lightmap textures lay the atlases out.
  geometry(lightmapUvs) {
    const g = new THREE.BufferGeometry();
    const attributes = [['position', 'positions', 3], ['normal', 'normals', 3], ['uv', 'uv0', 2],
      ['surface_tangent', 'tangents', 4], ['vertex_color', 'colors', 4]];
    for (const [attribute, name, size] of attributes) {
      g.setAttribute(attribute, new THREE.BufferAttribute(this.array(name), size));
    }
    g.setAttribute('lightmap_uv', new THREE.BufferAttribute(lightmapUvs, 2));
    g.setIndex(new THREE.BufferAttribute(this.array('indices'), 1));
    for (const group of this.manifest.groups) g.addGroup(group.start, group.count, group.material);
    g.computeBoundingSphere();
    return g;
  }

  // (H, W, 4) float32, float16 or uint8 array -> RGBA texture, linear filtering, no mipmaps, row 0
  // at v = 0 (uint8 texels read as value / 255, as a GPU samples an 8-bit map).
  texture(name, wrap = THREE.RepeatWrapping) {
    const [height, width] = this.manifest.arrays[name].shape;
    return dataTexture(this.array(name), width, height, wrap);
  }

  // (6, S, S, 4) float32 faces in GL order +X, -X, +Y, -Y, +Z, -Z -> cube texture.
  cube(name) {
    const spec = this.manifest.arrays[name];
    const size = spec.shape[1];
    const faceBytes = size * size * 4 * 4;
    const faces = [];
    for (let f = 0; f < 6; f++) {
      faces.push(new THREE.DataTexture(new Float32Array(this.data, spec.offset + f * faceBytes, size * size * 4),
        size, size, THREE.RGBAFormat, THREE.FloatType));
    }
    const cube = new THREE.CubeTexture(faces, THREE.CubeReflectionMapping, THREE.ClampToEdgeWrapping,
      THREE.ClampToEdgeWrapping, THREE.LinearFilter, THREE.LinearFilter, THREE.RGBAFormat, THREE.FloatType);
    settle(cube);
    return cube;
  }
}

export function dataTexture(pixels, width, height, wrap = THREE.RepeatWrapping) {
  const type = pixels instanceof Uint8Array ? THREE.UnsignedByteType
    : pixels instanceof Uint16Array ? THREE.HalfFloatType : THREE.FloatType;
  const t = new THREE.DataTexture(pixels, width, height, THREE.RGBAFormat, type);
  t.wrapS = t.wrapT = wrap;
  t.minFilter = t.magFilter = THREE.LinearFilter;
  settle(t);
  return t;
}

export function constantTexture(rgba) {
  return dataTexture(new Float32Array(rgba), 1, 1);
}

function settle(texture) {
  texture.generateMipmaps = false;
  texture.flipY = false;
  texture.colorSpace = THREE.NoColorSpace;
  texture.needsUpdate = true;
}
