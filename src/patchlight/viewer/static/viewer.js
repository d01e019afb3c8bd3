// The patchlight viewer: the scene bundle drawn with ShaderMaterials built from the GLSL
// chunks, an orbit camera, and controls for the model, exposure (per model, automatic on
// switching), options, lights, the bake's passes and debug overlays, the value probe, the
// view from a patch and an A/B split of two models.
// window.patchlight exposes the same renderer to tests (renderCase reads back the pixels).
import * as THREE from 'three';
import { AtlasGrid } from './atlas_grid.js';
import { constantTexture, loadBundle } from './bundle.js';
import { CameraRig } from './camera.js';
import { Inspector, OVERLAYS } from './inspect.js';
import { PatchPanel, legendRows } from './patchview.js';
import { engineSpecular, engineToneMapping, loadEngineScene } from './engine.js';
import { installVolume, volumeUniforms } from './ambient_cube.js';
import { GroundMapDemo, radiosityUniforms } from './groundmap.js';
import { ChunkLibrary } from './shaders.js';
import { skyDome } from './sky.js';

const $ = (id) => document.getElementById(id);

class Viewer {
  async init(canvas) {
    const chunks = new ChunkLibrary();
    const [bundle, vertexShader, fragmentShader, models, lightKinds, falloffs, displayGlsl] = await Promise.all([
      loadBundle(), chunks.program('surface_vertex.glsl'), chunks.program('surface_fragment.glsl'),
      chunks.names('MODEL'), chunks.names('LIGHT'), chunks.names('FALLOFF'), chunks.text('display.glsl')]);
    this.bundle = bundle;
    this.shaders = { vertexShader, fragmentShader };
    this.manifest = bundle.manifest;
    this.models = models;  // the ids of common.glsl's defines, as the uniforms take them
    this.lightKinds = lightKinds;
    this.falloffs = falloffs;
    this.maxLights = this.manifest.max_lights;
    const s = this.manifest.settings;
    this.state = {
      model: s.model, perVertex: s.per_vertex, normalMap: s.normal_map, lightmapSpecular: s.lightmap_specular,
      exposure: s.exposure, reflectivity: s.reflectivity, overlay: '', ambientCubeNaive: s.ambient_cube_naive,
      lights: this.manifest.lights.map((l) => ({ ...l })),
      exposures: {},  // exposure of each model (and of the incident-light overlay) once shown
      pass: 0, checker: false, outlines: false, split: '',
      engine: false,  // show scene.glb through three.js's materials and the GLTFLoader plugin
    };
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(1);
    this.renderer.setClearColor(0x000000, 0);
    this.atlasGrid = AtlasGrid.of(this.manifest, this.renderer.capabilities.maxTextureSize);
    if (!this.atlasGrid.fits) throw new Error(this.atlasGrid.refusal);
    this.uniforms = this.sharedUniforms();
    this.lightmapTexture = this.uniforms.lightmap.value;
    const compare = this.manifest.compare;  // a second bake's lightmap, for the A/B split
    this.compareTexture = compare && this.lightmapSpace(compare.lightmap);
    this.inspector = new Inspector(this);
    this.state.pass = this.inspector.passes;  // the final solution
    this.materials = this.manifest.materials.map((m) => this.material(m, vertexShader, fragmentShader));
    this.scene = new THREE.Scene();
    this.mesh = new THREE.Mesh(bundle.geometry(this.atlasGrid.uvs(bundle.array('uv1'))), this.materials);
    this.scene.add(this.mesh);
    this.engineScene = this.manifest.scene_glb ? await loadEngineScene() : null;
    if (this.engineScene) this.scene.add(this.engineScene);
    const sky = this.manifest.sky;  // the sky behind the scene: the env cube itself, or its own cube
    this.sky = skyDome(sky === this.manifest.env ? this.uniforms.env_map.value : sky && bundle.cube(sky),
      this.uniforms.exposure, displayGlsl);
    this.sky.visible = Boolean(sky);
    this.scene.add(this.sky);
    this.groundMap = new GroundMapDemo(this);  // cars lit by a ground map
    const [lo, hi] = this.manifest.bounds.map((v) => new THREE.Vector3(...v));
    this.radius = Math.max(lo.distanceTo(hi) / 2, 1e-3);
    this.camera = new THREE.PerspectiveCamera(45, 1, this.radius * 1e-3, this.radius * 100);
    this.rig = new CameraRig(this, canvas);
    this.controls = this.rig.controls;
    this.rig.reset();
    this.patch = new PatchPanel(this);
    this.apply();
    return this;
  }

  sharedUniforms() {
    const n = this.maxLights;
    const s = this.manifest.settings;
    const vec3s = () => Array.from({ length: n }, () => new THREE.Vector3());
    const lightmap = this.manifest.lightmap ? this.lightmapSpace(this.manifest.lightmap) : constantTexture([0, 0, 0, 1]);
    return {
      light_count: { value: 0 },
      light_kind: { value: new Array(n).fill(0) },
      light_position: { value: vec3s() },
      light_direction: { value: vec3s() },
      light_intensity: { value: vec3s() },
      light_range: { value: new Array(n).fill(0) },
      light_falloff: { value: new Array(n).fill(0) },
      light_cos_inner: { value: new Array(n).fill(1) },
      light_cos_outer: { value: new Array(n).fill(0) },
      ambient_color: { value: new THREE.Vector3(...s.ambient) },
      sky_color: { value: new THREE.Vector3(...s.sky) },
      ground_color: { value: new THREE.Vector3(...s.ground) },
      env_map: { value: this.bundle.cube(this.manifest.env) },
      lightmap: { value: lightmap },
      ...this.directionalUniforms(),
      exposure: { value: s.exposure },
      overlay_map: { value: constantTexture([0, 0, 0, 1]) },
      marks_map: { value: constantTexture([0, 0, 0, 0]) },
      ...radiosityUniforms(this.bundle, this.manifest.ground_map),
      ...volumeUniforms(this.bundle),
    };
  }

  // lightmap_directional.glsl's maps (black stand-ins without a directional bake).
  directionalUniforms() {
    const maps = this.manifest.directional?.maps ?? [];
    const uniforms = {};
    for (let k = 0; k < 4; k++) {
      uniforms[`directional_map${k}`] = { value: maps[k] ? this.lightmapSpace(maps[k]) : constantTexture([0, 0, 0, 1]) };
    }
    return uniforms;
  }

  // The bundle's array `name`, RGBA over the stacked atlases, as a texture the lightmap UVs address.
  lightmapSpace(name) {
    return this.atlasGrid.texture(this.bundle.array(name));
  }

  material(m, vertexShader, fragmentShader) {
    const map = (name, fallback) => (name ? this.bundle.texture(name) : constantTexture(fallback));
    const uniforms = {
      ...this.uniforms,  // the same objects in every material: one update reaches all
      base_color: { value: new THREE.Vector4(...m.base_color) },
      color_map: { value: map(m.color_map, [1, 1, 1, 1]) },
      emissive: { value: new THREE.Vector3(...m.emissive) },
      emissive_map: { value: map(m.emissive_map, [1, 1, 1, 1]) },
      normal_map: { value: map(m.normal_map, [0.5, 0.5, 1, 1]) },
      shininess: { value: m.shininess },
      reflectivity: { value: m.reflectivity },
    };
    const material = new THREE.ShaderMaterial({
      vertexShader, fragmentShader, uniforms, side: m.double_sided ? THREE.DoubleSide : THREE.FrontSide,
      toneMapped: false,  // display.glsl encodes; three.js's tone mapping is for the scene.glb view
    });
    material.userData.reflectivity = m.reflectivity;
    return material;
  }

  // A material without textures for an object the page adds (moving objects, probe cubes).
  plainMaterial(name, rgb, reflectivity) {
    const { vertexShader, fragmentShader } = this.shaders;
    return this.material({
      name, base_color: [...rgb, 1], emissive: [0, 0, 0], shininess: 32, reflectivity, double_sided: false,
      color_map: null, emissive_map: null, normal_map: null,
    }, vertexShader, fragmentShader);
  }

  // Push this.state into defines and uniforms.
  apply() {
    const st = this.state;
    const model = this.models.indexOf(st.model);
    if (model < 0) throw new Error(`unknown model ${st.model}`);
    const defines = { MODEL: model };
    if (st.perVertex) defines.PER_VERTEX = '';
    if (st.normalMap && !st.perVertex) defines.NORMAL_MAP = '';
    if (st.lightmapSpecular) defines.LIGHTMAP_SPECULAR = '';
    if (st.ambientCubeNaive) defines.AMBIENT_CUBE_NAIVE = '';
    if (this.manifest.directional?.mode === 'sh') defines.DIRECTIONAL_SH = '';
    if (st.overlay) defines.OVERLAY = '';
    if (st.overlay === 'light') defines.OVERLAY_LIGHT = '';
    const marks = this.inspector.marks(st.checker, st.outlines);
    if (marks) defines.MARKS = '';
    if (this.radianceOutput) defines.RADIANCE_OUTPUT = '';
    const key = JSON.stringify(defines);
    for (const material of this.materials) {
      if (material.userData.defines !== key) {
        material.defines = defines;
        material.userData.defines = key;
        material.needsUpdate = true;
      }
      material.uniforms.reflectivity.value = st.reflectivity ?? material.userData.reflectivity;
    }
    this.mesh.visible = !(st.engine && this.engineScene);
    if (this.engineScene) {
      this.engineScene.visible = !this.mesh.visible;
      engineSpecular(this.engineScene, st.lightmapSpecular);
    }
    engineToneMapping(this.renderer, this.mesh.visible ? null : st.exposure);
    const u = this.uniforms;
    u.exposure.value = st.exposure;
    u.lightmap.value = this.inspector.lightTexture(st.pass);
    if (st.overlay) u.overlay_map.value = this.inspector.overlayTexture(st.overlay, st.pass);
    if (marks) u.marks_map.value = marks;
    const lights = st.lights.slice(0, this.maxLights);
    u.light_count.value = lights.length;
    lights.forEach((l, i) => {
      u.light_kind.value[i] = this.lightKinds.indexOf(l.kind);
      u.light_position.value[i].set(...l.position);
      u.light_direction.value[i].set(...l.direction);
      u.light_intensity.value[i].set(...l.intensity);
      u.light_range.value[i] = l.range;
      u.light_falloff.value[i] = this.falloffs.indexOf(l.falloff);
      u.light_cos_inner.value[i] = l.cos_inner;
      u.light_cos_outer.value[i] = l.cos_outer;
    });
    this.onApply?.();
  }

  // What the exposure of the current view is kept under: the model, or the overlay of light values.
  exposureKey(model = this.state.model) {
    return this.state.overlay === 'light' ? 'overlay: incident light' : model;
  }

  // Show `model`: the exposure it had, or, the first time, the automatic one.
  switchModel(model) {
    this.switchView(() => { this.state.model = model; });
  }

  setOverlay(name) {
    this.switchView(() => { this.state.overlay = name; });
  }

  switchView(change) {
    const st = this.state;
    st.exposures[this.exposureKey()] = st.exposure;
    change();
    st.exposure = st.exposures[this.exposureKey()] ?? this.autoExposure();
    this.apply();
  }

  // The automatic exposure of the current view, stored for it.
  autoExposure() {
    const k = this.measureExposure();
    this.state.exposures[this.exposureKey()] = k;
    return k;
  }

  // The bake's `auto` rule (patchlight.imaging.exposure) on what the canvas shows: the view
  // drawn at linear radiance into a small float target, its lit luminances' percentile put
  // at the target display value (1 - exp(-k x)).
  measureExposure() {
    const rule = this.manifest.exposure_rule;
    const width = 64;
    const height = Math.max(1, Math.round(width / this.camera.aspect));
    const target = new THREE.WebGLRenderTarget(width, height, { type: THREE.FloatType });
    const sky = this.sky.visible;
    this.sky.visible = false;
    this.radianceOutput = true;
    this.apply();
    this.renderer.setRenderTarget(target);
    this.renderer.clear();
    this.renderer.render(this.scene, this.camera);
    const pixels = new Float32Array(width * height * 4);
    this.renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
    this.renderer.setRenderTarget(null);
    target.dispose();
    this.radianceOutput = false;
    this.sky.visible = sky;
    this.apply();
    const lit = [];
    for (let i = 0; i < width * height; i++) {
      const l = rule.luminance.reduce((sum, w, c) => sum + w * pixels[i * 4 + c], 0);
      if (pixels[i * 4 + 3] > 0 && l > 0) lit.push(l);
    }
    if (!lit.length) return 1;
    lit.sort((a, b) => a - b);
    const at = (lit.length - 1) * rule.percentile / 100;  // NumPy's linear percentile
    const lo = Math.floor(at);
    const value = lit[lo] + (lit[Math.min(lo + 1, lit.length - 1)] - lit[lo]) * (at - lo);
    return -Math.log(1 - rule.target) / value;
  }

  // The surface under a canvas position (NDC, y up): three's intersection, or null.
  pick(ndc) {
    const raycaster = new THREE.Raycaster();
    raycaster.setFromCamera(new THREE.Vector2(...ndc), this.camera);
    return raycaster.intersectObject(this.mesh, false)[0] ?? null;
  }

  // The value probe at a canvas position: the texel under it (lightmap UVs interpolated at
  // the hit) and, for a bake with texels.npz, everything the bake holds there; null on no surface.
  probe(ndc) {
    const hit = this.pick(ndc);
    if (!hit) return null;
    const g = this.mesh.geometry;
    const corners = [hit.face.a, hit.face.b, hit.face.c];
    const position = g.getAttribute('position');
    const [a, b, c] = corners.map((i) => new THREE.Vector3().fromBufferAttribute(position, i));
    const weights = THREE.Triangle.getBarycoord(hit.point, a, b, c, new THREE.Vector3()).toArray();
    const uv = this.bundle.array('uv1');  // stacked, as the texel arrays are
    const uv1 = [0, 1].map((k) => corners.reduce((sum, i, j) => sum + weights[j] * uv[i * 2 + k], 0));
    const result = { ndc, point: hit.point.toArray(), uv1, camera: this.cameraJson() };
    const t = this.inspector;
    if (t.t) {
      const x = Math.min(t.width - 1, Math.max(0, Math.floor(uv1[0] * t.width)));
      const y = Math.min(t.height - 1, Math.max(0, Math.floor(uv1[1] * t.height)));
      Object.assign(result, t.probe(x, y, this.state.pass));
    }
    return result;
  }

  cameraJson() {
    return { eye: this.camera.position.toArray(), target: this.controls.target.toArray(), fov: this.camera.fov,
      aspect: this.camera.aspect };
  }

  // Compare `model` (or '' for none; 'bake': the second bake's lightmap) on the right half
  // with the current model on the left.
  setSplit(model) {
    const st = this.state;
    if (model && model !== 'bake' && !(model in st.exposures) && this.exposureKey(model) === model) {
      const shown = st.model;
      st.exposures[this.exposureKey()] = st.exposure;
      st.model = model;
      this.autoExposure();
      st.model = shown;
      this.apply();
    }
    st.split = model;
  }

  // Look from eye at target exactly (tests); the controls orbit about target.
  setCamera(eye, target, fov) {
    this.rig.place(new THREE.Vector3(...eye), new THREE.Vector3(...target), fov);
  }

  setSize(width, height) {
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
  }

  // Render one frame; returns its time in milliseconds (GPU work included: a 1-pixel read waits for it).
  draw() {
    const start = performance.now();
    if (this.state.split) this.drawSplit();
    else this.renderer.render(this.scene, this.camera);
    const gl = this.renderer.getContext();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
    const ms = performance.now() - start;
    this.onFrame?.(ms);
    return ms;
  }

  // The current model on the left half, state.split on the right, each at its exposure (the
  // second bake: the same model and exposure with its lightmap).
  drawSplit() {
    const st = this.state;
    const { width, height } = this.renderer.getContext().canvas;
    const half = Math.floor(width / 2);
    const shown = { model: st.model, exposure: st.exposure };
    const bake = st.split === 'bake';
    this.renderer.setScissorTest(true);
    for (const [model, x, w] of [[shown.model, 0, half], [bake ? shown.model : st.split, half, width - half]]) {
      st.model = model;
      st.exposure = model === shown.model ? shown.exposure : st.exposures[this.exposureKey(model)] ?? shown.exposure;
      this.apply();
      if (bake && x > 0) this.uniforms.lightmap.value = this.compareTexture;
      this.renderer.setScissor(x, 0, w, height);
      this.renderer.render(this.scene, this.camera);
    }
    this.renderer.setScissorTest(false);
    Object.assign(st, shown);
    this.apply();
  }

  // The canvas as RGBA bytes, row 0 at the top.
  pixels() {
    const gl = this.renderer.getContext();
    const { width, height } = gl.canvas;
    const raw = new Uint8Array(width * height * 4);
    gl.readPixels(0, 0, width, height, gl.RGBA, gl.UNSIGNED_BYTE, raw);
    const rows = new Uint8Array(raw.length);
    const stride = width * 4;
    for (let y = 0; y < height; y++) rows.set(raw.subarray((height - 1 - y) * stride, (height - y) * stride), y * stride);
    return rows;
  }
}

// ------------------------------------------------------------------ page

function linearToHex(rgb) {
  const enc = (c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * c ** (1 / 2.4) - 0.055);
  return '#' + rgb.map((c) => Math.round(Math.min(1, Math.max(0, enc(c))) * 255).toString(16).padStart(2, '0')).join('');
}

function hexToLinear(hex) {
  const dec = (c) => (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);
  return [1, 3, 5].map((i) => dec(parseInt(hex.slice(i, i + 2), 16) / 255));
}

function bindControls(viewer, redraw) {
  const st = viewer.state;
  $('title').textContent = viewer.manifest.name;
  if (viewer.manifest.compare) $('split').add(new Option(`bake ${viewer.manifest.compare.name}`, 'bake'));
  for (const m of viewer.models) {
    $('model').add(new Option(m, m));
    $('split').add(new Option(m, m));
  }
  $('model').value = st.model;
  const inspector = viewer.inspector;
  const overlays = inspector.t ? Object.keys(OVERLAYS) : [];
  for (const name of overlays) $('surface').add(new Option(OVERLAYS[name], name));
  $('surface-row').hidden = overlays.length === 0;
  $('inspect-panel').hidden = !inspector.t;
  const notes = [];
  if (!viewer.manifest.lightmap) notes.push('no lightmap: the lightmap model shows black (view a bake directory)');
  if (viewer.manifest.lightmap && !viewer.manifest.directional) {
    notes.push('no directional lightmap: lightmap-directional shows the plain lightmap (bake with --directional)');
  }
  if (viewer.manifest.lightmap && !inspector.t) notes.push('this bake has no texels.npz: bake it again for passes, overlays, probe and patch view');
  if (viewer.manifest.env_note) notes.push(viewer.manifest.env_note);
  if (viewer.manifest.lights_dropped) notes.push(`${viewer.manifest.lights_dropped} lights beyond ${viewer.maxLights} not shown`);
  $('notes').textContent = notes.join('; ');
  const exposureLabel = () => {
    $('exposure').value = Math.log10(st.exposure);
    $('exposure-value').value = st.exposure.toPrecision(3);
    viewer.patch.draw();
  };
  exposureLabel();
  $('per-vertex').checked = st.perVertex;
  $('normal-map').checked = st.normalMap;
  $('lightmap-specular').checked = st.lightmapSpecular;
  $('engine-row').hidden = !viewer.engineScene;
  $('reflectivity-material').checked = st.reflectivity === null;
  $('reflectivity').value = st.reflectivity ?? 0.5;

  const change = (fn) => (event) => { fn(event); viewer.apply(); redraw(); };
  const inspected = () => { showInspection(viewer); exposureLabel(); };
  $('model').onchange = change(() => { viewer.switchModel($('model').value); inspected(); });
  $('surface').onchange = change(() => { viewer.setOverlay($('surface').value); inspected(); });
  $('exposure').oninput = change(() => {
    st.exposure = 10 ** Number($('exposure').value);
    st.exposures[viewer.exposureKey()] = st.exposure;
    exposureLabel();
    showInspection(viewer);
  });
  $('exposure-auto').onclick = change(() => { st.exposure = viewer.autoExposure(); inspected(); });
  $('split').onchange = change(() => {
    viewer.setSplit($('split').value);
    $('split-line').hidden = !viewer.state.split;
  });
  $('frame-all').onclick = () => { viewer.rig.frameAll(); redraw(); };
  $('camera-reset').onclick = () => { viewer.rig.reset(); redraw(); };
  $('pass').max = String(Math.max(1, inspector.passes));
  $('pass').value = String(st.pass);
  const passLabel = () => {
    $('pass-value').value = st.pass >= inspector.passes ? `${st.pass} of ${inspector.passes} (final)` : `${st.pass} of ${inspector.passes}`;
  };
  passLabel();
  $('pass').oninput = change(() => { st.pass = Number($('pass').value); passLabel(); showInspection(viewer); });
  $('checker').onchange = change(() => { st.checker = $('checker').checked; showInspection(viewer); });
  $('outlines').onchange = change(() => { st.outlines = $('outlines').checked; showInspection(viewer); });
  showInspection(viewer);
  $('per-vertex').onchange = change(() => {
    st.perVertex = $('per-vertex').checked;
    if (st.perVertex) { st.normalMap = false; $('normal-map').checked = false; }
  });
  $('normal-map').onchange = change(() => {
    st.normalMap = $('normal-map').checked;
    if (st.normalMap) { st.perVertex = false; $('per-vertex').checked = false; }
  });
  $('lightmap-specular').onchange = change(() => { st.lightmapSpecular = $('lightmap-specular').checked; });
  $('engine').onchange = change(() => { st.engine = $('engine').checked; });
  const reflectivity = change(() => {
    st.reflectivity = $('reflectivity-material').checked ? null : Number($('reflectivity').value);
  });
  $('reflectivity').oninput = reflectivity;
  $('reflectivity-material').onchange = reflectivity;

  bindLights(viewer, change);
}

// The legend of what the surfaces show, the atlas view and the probe's numbers, as they are now.
function showInspection(viewer) {
  const st = viewer.state;
  const t = viewer.inspector;
  if (!t.t) return;
  $('legend').replaceChildren(...legendRows(t.legend(st.overlay, st.checker, st.outlines)));
  const probed = viewer.probed?.texel ? viewer.inspector.probe(...viewer.probed.texel, st.pass) : null;
  t.drawAtlas($('atlas'), st.overlay, st.exposure, st.pass, t.marks(st.checker, st.outlines), probed?.texel);
  if (!viewer.probed) return;
  const v = { ...viewer.probed, ...probed };
  const rgb = (c) => c.map((x) => x.toPrecision(4)).join('  ');
  const lines = [`texel ${v.texel.join(',')}  chart ${v.chart}  ${v.status}`, `I    ${rgb(v.I)}`, `B    ${rgb(v.B)}`,
    `rho  ${rgb(v.rho)}`, `E    ${rgb(v.E)}`];
  if (v.pass) lines.push(`I after pass ${v.pass.k}: ${rgb(v.pass.I)}`);
  if (v.point) lines.push(`at   ${rgb(v.point)} m`);
  $('probe').textContent = lines.join('\n');
}

// Click: probe the texel under the pointer and view from its patch; double click: orbit about
// the point; the atlas view: click a texel to probe it.
function bindInspection(viewer, canvas, redraw) {
  const ndcOf = (event) => {
    const r = canvas.getBoundingClientRect();
    return [(event.clientX - r.left) / r.width * 2 - 1, 1 - (event.clientY - r.top) / r.height * 2];
  };
  let down = null;
  canvas.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
  canvas.addEventListener('pointerup', (e) => {
    if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 3 || e.button !== 0) return;
    inspectAt(viewer, viewer.probe(ndcOf(e)));
  });
  canvas.addEventListener('dblclick', (e) => { if (viewer.rig.pivotAt(ndcOf(e))) redraw(); });
  let hovered = null;  // the latest pointer position, probed once per animation frame
  canvas.addEventListener('pointermove', (e) => {
    if (e.buttons || !viewer.inspector.t) return;
    if (!hovered) requestAnimationFrame(() => { $('hover').textContent = hoverLine(viewer.probe(hovered)); hovered = null; });
    hovered = ndcOf(e);
  });
  $('atlas').addEventListener('click', (e) => {
    const t = viewer.inspector;
    const r = e.target.getBoundingClientRect();
    const x = Math.min(t.width - 1, Math.floor((e.clientX - r.left) / r.width * t.width));
    const y = Math.min(t.height - 1, Math.floor((e.clientY - r.top) / r.height * t.height));
    inspectAt(viewer, t.probe(x, y, viewer.state.pass));
  });
  window.addEventListener('keydown', (e) => {
    if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
    if (viewer.rig.key(e)) redraw();
  });
}

// One line about the texel under the pointer.
function hoverLine(v) {
  if (!v?.texel) return '';
  const rgb = (c) => c.map((x) => x.toPrecision(3)).join(' ');
  return `texel ${v.texel.join(',')}  chart ${v.chart}  ${v.status}  I ${rgb(v.I)}  B ${rgb(v.B)}`;
}

function inspectAt(viewer, probed) {
  viewer.probed = probed;
  if (!probed) { $('probe').textContent = 'no surface there'; return; }
  showInspection(viewer);
  if (probed.texel && probed.status !== 'uncovered') viewer.patch.show(...probed.texel);
}

// Aim of a light as the page shows it: azimuth (degrees from +Z towards +X) and elevation
// (degrees above the horizon; negative shines down) of the way it travels, and back.
function aimOf(direction) {
  const [x, y, z] = direction;
  const deg = (r) => Math.round(r * 180 / Math.PI * 100) / 100;
  const azimuth = Math.abs(x) + Math.abs(z) < 1e-9 ? 0 : Math.atan2(x, z);
  return [deg(azimuth), deg(Math.asin(Math.max(-1, Math.min(1, y))))];
}

function directionOf(azimuthDeg, elevationDeg) {
  const az = azimuthDeg * Math.PI / 180;
  const el = Math.max(-90, Math.min(90, elevationDeg)) * Math.PI / 180;
  return [Math.cos(el) * Math.sin(az), Math.sin(el), Math.cos(el) * Math.cos(az)];
}

const degreesOf = (cosine) => Math.round(Math.acos(Math.max(-1, Math.min(1, cosine))) * 180 / Math.PI * 100) / 100;
const cosineOf = (degrees) => Math.cos(degrees * Math.PI / 180);

// A new light of `kind` where the viewer looks from: at the camera, shining along the view,
// bright enough to give incident light 1 at the orbit target (J = pi d^2, E = pi).
function newLight(viewer, kind) {
  const eye = viewer.camera.position;
  const forward = viewer.controls.target.clone().sub(eye);
  const d = Math.max(forward.length(), 1e-3);
  forward.normalize();
  const strength = kind === 'directional' ? Math.PI : Math.PI * d * d;
  return {
    kind, position: eye.toArray(), direction: forward.toArray(), intensity: [strength, strength, strength],
    falloff: viewer.falloffs[0], range: 0, cos_inner: cosineOf(20), cos_outer: cosineOf(30),
  };
}

// The light panel: pick a light, add one of any kind, remove it; edit its position (point,
// spot), aim (directional, spot), colour, intensity, range and falloff (point, spot) and
// cone (spot). Kinds and falloffs are common.glsl's names, as the shaders number them.
function bindLights(viewer, change) {
  const st = viewer.state;
  for (const kind of viewer.lightKinds) $('light-kind').add(new Option(kind, kind));
  $('light-kind').value = 'point';
  for (const falloff of viewer.falloffs) $('light-falloff').add(new Option(falloff, falloff));
  const current = () => st.lights[Number($('light').value)];
  const listLights = (selected) => {
    $('light').replaceChildren(...st.lights.map((l, i) => new Option(`${i + 1}: ${l.kind}`, i)));
    if (st.lights.length) $('light').value = String(Math.min(selected, st.lights.length - 1));
    $('light-fields').hidden = st.lights.length === 0;
    $('light-remove').disabled = st.lights.length === 0;
    $('light-add').disabled = st.lights.length >= viewer.maxLights;
    showLight();
  };
  const showLight = () => {
    const l = current();
    if (!l) return;
    const peak = Math.max(...l.intensity);
    const directional = l.kind === 'directional';
    ['x', 'y', 'z'].forEach((axis, k) => { $(`light-${axis}`).value = l.position[k]; });
    const [azimuth, elevation] = aimOf(l.direction);
    $('light-azimuth').value = azimuth;
    $('light-elevation').value = elevation;
    $('light-color').value = linearToHex(l.intensity.map((c) => (peak > 0 ? c / peak : 1)));
    $('light-intensity').value = peak;
    $('light-range').value = l.range;
    $('light-falloff').value = l.falloff;
    $('light-inner').value = degreesOf(l.cos_inner);
    $('light-outer').value = degreesOf(l.cos_outer);
    $('light-position-row').hidden = directional;
    $('light-aim-row').hidden = l.kind === 'point';
    $('light-range-row').hidden = $('light-falloff-row').hidden = directional;
    $('light-cone-row').hidden = l.kind !== 'spot';
  };
  const edit = (fn) => change(() => { const l = current(); if (l) fn(l); });
  const position = edit((l) => { l.position = ['x', 'y', 'z'].map((axis) => Number($(`light-${axis}`).value)); });
  const aim = edit((l) => {
    l.direction = directionOf(Number($('light-azimuth').value), Number($('light-elevation').value));
  });
  const strength = edit((l) => {
    const colour = hexToLinear($('light-color').value);
    l.intensity = colour.map((c) => c * Math.max(0, Number($('light-intensity').value)));
  });
  const reach = edit((l) => {
    l.falloff = $('light-falloff').value;
    l.range = Math.max(0, Number($('light-range').value));
    if (l.falloff === 'range' && !(l.range > 0)) { l.range = viewer.radius; $('light-range').value = l.range; }
  });
  const cone = edit((l) => {
    const outer = Math.max(0, Math.min(90, Number($('light-outer').value)));
    const inner = Math.max(0, Math.min(outer, Number($('light-inner').value)));
    l.cos_outer = cosineOf(outer);
    l.cos_inner = cosineOf(inner);
  });
  $('light').onchange = showLight;
  for (const id of ['light-x', 'light-y', 'light-z']) $(id).oninput = position;
  for (const id of ['light-azimuth', 'light-elevation']) $(id).oninput = aim;
  $('light-intensity').oninput = strength;
  $('light-color').onchange = strength;
  $('light-range').onchange = reach;  // on commit: a half-typed "0" would take the default range
  $('light-falloff').onchange = reach;
  for (const id of ['light-inner', 'light-outer']) $(id).oninput = cone;
  $('light-add').onclick = change(() => {
    if (st.lights.length >= viewer.maxLights) return;
    st.lights.push(newLight(viewer, $('light-kind').value));
    listLights(st.lights.length - 1);
  });
  $('light-remove').onclick = change(() => {
    const i = Number($('light').value);
    if (!(i >= 0 && i < st.lights.length)) return;
    st.lights.splice(i, 1);
    listLights(i);
  });
  listLights(0);
}

async function main() {
  const canvas = $('view');
  const viewer = await new Viewer().init(canvas);
  const testing = new URLSearchParams(location.search).has('test');
  let pending = false;
  const redraw = () => {
    if (pending || testing) return;
    pending = true;
    requestAnimationFrame(() => { pending = false; viewer.draw(); });
  };
  const triangles = viewer.manifest.arrays.indices.shape[0];
  viewer.onFrame = (ms) => {
    const split = viewer.state.split === 'bake' ? `bake ${viewer.manifest.compare.name}` : viewer.state.split;
    $('stats').textContent = `${viewer.state.model}${split ? ` | ${split}` : ''}  ${ms.toFixed(1)} ms/frame  `
      + `${triangles} triangles`;
  };
  bindControls(viewer, redraw);
  bindInspection(viewer, canvas, redraw);
  viewer.groundMap.bindControls(redraw);
  const volume = installVolume(viewer, redraw, testing);
  const fit = () => { viewer.setSize(canvas.clientWidth, canvas.clientHeight); redraw(); };
  if (!testing) {
    window.addEventListener('resize', fit);
    viewer.controls.addEventListener('change', redraw);
    fit();
  }
  const patch = viewer.manifest.patch;
  if (patch) viewer.patch.show(...patch);
  window.patchlight = {
    viewer,
    volume,
    models: viewer.models,
    // The probe at a canvas position (NDC): what the click shows, and the patch view it loads.
    async probe(ndc) {
      inspectAt(viewer, viewer.probe(ndc));
      const view = viewer.probed?.texel && viewer.probed.status !== 'uncovered' ? await viewer.patch.loading : null;
      return { probe: viewer.probed, patch: view, text: $('probe').textContent };
    },
    // Look from eye at target (fov degrees) and draw.
    look({ eye, target, fov }) { viewer.setCamera(eye, target, fov); redraw(); },
    patchPixels: () => ['patch-picture', 'patch-weights'].map((id) => {
      const c = $(id);
      return { width: c.width, height: c.height, data: Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data) };
    }),
    // One frame of `spec` (model, per_vertex, normal_map, lightmap_specular, falloff, exposure,
    // reflectivity, overlay, pass (the passes slider; default the final), checker, sky (draw
    // the sky behind), engine (scene.glb through three.js's materials and the GLTFLoader
    // plugin), camera {eye, target, fov}, width,
    // height; lights: the lights to draw, as the manifest lists them (default: the manifest's),
    // or keep_lights: the lights as the controls left them); RGBA bytes, base64.
    renderCase(spec) {
      const st = viewer.state;
      st.model = spec.model;
      st.perVertex = Boolean(spec.per_vertex);
      st.normalMap = Boolean(spec.normal_map);
      st.lightmapSpecular = Boolean(spec.lightmap_specular);
      st.overlay = spec.overlay ?? '';
      st.pass = spec.pass ?? viewer.inspector.passes;
      st.checker = Boolean(spec.checker);
      st.engine = Boolean(spec.engine);
      if (spec.exposure !== undefined) st.exposure = spec.exposure;
      if (spec.reflectivity !== undefined) st.reflectivity = spec.reflectivity;
      viewer.groundMap.configure(spec.radiosity);
      st.ambientCubeNaive = Boolean(spec.ambient_cube_naive);
      const lights = spec.keep_lights ? st.lights : spec.lights ?? viewer.manifest.lights;
      st.lights = lights.map((l) => ({ ...l, falloff: (l.kind !== 'directional' && spec.falloff) || l.falloff }));
      // the pixel comparisons cover surfaces only (alpha 0 elsewhere), unless a case asks for the sky
      viewer.sky.visible = Boolean(spec.sky && viewer.manifest.sky);
      viewer.apply();
      viewer.setSize(spec.width, spec.height);
      viewer.setCamera(spec.camera.eye, spec.camera.target, spec.camera.fov);
      viewer.draw();
      const bytes = viewer.pixels();
      let binary = '';
      for (let i = 0; i < bytes.length; i += 0x8000) binary += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
      return btoa(binary);
    },
  };
  document.body.dataset.ready = 'true';
}

main().catch((error) => {
  console.error(error);
  document.body.dataset.ready = 'error';
  $('stats').textContent = `error: ${error.message}`;
});
