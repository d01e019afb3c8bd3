// ambient_cube.js: the light volume of ambient cubes in the viewer.
//
// volumeUniforms: the manifest's volume (bundle.py) as ambient_cube.glsl's uniforms: one 3D
// float RGBA texture of NX x NY x 6 NZ texels (axis a's probes in slices a NZ .. (a + 1) NZ - 1;
// RGB the axis' incident light, alpha the probe's validity, 0 inside geometry, which the
// shader's interpolation weights by), fetched exactly, and the grid's origin, spacing and dims.
//
// installVolume: a panel section with the naive / squared weights toggle and, when a baked
// volume is loaded, a sphere and a character-sized box moving through the scene lit by the
// volume (model ambient-cube, whatever model the scene itself shows), and the probes drawn as
// small cubes whose faces each show their axis' value (a face of normal +X at a probe is lit
// by exactly that probe's +X value). window.patchlight.volume drives them from tests.
import * as THREE from 'three';

const PERIOD = 24;             // seconds for one lap of the path
const PATH_SAMPLES = 256;      // floor heights precomputed along the path
const MAX_PROBE_CUBES = 20000; // beyond this the probes are thinned out evenly
const $ = (id) => document.getElementById(id);

export function volumeUniforms(bundle) {
  const v = bundle.manifest.volume;
  const [nx, ny, nz] = v.dims;
  const texture = new THREE.Data3DTexture(bundle.array(v.texture), nx, ny, 6 * nz);
  texture.format = THREE.RGBAFormat;
  texture.premultiplyAlpha = false; // alpha is the probe's validity, never to scale the RGB
  texture.type = THREE.FloatType;
  texture.minFilter = texture.magFilter = THREE.NearestFilter;
  texture.generateMipmaps = false;
  texture.colorSpace = THREE.NoColorSpace;
  texture.needsUpdate = true;
  return {
    ambient_cube_volume: { value: texture },
    ambient_cube_origin: { value: new THREE.Vector3(...v.origin) },
    ambient_cube_spacing: { value: new THREE.Vector3(...v.spacing) },
    ambient_cube_dims: { value: new THREE.Vector3(nx, ny, nz) },
  };
}

// The attributes surface_vertex.glsl reads that three's geometries lack.
function withSurfaceAttributes(geometry) {
  const n = geometry.attributes.position.count;
  const fill = (size, values) => {
    const a = new Float32Array(n * size);
    for (let i = 0; i < a.length; i++) a[i] = values[i % size];
    return new THREE.BufferAttribute(a, size);
  };
  geometry.setAttribute('lightmap_uv', fill(2, [0, 0]));
  geometry.setAttribute('surface_tangent', fill(4, [1, 0, 0, 1]));
  geometry.setAttribute('vertex_color', fill(4, [1, 1, 1, 1]));
  return geometry;
}

// One geometry of a small cube at every probe outside geometry.
function probeCubes(volume, insideFlags) {
  const [nx, ny, nz] = volume.dims;
  const size = 0.08 * Math.min(...volume.spacing);
  const cube = new THREE.BoxGeometry(size, size, size).toNonIndexed();
  const corners = cube.attributes.position.array;
  const normals = cube.attributes.normal.array;
  const total = nx * ny * nz;
  const stride = Math.max(1, Math.ceil(total / MAX_PROBE_CUBES));
  const probes = [];
  for (let i = 0; i < total; i += stride) if (!insideFlags[i]) probes.push(i);
  const position = new Float32Array(probes.length * corners.length);
  const normal = new Float32Array(probes.length * normals.length);
  probes.forEach((p, k) => {
    const at = [p % nx, Math.floor(p / nx) % ny, Math.floor(p / (nx * ny))]
      .map((index, axis) => volume.origin[axis] + index * volume.spacing[axis]);
    for (let j = 0; j < corners.length; j++) position[k * corners.length + j] = corners[j] + at[j % 3];
    normal.set(normals, k * normals.length);
  });
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(position, 3));
  g.setAttribute('normal', new THREE.BufferAttribute(normal, 3));
  g.setAttribute('uv', new THREE.BufferAttribute(new Float32Array(probes.length * 36 * 2), 2));
  return withSurfaceAttributes(g);
}

// The box the volume's probes span, and a closed path through its middle whose height
// follows the floor under it (the scene's highest surface below the middle height).
function makePath(volume, scene) {
  const lo = new THREE.Vector3(...volume.origin);
  const hi = new THREE.Vector3(...volume.dims.map((n, a) => volume.origin[a] + (n - 1) * volume.spacing[a]));
  const centre = lo.clone().add(hi).multiplyScalar(0.5);
  const extent = hi.clone().sub(lo);
  const raycaster = new THREE.Raycaster();
  const down = new THREE.Vector3(0, -1, 0);
  const samples = [];
  for (let k = 0; k < PATH_SAMPLES; k++) {
    const angle = (2 * Math.PI * k) / PATH_SAMPLES;
    const x = centre.x + 0.3 * extent.x * Math.cos(angle);
    const z = centre.z + 0.3 * extent.z * Math.sin(angle);
    raycaster.set(new THREE.Vector3(x, centre.y, z), down);
    const hit = raycaster.intersectObjects(scene.children, false)[0];
    samples.push(new THREE.Vector3(x, hit ? hit.point.y : lo.y, z));
  }
  return { samples, scale: Math.min(1, extent.y / 3) };
}

class VolumeShow {
  constructor(viewer, testing) {
    this.viewer = viewer;
    this.group = new THREE.Group();
    this.materials = [];
    const volume = viewer.manifest.volume;
    this.path = makePath(volume, viewer.scene);
    const s = this.path.scale;
    this.sphere = new THREE.Mesh(withSurfaceAttributes(new THREE.SphereGeometry(0.25 * s, 64, 32)),
      this.material('volume sphere', [0.8, 0.8, 0.8], 0.25));
    this.box = new THREE.Mesh(withSurfaceAttributes(new THREE.BoxGeometry(0.5 * s, 1.8 * s, 0.3 * s)),
      this.material('volume box', [0.7, 0.7, 0.7], 0));
    this.probes = new THREE.Mesh(probeCubes(volume, viewer.bundle.array(volume.inside)),
      this.material('volume probes', [1, 1, 1], 0));
    this.group.add(this.sphere, this.box);
    this.probes.visible = false;
    this.group.visible = !testing;
    viewer.scene.add(this.group, this.probes);
    this.moving = !testing;
    this.setTime(0);
  }

  material(name, rgb, reflectivity) {
    const m = this.viewer.plainMaterial(name, rgb, reflectivity);
    this.materials.push(m);
    return m;
  }

  // Model ambient-cube on every object, with the viewer's choice of weights.
  sync() {
    const defines = { MODEL: this.viewer.models.indexOf('ambient-cube') };
    if (this.viewer.state.ambientCubeNaive) defines.AMBIENT_CUBE_NAIVE = '';
    const key = JSON.stringify(defines);
    for (const m of this.materials) {
      if (m.userData.defines !== key) {
        m.defines = defines;
        m.userData.defines = key;
        m.needsUpdate = true;
      }
    }
  }

  // Place the objects at time t (seconds) along their path: the sphere floats at 1.2 m, the
  // box stands on the floor half a lap behind, facing where it walks.
  setTime(t) {
    const { samples, scale } = this.path;
    const at = (u) => {
      const x = ((u % 1) + 1) % 1 * PATH_SAMPLES;
      const k = Math.floor(x);
      return samples[k].clone().lerp(samples[(k + 1) % PATH_SAMPLES], x - k);
    };
    const u = t / PERIOD;
    this.sphere.position.copy(at(u)).add(new THREE.Vector3(0, 1.2 * scale, 0));
    const feet = at(u + 0.5);
    this.box.position.copy(feet).add(new THREE.Vector3(0, 0.9 * scale, 0));
    const ahead = at(u + 0.5 + 1 / PATH_SAMPLES);
    this.box.rotation.y = Math.atan2(ahead.x - feet.x, ahead.z - feet.z);
  }
}

function addControls(viewer, show, redraw) {
  const box = document.createElement('fieldset');
  box.id = 'volume-panel';
  const baked = Boolean(show);
  box.innerHTML = `<legend>light volume${baked ? '' : ' (none baked: the sky as one probe)'}</legend>
    <label><input id="volume-naive" type="checkbox"> naive weights saturate(n)</label>` + (baked ? `
    <label><input id="volume-objects" type="checkbox"> moving sphere and box</label>
    <label><input id="volume-probes" type="checkbox"> probes as cubes</label>` : '');
  $('notes').before(box);
  $('volume-naive').checked = viewer.state.ambientCubeNaive;
  $('volume-naive').onchange = () => { viewer.state.ambientCubeNaive = $('volume-naive').checked; viewer.apply(); redraw(); };
  if (!baked) return;
  $('volume-objects').checked = show.group.visible;
  $('volume-probes').checked = show.probes.visible;
  const tick = (now) => {
    if (!show.moving) return;
    show.setTime(now / 1000);
    redraw();
    requestAnimationFrame(tick);
  };
  $('volume-objects').onchange = () => {
    show.group.visible = show.moving = $('volume-objects').checked;
    if (show.moving) requestAnimationFrame(tick);
    redraw();
  };
  $('volume-probes').onchange = () => { show.probes.visible = $('volume-probes').checked; redraw(); };
  if (show.moving) requestAnimationFrame(tick);
}

// Add the volume's objects and controls to a running viewer; returns the test interface.
export function installVolume(viewer, redraw, testing) {
  const show = viewer.manifest.volume.baked ? new VolumeShow(viewer, testing) : null;
  if (show) {
    viewer.onApply = () => show.sync();
    show.sync();
  }
  addControls(viewer, show, redraw);
  return {
    baked: Boolean(show),
    setTime: (t) => show?.setTime(t),
    showObjects: (visible) => { if (show) show.group.visible = visible; },
    showProbes: (visible) => { if (show) show.probes.visible = visible; },
    // Where the objects are: sphere centre and radius, box centre, size and turn about +Y.
    objects: () => (show ? {
      sphere: { center: show.sphere.position.toArray(), radius: show.sphere.geometry.parameters.radius },
      box: { center: show.box.position.toArray(), rotation: show.box.rotation.y,
        size: ['width', 'height', 'depth'].map((k) => show.box.geometry.parameters[k]) },
    } : null),
  };
}
