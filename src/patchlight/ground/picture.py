"""The top-down picture of the lit level and its static sun shadows.

One ray per texel centre looks straight down (-Y) at the map geometry (prepare.py): the
turned-up vertical layer first, then the flat layer (`cast_down`: geometry only, so it runs
before a bake). A hit shows the light leaving the original surface there, B = rho I + E
(radiance), read from the bake (`look_down`).

Shadows: shadow rays from the flat layer's hit towards the sun, against the whole level
(tree canopies and poles left out of the picture still cast shadows), say how much of the sun
reaches that spot of ground. They are the bake's own direct-light rays (radiosity.direct):
one to the sun's centre for a hard sun, stratified over its disc when it has an angle (the
bake's sun_angle or the light's), so the map's shadows are the bake's.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..rays.tracer import Hits, Tracer
from ..scene.model import Light
from ..solved import SolvedScene
from .mapping import GroundArea
from .prepare import MapGeometry

_DOWN = np.array([0.0, -1.0, 0.0], np.float32)


@dataclass
class Footprint:
    """Where each texel's downward ray lands, before any light: per texel of a size x size
    map (rows along z, columns along x, mapping.py), flattened to N = size^2.

    tri (N,) int64 the scene triangle hit (-1: none); u, v (N,) float32 its barycentrics;
    covered (N,) bool, tri >= 0; ground (N, 3) world point of the flat layer's hit (NaN
    where none), where shadows are tested."""

    size: int
    tri: np.ndarray
    u: np.ndarray
    v: np.ndarray
    covered: np.ndarray
    ground: np.ndarray


@dataclass
class TopDown:
    """Per texel of a size x size map, rows along z, columns along x (mapping.py).

    excident (H, W, 3) radiance B seen from above; reflectance (H, W, 3) rho there;
    covered (H, W) bool, False where no surface lies under the texel;
    ground (H, W, 3) world point of the flat layer's hit (NaN where none), where shadows
    are tested."""

    excident: np.ndarray
    reflectance: np.ndarray
    covered: np.ndarray
    ground: np.ndarray


def _look_down(tracer: Tracer | None, xz: np.ndarray, top_y: float) -> Hits | None:
    if tracer is None:
        return None
    origins = np.stack([xz[:, 0], np.full(len(xz), top_y), xz[:, 1]], axis=1).astype(np.float32)
    return tracer.intersect(origins, np.broadcast_to(_DOWN, origins.shape))


def cast_down(geometry: MapGeometry, area: GroundArea, size: int) -> Footprint:
    """One ray per texel centre of a size x size map over `area`, straight down through
    `geometry`: the turned-up layer first, then the flat one. Needs no light, so it can run
    (and refuse an area with nothing under it) before a bake."""
    xz = area.texel_centres(size).reshape(-1, 2)
    n = len(xz)
    layers = [(geometry.fallen_positions, geometry.fallen_source), (geometry.flat_positions, geometry.flat_source)]
    top_y = max([float(p[:, 1].max()) for p, _ in layers if len(p)], default=0.0) + 1.0
    tri = np.full(n, -1, np.int64)
    u = np.zeros(n, np.float32)
    v = np.zeros(n, np.float32)
    ground = np.full((n, 3), np.nan)
    for positions, source in layers:
        hits = _look_down(MapGeometry.tracer(positions), xz, top_y)
        if hits is None:
            continue
        hit = hits.tri >= 0
        if source is geometry.flat_source:
            ground[hit] = np.stack([xz[hit, 0], top_y - hits.t[hit], xz[hit, 1]], axis=1)
        take = hit & (tri < 0)
        tri[take] = source[hits.tri[take]]
        u[take], v[take] = hits.u[take], hits.v[take]
    return Footprint(size, tri, u, v, tri >= 0, ground)


def look_down(solved: SolvedScene, footprint: Footprint) -> TopDown:
    """The top-down picture of `solved` at the texels of `footprint` (cast_down over the
    same scene's geometry)."""
    n, size = len(footprint.tri), footprint.size
    covered = footprint.covered
    excident = np.zeros((n, 3), np.float32)
    reflectance = np.zeros((n, 3), np.float32)
    if covered.any():
        t, uu, vv = footprint.tri[covered], footprint.u[covered], footprint.v[covered]
        reflectance[covered] = solved.reflectance(t, uu, vv)
        excident[covered] = reflectance[covered] * solved.incident(t, uu, vv) + solved.emission(t, uu, vv)
    shape = (size, size)
    return TopDown(excident.reshape(*shape, 3), reflectance.reshape(*shape, 3), covered.reshape(shape),
                   footprint.ground.reshape(*shape, 3))


def the_sun(lights: list[Light]) -> Light | None:
    """The scene's brightest directional light, or None."""
    suns = [light for light in lights if light.kind == "directional"]
    return max(suns, key=lambda s: float(np.sum(s.radiometric)), default=None)


def sun_shadow(tracer: Tracer, ground: np.ndarray, sun: Light, lift: float, above: np.ndarray,
               sun_angle: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """What the level keeps from the sun on the ground, by the bake's own direct-light function
    (radiosity.direct.direct_light), so the sun's disc, when it has one, gives the same soft
    shadows as in the bake. ground (H, W, 3) the flat layer's points (NaN where none), tested
    `lift` metres above; above (3,) a point over the whole level, where the sun is never blocked;
    sun_angle (radians) overrides the sun's own.

    Returns (blocked (H, W, 3), free (3,)): the incident light I the sun would add at each point
    were nothing in its way (0 where there is no point), and the I it gives an unshadowed
    horizontal patch (Es max(0, -d.y) / pi, averaged over the disc)."""
    from ..radiosity.direct import direct_light

    points = ground.reshape(-1, 3)
    known = np.flatnonzero(~np.isnan(points[:, 0]))
    up = np.array([[0.0, 1.0, 0.0]])
    free = direct_light(np.asarray(above, np.float64)[None], up, [sun], tracer, sun_angle=sun_angle)[0]
    seen = direct_light(points[known] + lift * up, np.repeat(up, len(known), axis=0), [sun], tracer,
                        sun_angle=sun_angle)
    blocked = np.zeros((len(points), 3), np.float32)
    blocked[known] = free - seen
    return blocked.reshape(ground.shape), free
