// The view from a patch: /scene/patch?x=&y= (patchlight/patchview.py, the bake's own gather)
// drawn with the viewer's exposure: the hemicube unfolded as a cross (or the stratified rays
// on the hemisphere) beside its multiplier map, with what each mark means.
import { displayByte, srgbByte } from './inspect.js';

const $ = (id) => document.getElementById(id);

export class PatchPanel {
  constructor(viewer) {
    this.viewer = viewer;
    this.view = null;
    this.loading = null;
  }

  // Fetch and draw the view from texel (x, y); resolves with the view (or its error).
  show(x, y) {
    $('patch-panel').hidden = false;
    $('patch-caption').textContent = `texel ${x},${y} ...`;
    this.loading = fetch(`/scene/patch?x=${x}&y=${y}`).then((r) => r.json()).then((view) => {
      this.view = view;
      this.draw();
      return view;
    });
    return this.loading;
  }

  draw() {
    const v = this.view;
    if (!v) return;
    if (v.error) { $('patch-caption').textContent = v.error; return; }
    const exposure = this.viewer.state.exposure;
    const peak = Math.max(...v.weight);
    this.paint($('patch-picture'), v, (i) => {
      const mark = v.marks[v.kind[i]];
      return mark ? mark.map(srgbByte) : [0, 1, 2].map((c) => displayByte(v.radiance[i * 3 + c], exposure));
    });
    this.paint($('patch-weights'), v, (i) => (v.kind[i] === v.background
      ? v.marks[v.background].map(srgbByte) : Array(3).fill(srgbByte(v.weight[i] / peak))));
    const g = v.gathered.map((c) => c.toPrecision(4)).join(', ');
    const n = v.counts;
    $('patch-caption').textContent = `texel ${v.texel.join(',')}: ${v.method} ${v.size}, ${v.rays} rays `
      + `(${n.sky} sky, ${n['back face']} back faces, ${n.lost} lost); gathered light ${g}`;
    const swatch = (code) => `rgb(${v.marks[code].map(srgbByte).join(',')})`;
    $('patch-legend').replaceChildren(...legendRows([[swatch(v.kinds['back face']), 'back face (leak or inside)'],
      [swatch(v.kinds.lost), 'lost hit (uncovered texel)'], ['#000', 'the rest: B of the patch seen, or the sky'],
      ['linear-gradient(90deg,#000,#fff)', 'right: multiplier map (weight / largest)']]));
  }

  paint(canvas, v, colourOf) {
    canvas.width = v.width;
    canvas.height = v.height;
    const ctx = canvas.getContext('2d');
    const image = ctx.createImageData(v.width, v.height);
    for (let i = 0; i < v.width * v.height; i++) image.data.set([...colourOf(i), 255], i * 4);
    ctx.putImageData(image, 0, 0);
  }
}

// Legend rows: a swatch and its meaning.
export function legendRows(rows) {
  return rows.map(([colour, text]) => {
    const row = document.createElement('div');
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = colour;
    row.append(swatch, ` ${text}`);
    return row;
  });
}
