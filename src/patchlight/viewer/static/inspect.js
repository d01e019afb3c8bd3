// Inspecting a bake (its texels.npz, patchlight/bakedir.py, in the scene bundle): the passes'
// lightmaps, the debug overlays (incident light, texel status, charts), the marks laid over
// the surfaces (texel checker, chart outlines), the value probe of one texel, the 2-D atlas
// view and the legend of every debug colour.
import * as THREE from 'three';

export const OVERLAYS = { light: 'incident light I', adaptive: 'gathered / interpolated / inside', charts: 'UV charts' };
const OUTLINE = [255, 255, 255, 255];  // chart borders
const CHECKER = [0, 0, 0, 90];         // every other texel darkened (alpha of 255)
const PROBED = [0, 255, 255];          // the probed texel in the atlas view
const MAX_OBJECTS = 12;                // objects whose texel density the checker's legend names

// Linear value -> display byte: film exposure 1 - exp(-k x), then sRGB (display.glsl).
export function displayByte(value, exposure) {
  return srgbByte(1 - Math.exp(-exposure * Math.max(value, 0)));
}

export function srgbByte(c) {
  const e = c <= 0.0031308 ? 12.92 * c : 1.055 * c ** (1 / 2.4) - 0.055;
  return Math.round(Math.min(1, Math.max(0, e)) * 255);
}

// A chart's colour: hues spread by the golden angle, so neighbouring ids differ.
function chartColour(id) {
  const c = new THREE.Color().setHSL((id * 0.618034) % 1, 0.55, 0.55);
  return [c.r, c.g, c.b].map((v) => Math.round(v * 255));
}

export class Inspector {
  constructor(viewer) {
    this.viewer = viewer;
    const t = viewer.manifest.texels;
    this.t = t;
    this.cache = new Map();
    if (!t) return;
    const b = viewer.bundle;
    this.width = t.width;
    this.height = t.height;
    this.status = b.array(t.status);
    this.chart = b.array(t.chart);
    this.rho = b.array(t.rho);
    this.emission = b.array(t.emission);
    this.excident = b.array(t.excident);
    this.lightmap = b.array(viewer.manifest.lightmap);  // RGBA float32: the final incident light
  }

  get passes() { return this.t ? this.t.passes.length : 0; }

  // The lightmap texture of pass k (1..passes); the last is lightmap.exr itself.
  lightTexture(k) {
    if (!this.t || k >= this.passes) return this.viewer.lightmapTexture;
    return this.cached(`pass ${k}`, () => this.viewer.lightmapSpace(this.t.passes[k - 1]));
  }

  // (R, G, B) incident light of texel (x, y) after pass k.
  incident(x, y, k) {
    const i = y * this.width + x;
    if (k >= this.passes) return Array.from(this.lightmap.subarray(i * 4, i * 4 + 3));
    const half = this.viewer.bundle.array(this.t.passes[k - 1]);
    return [0, 1, 2].map((c) => THREE.DataUtils.fromHalfFloat(half[i * 4 + c]));
  }

  overlayTexture(name, k) {
    if (name === 'light') return this.lightTexture(k);
    return this.cached(name, () => this.texelTexture((i) => this.overlayColour(name, i)));
  }

  overlayColour(name, i) {
    if (name === 'adaptive') return this.t.status_colours[this.status[i]];
    return this.chart[i] < 0 ? [0, 0, 0] : chartColour(this.chart[i]);
  }

  // RGBA marks (checker, outlines), or null when neither is on.
  marks(checker, outlines) {
    if (!this.t || !(checker || outlines)) return null;
    return this.cached(`marks ${checker} ${outlines}`, () => {
      const w = this.width;
      const border = (x, y) => {
        const c = this.chart[y * w + x];
        if (c < 0) return false;
        return [[1, 0], [-1, 0], [0, 1], [0, -1]].some(([dx, dy]) => {
          const xx = x + dx, yy = y + dy;
          return xx < 0 || yy < 0 || xx >= w || yy >= this.height || this.chart[yy * w + xx] !== c;
        });
      };
      return this.texelTexture((i) => {
        const x = i % w, y = (i - x) / w;
        if (outlines && border(x, y)) return OUTLINE;
        return checker && (x + y) % 2 ? CHECKER : [0, 0, 0, 0];
      });
    });
  }

  // An RGBA8 texture of one colour per texel, drawn texel by texel (nearest).
  texelTexture(colourOf) {
    const pixels = new Uint8Array(this.width * this.height * 4);
    for (let i = 0; i < this.width * this.height; i++) {
      const c = colourOf(i);
      pixels.set([c[0], c[1], c[2], c[3] ?? 255], i * 4);
    }
    const texture = this.viewer.atlasGrid.texture(pixels);
    texture.minFilter = texture.magFilter = THREE.NearestFilter;
    texture.userData.pixels = pixels;
    return texture;
  }

  cached(key, make) {
    if (!this.cache.has(key)) this.cache.set(key, make());
    return this.cache.get(key);
  }

  // Everything the bake holds about texel (x, y): chart, status, I (final and after pass k),
  // B, rho, E.
  probe(x, y, k) {
    const i = y * this.width + x;
    const rgb = (a) => Array.from(a.subarray(i * 3, i * 3 + 3));
    const values = { texel: [x, y], chart: this.chart[i], status: this.t.status_names[this.status[i]],
      I: this.incident(x, y, this.passes), B: rgb(this.excident), rho: rgb(this.rho), E: rgb(this.emission) };
    if (k < this.passes) values.pass = { k, I: this.incident(x, y, k) };
    return values;
  }

  // The 2-D atlas view: the overlay (incident light when shaded) in lightmap space, the marks
  // over it, and the probed texel.
  drawAtlas(canvas, overlay, exposure, k, marks, probed) {
    canvas.width = this.width;
    canvas.height = this.height;
    const ctx = canvas.getContext('2d');
    const image = ctx.createImageData(this.width, this.height);
    const mark = marks?.userData.pixels;
    for (let i = 0; i < this.width * this.height; i++) {
      let c;
      if (overlay === 'adaptive' || overlay === 'charts') c = this.overlayColour(overlay, i);
      else {
        const x = i % this.width;
        c = this.incident(x, (i - x) / this.width, k).map((v) => displayByte(v, exposure));
      }
      if (mark && mark[i * 4 + 3]) {
        const a = mark[i * 4 + 3] / 255;
        c = [0, 1, 2].map((j) => Math.round(c[j] * (1 - a) + mark[i * 4 + j] * a));
      }
      image.data.set([c[0], c[1], c[2], 255], i * 4);
    }
    if (probed) image.data.set([...PROBED, 255], (probed[1] * this.width + probed[0]) * 4);
    ctx.putImageData(image, 0, 0);
  }

  // [colour (CSS), meaning] pairs for what the surfaces show now.
  legend(overlay, checker, outlines) {
    const rgb = (c) => `rgb(${c.slice(0, 3).join(',')})`;
    const rows = [];
    if (overlay === 'adaptive') this.t.status_colours.forEach((c, s) => rows.push([rgb(c), this.t.status_names[s]]));
    if (overlay === 'charts') rows.push(['linear-gradient(90deg,#c66,#6c6,#66c)', 'one colour per UV chart']);
    if (overlay === 'light') rows.push(['linear-gradient(90deg,#000,#fff)', 'incident light I, exposed']);
    if (outlines) rows.push([rgb(OUTLINE), 'chart border texels']);
    if (checker) {
      const { atlases: n, width, height } = this.viewer.atlasGrid;
      const atlases = n > 1 ? `${n} atlases of ${width} x ${height}` : `${width} x ${height}`;
      rows.push([`rgba(0,0,0,${CHECKER[3] / 255})`, `every other texel (${atlases})`]);
      // each object's squares are its own texels: its density, as bake.json measured it
      for (const o of this.t.objects.slice(0, MAX_OBJECTS)) rows.push(['transparent', `${o.name}: ${o.texels_per_unit.toFixed(1)} texels/m`]);
      if (this.t.objects.length > MAX_OBJECTS) rows.push(['transparent', `... ${this.t.objects.length - MAX_OBJECTS} more objects`]);
    }
    return rows;
  }
}
