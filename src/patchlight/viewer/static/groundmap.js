// Hemisphere lighting with a radiosity ground map in the viewer (patchlight/ground/viewer.py,
// shaders/hemisphere_radiosity.glsl): the model's uniforms for every material and, when a
// baked ground map came with the scene, cars driving a loop lit by it, with controls that
// switch the map (PNG texels, block-compressed texels, none), its shadow encoding and the
// sample offset live.
import * as THREE from 'three';
import { constantTexture } from './bundle.js';

const CAR_COLOURS = [[0.70, 0.04, 0.03], [0.05, 0.18, 0.65], [0.85, 0.62, 0.05], [0.06, 0.45, 0.12],
  [0.80, 0.80, 0.78], [0.10, 0.10, 0.11]];
const SPEED = 22;          // metres per second along the loop
const CAR_REFLECTIVITY = 0.6;  // paint: the listing's per-vertex reflectivity, here per material
const GLASS = [[0.04, 0.05, 0.06], 0.9];
const TYRES = [[0.03, 0.03, 0.03], 0.05];
const $ = (id) => document.getElementById(id);

// The hemisphere-radiosity uniforms from the bundle's ground_map entry (float textures: the
// CPU reference samples exactly these texels).
export function radiosityUniforms(bundle, g) {
  return {
    radiosity_map: { value: bundle.texture(g.map, THREE.ClampToEdgeWrapping) },
    radiosity_shadow_map: { value: bundle.texture(g.shadow_map, THREE.ClampToEdgeWrapping) },
    radiosity_u: { value: new THREE.Vector4(...g.U) },
    radiosity_v: { value: new THREE.Vector4(...g.V) },
    radiosity_encoding: { value: g.encoding },
    radiosity_offset_mode: { value: g.offset_mode },
    radiosity_offset: { value: g.offset },
    radiosity_side: { value: new THREE.Vector3(...g.side) },
    radiosity_sky_scale: { value: new THREE.Vector3(...g.sky_scale) },
    radiosity_neutral: { value: g.neutral },
    fog_color: { value: new THREE.Vector3(...g.fog_color) },
    fog_range: { value: new THREE.Vector2(...g.fog_range) },
  };
}

// A car along +Z (glTF's front), +X to its right, wheels on y = 0: body, cabin and wheels
// as smooth shapes, so the hemisphere tween and the offset lookups vary over them.
function carGeometry() {
  const parts = [
    [new THREE.SphereGeometry(1, 32, 16), [0.95, 0.42, 2.2], [0, 0.62, 0], 0],
    [new THREE.SphereGeometry(1, 24, 12), [0.72, 0.38, 1.05], [0, 1.0, -0.25], 1],
  ];
  for (const [x, z] of [[-0.85, 1.35], [0.85, 1.35], [-0.85, -1.35], [0.85, -1.35]]) {
    const wheel = new THREE.CylinderGeometry(0.34, 0.34, 0.26, 16).rotateZ(Math.PI / 2);
    parts.push([wheel, [1, 1, 1], [x, 0.34, z], 2]);
  }
  const merged = { position: [], normal: [], uv: [], index: [], groups: [] };
  for (const [g, scale, offset, material] of parts) {
    g.applyMatrix4(new THREE.Matrix4().makeScale(...scale)).translate(...offset);
    const base = merged.position.length / 3;
    const start = merged.index.length;
    merged.position.push(...g.attributes.position.array);
    merged.normal.push(...g.attributes.normal.array);
    merged.uv.push(...g.attributes.uv.array);
    merged.index.push(...g.index.array.map((i) => i + base));
    merged.groups.push([start, merged.index.length - start, material]);
  }
  const n = merged.position.length / 3;
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.Float32BufferAttribute(merged.position, 3));
  geometry.setAttribute('normal', new THREE.Float32BufferAttribute(merged.normal, 3));
  geometry.setAttribute('uv', new THREE.Float32BufferAttribute(merged.uv, 2));
  geometry.setAttribute('lightmap_uv', new THREE.Float32BufferAttribute(new Float32Array(n * 2), 2));
  geometry.setAttribute('surface_tangent', new THREE.Float32BufferAttribute(
    Float32Array.from({ length: n * 4 }, (_, i) => (i % 4 === 0 || i % 4 === 3 ? 1 : 0)), 4));
  geometry.setAttribute('vertex_color', new THREE.Float32BufferAttribute(new Float32Array(n * 4).fill(1), 4));
  geometry.setIndex(merged.index);
  for (const [start, count, material] of merged.groups) geometry.addGroup(start, count, material);
  geometry.computeBoundingSphere();
  return geometry;
}

// A closed polyline (K, 3) walked by arc length.
class Loop {
  constructor(points) {
    this.points = points.map((p) => new THREE.Vector3(...p));
    this.lengths = [0];
    for (let i = 0; i < this.points.length; i++) {
      const next = this.points[(i + 1) % this.points.length];
      this.lengths.push(this.lengths[i] + this.points[i].distanceTo(next));
    }
    this.total = this.lengths[this.lengths.length - 1];
  }

  // Position and unit forward direction at distance s along the loop.
  at(s) {
    const d = ((s % this.total) + this.total) % this.total;
    let i = 0;
    while (this.lengths[i + 1] < d) i++;
    const a = this.points[i];
    const b = this.points[(i + 1) % this.points.length];
    const f = (d - this.lengths[i]) / Math.max(this.lengths[i + 1] - this.lengths[i], 1e-9);
    return [a.clone().lerp(b, f), b.clone().sub(a).normalize()];
  }
}

export class GroundMapDemo {
  constructor(viewer) {
    this.viewer = viewer;
    this.g = viewer.manifest.ground_map;
    this.uniforms = viewer.uniforms;
    this.textures = new Map();
    this.state = { map: 'png', encoding: this.g.encodings[this.g.encoding], offsetMode: this.g.offset_modes[this.g.offset_mode],
      offset: this.g.offset, fog: this.g.fog_range[1] > this.g.fog_range[0], drive: true };
    this.cars = [];
    if (this.g.baked && this.g.path) this.addCars();
  }

  // The cars: the viewer's own material (model hemisphere-radiosity, lit per vertex as the
  // listing does), each car with its side vector.
  addCars() {
    const geometry = carGeometry();
    this.loop = new Loop(this.g.path);
    const defines = { MODEL: this.viewer.models.indexOf('hemisphere-radiosity'), PER_VERTEX: '' };
    CAR_COLOURS.forEach((colour, k) => {
      const side = { value: new THREE.Vector3(1, 0, 0) };
      const material = ([rgb, reflectivity], part) => {
        const m = this.viewer.plainMaterial(`car ${k} ${part}`, rgb, reflectivity);
        m.defines = defines;
        m.uniforms.radiosity_side = side;
        return m;
      };
      const mesh = new THREE.Mesh(geometry, [material([colour, CAR_REFLECTIVITY], 'paint'), material(GLASS, 'glass'),
        material(TYRES, 'tyres')]);
      mesh.userData = { side, distance: k * this.loop.total / CAR_COLOURS.length };
      this.viewer.scene.add(mesh);
      this.cars.push(mesh);
    });
    this.place(0);
  }

  // Put every car `dt` seconds further along the loop, facing along it; its side vector is
  // its local +X in world space.
  place(dt) {
    for (const car of this.cars) {
      car.userData.distance += SPEED * dt;
      const [position, forward] = this.loop.at(car.userData.distance);
      car.position.copy(position);
      car.rotation.set(0, Math.atan2(forward.x, forward.z), 0);
      car.userData.side.value.set(forward.z, 0, -forward.x);
    }
  }

  texture(name) {
    if (!this.textures.has(name)) this.textures.set(name, this.viewer.bundle.texture(name, THREE.ClampToEdgeWrapping));
    return this.textures.get(name);
  }

  // Push this.state into the shared uniforms.
  apply() {
    const st = this.state;
    const u = this.uniforms;
    const g = this.g;
    u.radiosity_offset_mode.value = g.offset_modes.indexOf(st.offsetMode);
    u.radiosity_offset.value = st.offset;
    u.fog_range.value.set(...(st.fog ? g.fog_range : [0, 0]));
    if (st.map === 'none' || !g.baked) {  // the plain hemisphere: ground.py's neutral_ground_map
      const s = this.viewer.manifest.settings;
      const scale = Math.max(...s.sky, ...s.ground, 1e-6);
      u.radiosity_map.value = constantTexture([...s.ground.map((c) => c / scale), 1]);
      u.radiosity_shadow_map.value = constantTexture([1, 1, 1, 1]);
      u.radiosity_encoding.value = g.encodings.indexOf('alpha');
      u.radiosity_sky_scale.value.set(...s.sky.map((c) => c / scale));
      u.radiosity_neutral.value = 0.5 * scale;
      return;
    }
    const v = g.variants[`${st.encoding}-${st.map}`];
    u.radiosity_map.value = this.texture(v.map);
    u.radiosity_shadow_map.value = v.shadow_map ? this.texture(v.shadow_map) : constantTexture([1, 1, 1, 1]);
    u.radiosity_encoding.value = g.encodings.indexOf(st.encoding);
    u.radiosity_sky_scale.value.set(...v.sky_scale);
    u.radiosity_neutral.value = v.neutral;
  }

  // Tests: set the uniforms as the CPU reference's GroundMapInputs.with_options(...) does;
  // variant "<encoding>-<png|dds>" picks one of the bundle's maps first.
  configure(options = {}) {
    const u = this.uniforms;
    if (options.variant !== undefined) {
      [this.state.encoding, this.state.map] = options.variant.split('-');
      this.apply();
    }
    if (options.offset_mode !== undefined) u.radiosity_offset_mode.value = this.g.offset_modes.indexOf(options.offset_mode);
    if (options.offset !== undefined) u.radiosity_offset.value = options.offset;
    if (options.side !== undefined) u.radiosity_side.value.set(...options.side);
    if (options.fog_color !== undefined) u.fog_color.value.set(...options.fog_color);
    if (options.fog_range !== undefined) u.fog_range.value.set(...options.fog_range);
    for (const car of this.cars) car.visible = Boolean(options.cars);
  }

  bindControls(redraw) {
    if (!this.g.baked) return;
    const panel = document.createElement('fieldset');
    panel.id = 'ground-map-panel';
    const options = (values) => values.map((v) => `<option>${v}</option>`).join('');
    panel.innerHTML = `<legend>ground map</legend>
      <label>map <select id="gm-map">${options(['png', 'dds', 'none'])}</select></label>
      <label>shadows <select id="gm-encoding">${options(this.g.encodings)}</select></label>
      <label>offset <select id="gm-offset-mode">${options(this.g.offset_modes)}</select>
        <input id="gm-offset" type="range" min="0" max="4" step="0.1"></label>
      <label><input id="gm-fog" type="checkbox"> fog</label>
      <label><input id="gm-drive" type="checkbox"> cars drive</label>`;
    $('notes').before(panel);
    const st = this.state;
    $('gm-map').value = st.map;
    $('gm-encoding').value = st.encoding;
    $('gm-offset-mode').value = st.offsetMode;
    $('gm-offset').value = st.offset;
    $('gm-fog').checked = st.fog;
    $('gm-drive').checked = st.drive;
    const change = (fn) => () => { fn(); this.apply(); redraw(); };
    $('gm-map').onchange = change(() => { st.map = $('gm-map').value; });
    $('gm-encoding').onchange = change(() => { st.encoding = $('gm-encoding').value; });
    $('gm-offset-mode').onchange = change(() => { st.offsetMode = $('gm-offset-mode').value; });
    $('gm-offset').oninput = change(() => { st.offset = Number($('gm-offset').value); });
    $('gm-fog').onchange = change(() => { st.fog = $('gm-fog').checked; });
    $('gm-drive').onchange = () => { st.drive = $('gm-drive').checked; this.run(redraw); };
    if (!new URLSearchParams(location.search).has('test')) this.run(redraw);
  }

  // Drive the cars while `drive` is on, drawing a frame each step.
  run(redraw) {
    if (!this.cars.length || this.running) return;
    this.running = true;
    let last = performance.now();
    const step = (now) => {
      if (!this.state.drive) { this.running = false; return; }
      this.place(Math.min((now - last) / 1000, 0.1));
      last = now;
      redraw();
      requestAnimationFrame(step);
    };
    requestAnimationFrame(step);
  }
}
