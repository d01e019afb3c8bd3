// The viewer's camera: OrbitControls about a pivot at the scene's depth (the scene's centre
// projected on the line of sight, or a point picked with a double click), so a drag turns
// the scene, not the eye, and the wheel zooms by a share of the distance; frame-all and reset;
// first-person keys (W A S D forward, left, back, right; Q E down, up; Shift: 5 x faster).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const STEP = 0.02;          // a key press moves the eye this share of the scene's radius
const NEAREST_PIVOT = 0.05; // the pivot lies at least this share of the radius ahead of the eye

export class CameraRig {
  constructor(viewer, canvas) {
    this.viewer = viewer;
    this.camera = viewer.camera;
    const [lo, hi] = viewer.manifest.bounds.map((v) => new THREE.Vector3(...v));
    this.centre = lo.clone().add(hi).multiplyScalar(0.5);
    this.radius = viewer.radius;
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.zoomToCursor = false;
    this.controls.minDistance = this.radius * 1e-3;
    this.controls.maxDistance = this.radius * 50;
  }

  // Look from `eye` towards `target` (fov in degrees), orbiting about the point of the line of
  // sight nearest the scene's centre.
  view(eye, target, fov) {
    const from = new THREE.Vector3(...eye);
    const forward = new THREE.Vector3(...target).sub(from).normalize();
    const depth = Math.max(this.centre.clone().sub(from).dot(forward), NEAREST_PIVOT * this.radius);
    this.place(from, from.clone().addScaledVector(forward, depth), fov);
  }

  place(eye, pivot, fov = this.camera.fov) {
    this.camera.fov = fov;
    this.camera.position.copy(eye);
    this.controls.target.copy(pivot);
    this.camera.lookAt(pivot);
    this.camera.updateProjectionMatrix();
    this.controls.update();
  }

  // The whole scene (its bounding sphere) in view along the current line of sight.
  frameAll() {
    const forward = this.controls.target.clone().sub(this.camera.position).normalize();
    const vertical = THREE.MathUtils.degToRad(this.camera.fov) / 2;
    const half = Math.min(vertical, Math.atan(Math.tan(vertical) * this.camera.aspect));
    const distance = this.radius / Math.sin(half);
    this.place(this.centre.clone().addScaledVector(forward, -distance), this.centre.clone());
  }

  reset() {
    const c = this.viewer.manifest.camera;
    this.view(c.eye, c.target, c.fov);
  }

  // Orbit about the surface point under the canvas position (NDC), keeping the eye.
  pivotAt(ndc) {
    const hit = this.viewer.pick(ndc);
    if (hit) this.place(this.camera.position.clone(), hit.point);
    return Boolean(hit);
  }

  // Move eye and pivot together by a first-person key; true when the key is one of them.
  key(event) {
    const moves = { w: [0, 0, 1], s: [0, 0, -1], a: [-1, 0, 0], d: [1, 0, 0], q: [0, -1, 0], e: [0, 1, 0] };
    const move = moves[event.key.toLowerCase()];
    if (!move) return false;
    const forward = this.controls.target.clone().sub(this.camera.position).normalize();
    const right = forward.clone().cross(this.camera.up).normalize();
    const step = STEP * this.radius * (event.shiftKey ? 5 : 1);
    const delta = right.multiplyScalar(move[0] * step).add(this.camera.up.clone().multiplyScalar(move[1] * step))
      .addScaledVector(forward, move[2] * step);
    this.camera.position.add(delta);
    this.controls.target.add(delta);
    this.controls.update();
    return true;
  }
}
