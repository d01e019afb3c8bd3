// Fetches the GLSL chunks from /shaders/ (patchlight/shaders/, the single source of the
// lighting models) and resolves their `#include "file.glsl"` lines, each file once, so
// three.js's ShaderMaterial receives plain GLSL.

const INCLUDE = /^[ \t]*#include[ \t]+"([\w.]+)"[ \t]*$/gm;

export class ChunkLibrary {
  constructor() {
    this.texts = new Map();
  }

  async text(name) {
    if (!this.texts.has(name)) {
      this.texts.set(name, fetch(`/shaders/${name}`).then((response) => {
        if (!response.ok) throw new Error(`shader chunk ${name}: HTTP ${response.status}`);
        return response.text();
      }));
    }
    return this.texts.get(name);
  }

  // The entry chunk with every include replaced by the included file (each file once).
  async program(entry, seen = new Set()) {
    if (seen.has(entry)) return '';
    seen.add(entry);
    const text = await this.text(entry);
    let out = '';
    let last = 0;
    for (const match of text.matchAll(INCLUDE)) {
      out += text.slice(last, match.index) + await this.program(match[1], seen);
      last = match.index + match[0].length;
    }
    return out + text.slice(last);
  }

  // Names by id from common.glsl's PREFIX_* defines: names('MODEL') turns MODEL_BLINN_PHONG 4
  // into "blinn-phong" at index 4; 'LIGHT' gives the light kinds, 'FALLOFF' the falloffs.
  async names(prefix) {
    const text = await this.text('common.glsl');
    const names = [];
    for (const [, name, id] of text.matchAll(new RegExp(`^#define[ \\t]+${prefix}_(\\w+)[ \\t]+(\\d+)`, 'gm'))) {
      names[Number(id)] = name.toLowerCase().replaceAll('_', '-');
    }
    return names;
  }
}
