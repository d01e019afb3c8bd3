"""The built-in outdoor scene `track`: the ground-map demo: a race
track seen by fast moving cars, lit by hemisphere lighting with a radiosity ground map.

A 160 x 160 m grass field (x, z in [-80, 80], +Y up) holding:
- a closed asphalt loop, 12 m wide: two 80 m straights along x at z = +-25 joined by two
  half circles of radius 25 m around (+-40, 0); its centre line is `track_centerline()`,
  the path the viewer's cars drive;
- rumble strips 1.2 m wide on both edges, red and white alternating every ~3 m;
- a forest of box-canopy trees in the infield and one in the north-west corner: each canopy
  is a cluster of leaf blocks with gaps between them, so the sun throws dappled shadows;
- fences (1.2 m sponsor boards) between the main straight and the pits and along the back
  straight;
- buildings: a low pit building (2.8 m, below the ground map's default max_height, so its
  colours reach the map), a tall grandstand and two houses, and four 12 m floodlight poles;
- a sun 45 degrees up and a blue gradient sky.

About 6,000 triangles. Bake it coarsely, e.g. `patchlight bake track -o out/track
--texels-per-unit 2` (`patchlight groundmap track` does so by itself).
"""
from __future__ import annotations

import numpy as np

from .builtin import SceneBuilder
from .model import Light, Scene
from .sky import Sky

FIELD = 80.0            # half size of the grass field, metres
STRAIGHT = 40.0         # half length of each straight
RADIUS = 25.0           # centre-line radius of the bends
HALF_WIDTH = 6.0        # half width of the asphalt
RUMBLE = 1.2            # rumble strip width
SEGMENT = 3.0           # rumble strip length (one colour)
ASPHALT_Y, RUMBLE_Y = 0.02, 0.04  # lifted off the grass so the surfaces never coincide
SUN_DIRECTION = (0.45, -0.72, 0.53)  # the way sunlight travels, about 46 degrees up
SEED = 7


def track_centerline(spacing: float = SEGMENT) -> np.ndarray:
    """(K, 3) points of the closed centre line at y = 0, counter-clockwise seen from above
    (+X right, +Z down the map), about `spacing` metres apart; the last point is not repeated."""
    straight = 2 * STRAIGHT
    bend = np.pi * RADIUS
    n_straight = max(1, round(straight / spacing))
    n_bend = max(2, round(bend / spacing))
    pts = []
    for x in np.linspace(-STRAIGHT, STRAIGHT, n_straight, endpoint=False):   # z = +25, going +x
        pts.append((x, RADIUS))
    for a in np.linspace(np.pi / 2, -np.pi / 2, n_bend, endpoint=False):      # right bend
        pts.append((STRAIGHT + RADIUS * np.cos(a), RADIUS * np.sin(a)))
    for x in np.linspace(STRAIGHT, -STRAIGHT, n_straight, endpoint=False):   # z = -25, going -x
        pts.append((x, -RADIUS))
    for a in np.linspace(-np.pi / 2, -3 * np.pi / 2, n_bend, endpoint=False):  # left bend
        pts.append((-STRAIGHT + RADIUS * np.cos(a), RADIUS * np.sin(a)))
    xz = np.array(pts, np.float64)
    return np.stack([xz[:, 0], np.zeros(len(xz)), xz[:, 1]], axis=1)


def _edge_offsets(center: np.ndarray) -> np.ndarray:
    """(K, 3) unit horizontal vectors pointing outward-left of the direction of travel at
    each centre-line point (the mean of the two adjoining segments' normals)."""
    forward = np.roll(center, -1, axis=0) - np.roll(center, 1, axis=0)
    forward /= np.linalg.norm(forward, axis=1, keepdims=True)
    return np.cross(forward, [0.0, 1.0, 0.0])


def _strip(b: SceneBuilder, center, side, inner: float, outer: float, y: float, materials) -> None:
    """Quads between offsets inner..outer along the loop, cycling through `materials`."""
    k = len(center)
    for i in range(k):
        j = (i + 1) % k
        corners = [center[i] + side[i] * inner, center[j] + side[j] * inner,
                   center[j] + side[j] * outer, center[i] + side[i] * outer]
        corners = [(c[0], y, c[2]) for c in corners]
        b.quad(corners, materials[i % len(materials)], (0, 1, 0))


def _oriented_box(b: SceneBuilder, a, c, height: float, thickness: float, material: int) -> None:
    """A wall of `thickness` from ground point a to ground point c (each (x, z)), `height` tall."""
    a, c = np.asarray(a, np.float64), np.asarray(c, np.float64)
    along = (c - a) / np.linalg.norm(c - a)
    across = np.array([-along[1], along[0]]) * thickness / 2
    foot = [a - across, c - across, c + across, a + across]
    bottom = [(p[0], 0.0, p[1]) for p in foot]
    top = [(p[0], height, p[1]) for p in foot]
    b.quad(top, material, (0, 1, 0))
    for i in range(4):
        j = (i + 1) % 4
        mid = (np.asarray(bottom[i]) + bottom[j]) / 2
        outward = mid - np.array([(a[0] + c[0]) / 2, 0.0, (a[1] + c[1]) / 2])
        b.quad([bottom[i], bottom[j], top[j], top[i]], material, outward)


def _tree(b: SceneBuilder, x: float, z: float, rng: np.random.Generator, trunk: int, leaves: list[int]) -> None:
    """A trunk and a canopy of 5 leaf blocks with gaps between them (dappled shadows)."""
    b.box((x - 0.18, 0.0, z - 0.18), (x + 0.18, 3.2, z + 0.18), trunk)
    for _ in range(5):
        dx, dz = rng.uniform(-1.4, 1.4, 2)
        cy = rng.uniform(3.8, 5.6)
        half = rng.uniform(0.6, 0.95)
        b.box((x + dx - half, cy - half, z + dz - half), (x + dx + half, cy + half, z + dz + half),
              leaves[int(rng.integers(len(leaves)))])


def _forest(b: SceneBuilder, rng, count: int, x0, x1, z0, z1, keep_out, trunk, leaves) -> None:
    """`count` trees scattered over [x0, x1] x [z0, z1], none within keep_out(x, z)."""
    placed = 0
    while placed < count:
        x, z = rng.uniform(x0, x1), rng.uniform(z0, z1)
        if not keep_out(x, z):
            _tree(b, x, z, rng, trunk, leaves)
            placed += 1


def _near_track(x: float, z: float, margin: float) -> bool:
    """True within HALF_WIDTH + RUMBLE + margin of the centre line."""
    if abs(x) <= STRAIGHT:
        d = abs(abs(z) - RADIUS)
    else:
        d = abs(np.hypot(x - np.sign(x) * STRAIGHT, z) - RADIUS)
    return d < HALF_WIDTH + RUMBLE + margin


def track() -> Scene:
    """The race-track scene described in the module docstring."""
    b = SceneBuilder()
    rng = np.random.default_rng(SEED)
    grass = b.material("grass", (0.16, 0.34, 0.09))
    asphalt = b.material("asphalt", (0.12, 0.12, 0.13))
    red = b.material("rumble red", (0.70, 0.05, 0.04))
    white = b.material("rumble white", (0.80, 0.80, 0.78))
    trunk = b.material("bark", (0.28, 0.18, 0.10))
    leaves = [b.material("leaves", (0.10, 0.30, 0.06)), b.material("leaves light", (0.22, 0.40, 0.08))]
    boards = [b.material("board blue", (0.05, 0.15, 0.60)), b.material("board yellow", (0.85, 0.65, 0.05))]
    pit_wall = b.material("pit building", (0.82, 0.80, 0.76))
    concrete = b.material("concrete", (0.50, 0.50, 0.50))
    brick = b.material("brick", (0.55, 0.22, 0.14))
    roof = b.material("roof", (0.30, 0.12, 0.10))
    steel = b.material("steel", (0.60, 0.62, 0.65))

    b.quad([(-FIELD, 0, -FIELD), (FIELD, 0, -FIELD), (FIELD, 0, FIELD), (-FIELD, 0, FIELD)], grass, (0, 1, 0))
    center = track_centerline()
    side = _edge_offsets(center)
    _strip(b, center, side, -HALF_WIDTH, HALF_WIDTH, ASPHALT_Y, [asphalt])
    _strip(b, center, side, HALF_WIDTH, HALF_WIDTH + RUMBLE, RUMBLE_Y, [red, white])
    _strip(b, center, side, -HALF_WIDTH - RUMBLE, -HALF_WIDTH, RUMBLE_Y, [red, white])

    # fences: sponsor boards between the main straight and the pits, and along the back straight
    for k, x in enumerate(np.arange(-36.0, 36.0, 6.0)):
        _oriented_box(b, (x, 34.0), (x + 5.6, 34.0), 1.2, 0.1, boards[k % 2])
        _oriented_box(b, (x, -34.0), (x + 5.6, -34.0), 1.2, 0.1, boards[(k + 1) % 2])
    # buildings
    b.box((-30.0, 0.0, 37.0), (30.0, 2.8, 45.0), pit_wall)          # pit building, below max-height
    b.box((-25.0, 0.0, -50.0), (25.0, 8.0, -40.0), concrete)        # grandstand
    b.box((50.0, 0.0, 45.0), (60.0, 5.0, 55.0), brick)              # houses
    b.box((49.5, 5.0, 44.5), (60.5, 5.4, 55.5), roof)
    b.box((-65.0, 0.0, 45.0), (-57.0, 4.0, 53.0), brick)
    b.box((-65.5, 4.0, 44.5), (-56.5, 4.4, 53.5), roof)
    for x, z in ((-45.0, 36.0), (45.0, 36.0), (-45.0, -36.0), (45.0, -36.0)):  # floodlight poles
        b.box((x - 0.15, 0.0, z - 0.15), (x + 0.15, 12.0, z + 0.15), steel)
        b.box((x - 1.0, 12.0, z - 0.4), (x + 1.0, 12.8, z + 0.4), steel)
    # forests: the infield, and the north-west corner
    _forest(b, rng, 45, -58.0, 58.0, -17.0, 17.0, lambda x, z: _near_track(x, z, 2.5), trunk, leaves)
    _forest(b, rng, 25, -78.0, -50.0, -78.0, -40.0, lambda x, z: _near_track(x, z, 2.5), trunk, leaves)

    direction = np.array(SUN_DIRECTION, np.float32)
    sun = Light("directional", np.array([1.0, 0.96, 0.88], np.float32), 90.0,
                direction=direction / np.linalg.norm(direction), angle=np.radians(0.53), name="sun")
    sky = Sky.gradient(zenith=(1.1, 1.8, 3.4), horizon=(2.4, 2.7, 3.0), ground=(0.35, 0.32, 0.28))
    scene = b.scene("track", lights=[sun], sky=sky)
    scene.extras["camera"] = {"eye": [-20.0, 14.0, 52.0], "target": [10.0, 0.0, 20.0], "fov": 50.0}
    scene.extras["path"] = track_centerline(1.0) + np.array([0.0, ASPHALT_Y, 0.0])  # the viewer's cars drive it
    return scene
