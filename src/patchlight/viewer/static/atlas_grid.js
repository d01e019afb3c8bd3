// The lightmap's atlases on the GPU. A bake of several atlases holds them stacked along v
// (the manifest's lightmap, passes and texel arrays, and its TEXCOORD_1: scene/model.py's
// stacked_uv1), which can be taller than the device's largest texture; the page uploads every
// lightmap-space texture as a grid of cols x rows atlases that fits, and draws with each
// vertex's lightmap UVs moved into its atlas's cell. Everything read on the CPU (the probe,
// the atlas view, the texel arrays) stays stacked.
import * as THREE from 'three';
import { dataTexture } from './bundle.js';

export class AtlasGrid {
  // `atlases` atlases of width x height texels each; maxSize: the largest texture side allowed.
  // The fewest columns that fit: as many rows as the limit allows (one column, the stacked
  // layout itself, when all fit); when even that is too wide, no grid fits.
  constructor(atlases, width, height, maxSize) {
    Object.assign(this, { atlases, width, height, maxSize });
    const rows = Math.min(atlases, Math.floor(maxSize / height));
    this.cols = rows > 0 ? Math.ceil(atlases / rows) : 0;
    this.rows = rows > 0 ? Math.ceil(atlases / this.cols) : 0;
    this.fits = rows > 0 && this.cols * width <= maxSize;
  }

  // The grid of the manifest's lightmap under the device's limit (capped by the page's
  // `?max-texture=N`, which tests use to lay out small bakes as a grid).
  static of(manifest, deviceMax) {
    const cap = Number(new URLSearchParams(location.search).get('max-texture')) || Infinity;
    const max = Math.min(deviceMax, cap);
    if (!manifest.lightmap) return new AtlasGrid(1, 1, 1, max);
    const [height, width] = manifest.arrays[manifest.lightmap].shape;
    return new AtlasGrid(manifest.atlases, width, height / manifest.atlases, max);
  }

  // Why the lightmap cannot be shown on this device, in one line.
  get refusal() {
    const what = this.atlases > 1 ? `${this.atlases} lightmap atlases of ${this.width} x ${this.height} do`
      : `the lightmap of ${this.width} x ${this.height} does`;
    return `${what} not fit in this device's largest texture (${this.maxSize} x ${this.maxSize}): bake with fewer texels`;
  }

  get stacked() { return this.cols === 1; }

  // (V * 2) stacked lightmap UVs -> the same points in the grid (each vertex inside its atlas's
  // band, as scene/model.py's atlas_uv1 splits them).
  uvs(stacked) {
    if (this.stacked) return stacked;
    const grid = new Float32Array(stacked.length);
    for (let i = 0; i < stacked.length; i += 2) {
      const v = stacked[i + 1] * this.atlases;
      const atlas = Math.min(this.atlases - 1, Math.max(0, Math.floor(v)));
      grid[i] = ((atlas % this.cols) + stacked[i]) / this.cols;
      grid[i + 1] = (Math.floor(atlas / this.cols) + v - atlas) / this.rows;
    }
    return grid;
  }

  // RGBA texels of the stacked atlases (atlases * height rows of width, row 0 first) as the
  // grid's texture: ClampToEdge, linear filtering, each atlas in its cell (the rest zero).
  texture(stacked) {
    const { width: w, height: h, cols } = this;
    let pixels = stacked;
    if (!this.stacked) {
      pixels = new stacked.constructor(this.rows * h * cols * w * 4);
      for (let atlas = 0; atlas < this.atlases; atlas++) {
        const x0 = (atlas % cols) * w, y0 = Math.floor(atlas / cols) * h;
        for (let y = 0; y < h; y++) {
          const row = (atlas * h + y) * w * 4;
          pixels.set(stacked.subarray(row, row + w * 4), ((y0 + y) * cols * w + x0) * 4);
        }
      }
    }
    return dataTexture(pixels, cols * w, this.rows * h, THREE.ClampToEdgeWrapping);
  }
}
