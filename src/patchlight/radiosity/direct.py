"""Direct light from the sun, point and spot lights, ray traced (never rendered into
hemicubes: the radiosity article found point lights lost at hemicube edges).

Units (docs/architecture.md): each light adds incident light I = radiance-equivalent of its
irradiance, E / pi. Sun: I = Es max(0, n.l) V / pi. Point and spot: I = Iv cos / d^2 V / pi
(inverse-square, the physical law, windowed to zero at a light's range when it has one), or
with the game falloff `range`: I = Iv cos (1 - (d/r)^2)_+ V / pi; spot cones as
KHR_lights_punctual. Point and spot lights use the runtime's own functions
(shading.lights), so a baked lamp and the same lamp in the shaders give the same light.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..atlas.patches import Patches
from ..scene.model import Light
from ..rays.tracer import Tracer
from ..shading.lights import from_scene_light, incident_light
from . import _kernels
from .hemicube import concentric_disk

REFINE_GRIDS = (8, 16)     # points per texel axis after the first look, where the points disagree
REFINE_SPREAD = 0.02       # points disagree when their light spreads over 2 % of the brightest
POINTS_PER_CHUNK = 32768   # points per task (each casts a shadow ray per light and sun direction)


def _sun_directions(light: Light, angle: float, samples: int) -> np.ndarray:
    """(K, 3) unit directions towards the sun: its centre, or K stratified over its disc."""
    to_sun = -np.asarray(light.direction, np.float64)
    to_sun /= np.linalg.norm(to_sun)
    if angle <= 0 or samples <= 1:
        return to_sun[None]
    s = int(np.sqrt(samples))
    i, j = np.meshgrid(np.arange(s), np.arange(s), indexing="ij")
    x, y = concentric_disk((i.ravel() + 0.5) / s, (j.ravel() + 0.5) / s)
    radius = np.tan(angle / 2)
    helper = np.array([1.0, 0, 0]) if abs(to_sun[0]) < 0.9 else np.array([0, 1.0, 0])
    t = np.cross(to_sun, helper)
    t /= np.linalg.norm(t)
    b = np.cross(to_sun, t)
    dirs = to_sun + radius * (x[:, None] * t + y[:, None] * b)
    return dirs / np.linalg.norm(dirs, axis=1, keepdims=True)


@dataclass
class _Sun:
    """A directional light ready to trace: directions (S, 3) f64 towards its disc (`_sun_directions`)
    and light (3,) f64, its colour x irradiance Es."""

    directions: np.ndarray
    light: np.ndarray


def _sources(lights: list[Light], falloff: str, sun_angle: float | None, sun_samples: int) -> list:
    """Each light ready to trace, made once per stage: a `_Sun`, or a point or spot light as the
    runtime's own model (shading.lights.PunctualLight)."""
    sources = []
    for light in lights:
        if light.kind == "directional":
            angle = light.angle if sun_angle is None else sun_angle
            sources.append(_Sun(_sun_directions(light, angle, sun_samples), light.radiometric.astype(np.float64)))
        else:
            sources.append(from_scene_light(light, falloff, f"light {light.name or light.kind!r}"))
    return sources


def sun_light(origins, normals, sun: _Sun, tracer: Tracer, total: np.ndarray) -> None:
    """Add to total (N, K, 3) the incident light from a directional light with ray-traced
    (soft) shadows at each of K points per texel, shadow rays leaving from origins (N, K, 3),
    all in one tracer call on the calling thread. The sun's disc directions are dealt out over
    the points (`_kernels.sun_rays`)."""
    cos = np.stack([normals @ d for d in sun.directions], axis=1)  # (N, S)
    ray, ray_origins, ray_dirs = _kernels.sun_rays(origins, cos, sun.directions)
    blocked = tracer.occluded_chunk(ray_origins, ray_dirs, np.full(len(ray), 1e30, np.float32))
    _kernels.add_sun_light(total, cos, ray, blocked, sun.light)


def local_light(points, origins, normals, lamp, tracer: Tracer) -> np.ndarray:
    """(N, K, 3) incident light from a point or spot light `lamp` (shading.lights.PunctualLight)
    with ray-traced shadows at each of the K points per texel of points (N, K, 3), all in one
    tracer call on the calling thread. The light is evaluated at the points themselves; shadow
    rays leave from `origins` (N, K, 3), the points lifted. The falloff and cone are the
    runtime models' own (shading.lights, the NumPy twin of the GLSL), so baked and real-time
    light agree."""
    strength = np.zeros(points.shape[:2] + (3,))
    for k in range(points.shape[1]):
        L, I = incident_light(lamp, points[:, k])
        strength[:, k] = np.maximum(np.einsum("ij,ij->i", normals, L), 0.0)[:, None] * I
    texel, point = np.nonzero(strength.max(axis=2) > 0)
    to_lamp = lamp.position - origins[texel, point]
    d = np.linalg.norm(to_lamp, axis=1)
    blocked = tracer.occluded_chunk(origins[texel, point], to_lamp / d[:, None],
                                    (d * (1 - 1e-4)).astype(np.float32))
    value = np.zeros(points.shape[:2] + (3,))
    value[texel, point] = np.where(blocked[:, None], 0.0, strength[texel, point])
    return value


def point_light(points: np.ndarray, normals: np.ndarray, sources: list, tracer: Tracer, lift=0.0) -> np.ndarray:
    """(N, K, 3) incident light from every light of `sources` (`_sources`) at each of K points
    per texel, points (N, K, 3) with unit normals (N, 3) per texel; see `direct_light`. Traced
    on the calling thread (callers spread chunks of texels over the tracer's threads, `_over_chunks`)."""
    points = np.asarray(points, np.float64)
    normals = np.asarray(normals, np.float64)
    lift = np.broadcast_to(np.asarray(lift, np.float64), (len(points),))[:, None, None]
    origins = points + lift * normals[:, None]
    total = np.full(points.shape[:2] + (3,), 0.0)  # written, not np.zeros: see _kernels.next_event_samples
    for source in sources:
        if isinstance(source, _Sun):
            sun_light(origins, normals, source, tracer, total)
        else:
            total += local_light(points, origins, normals, source, tracer)
    return total


def _over_chunks(tracer: Tracer, fn, rows: np.ndarray, points_per_row: int) -> list:
    """fn(chunk of rows) over chunks of about POINTS_PER_CHUNK points, on the tracer's threads."""
    size = max(1, POINTS_PER_CHUNK // max(points_per_row, 1))
    return tracer.over_spans(lambda first, last: fn(rows[first:last]), 0, len(rows), size)


def direct_light(points: np.ndarray, normals: np.ndarray, lights: list[Light], tracer: Tracer,
                 falloff: str = "inverse-square", sun_angle: float | None = None,
                 sun_samples: int = 16, lift=0.0) -> np.ndarray:
    """(N, 3) f32 incident light I from every light at `points` (N, 3), or the mean over
    (N, K, 3) K points spread over each texel, with unit normals (N, 3). Shadow rays leave
    from the points lifted by `lift` metres along the normal (a scalar or (N,)), so that they
    clear their own surface; the light itself is evaluated on the surface. sun_angle
    (radians) overrides each sun's."""
    points = np.asarray(points, np.float64)
    if points.ndim == 2:
        points = points[:, None, :]
    normals = np.asarray(normals, np.float64)
    lift = np.broadcast_to(np.asarray(lift, np.float64), (len(points),))
    sources = _sources(lights, falloff, sun_angle, sun_samples)

    def chunk(rows):
        values = point_light(points[rows], normals[rows], sources, tracer, lift[rows])
        return _kernels.mean_over_points(values).astype(np.float32)

    parts = _over_chunks(tracer, chunk, np.arange(len(points)), points.shape[1])
    return np.concatenate(parts) if parts else np.zeros((0, 3), np.float32)


def texel_direct_light(points_of, patches: Patches, lights: list[Light], tracer: Tracer,
                       falloff: str = "inverse-square", sun_angle: float | None = None,
                       sun_samples: int = 16, lift=0.0, first: int = 2) -> np.ndarray:
    """(N, 3) f32 the mean of the lamps' light over each texel's area, refined where it varies.

    points_of(n, rows): (R, n * n, 3) points on an n x n grid over the texels of patches
    `rows` (atlas.raster.TexelPoints). Every texel is sampled on a first x first grid; where its
    points disagree (a shadow edge or a cone edge crosses it), and next to such a texel (an
    edge may slip between the first points), it is sampled again on the next, finer grid,
    and so on while the points still disagree: a hard edge gives the lit fraction of the
    texel's area, to within the finest grid's resolution. Chunks of texels run on the
    tracer's threads, points made and traced on each."""
    lift = np.broadcast_to(np.asarray(lift, np.float32), (len(patches),))
    sources = _sources(lights, falloff, sun_angle, sun_samples)
    rows = np.arange(len(patches))
    total = np.zeros((len(patches), 3), np.float32)
    for n in (first, *REFINE_GRIDS):
        if len(rows) == 0 or not lights:
            break

        def chunk(part, n=n):
            values = point_light(points_of(n, part), patches.normal[part], sources, tracer, lift[part])
            total[part] = _kernels.mean_over_points(values)
            return _kernels.points_disagree(values, REFINE_SPREAD)

        rows = rows[np.concatenate(_over_chunks(tracer, chunk, rows, n * n))]
        rows = _with_neighbours(patches, rows) if n == first else rows
    return total


def _with_neighbours(patches: Patches, rows: np.ndarray) -> np.ndarray:
    """Patch ids `rows` and their covered 8-neighbours in the lightmap, sorted."""
    y, x = patches.texel_y[rows], patches.texel_x[rows]
    found = [rows]
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            yy, xx = y + dy, x + dx
            ok = (yy >= 0) & (yy < patches.height) & (xx >= 0) & (xx < patches.width)
            ids = patches.index[yy[ok], xx[ok]]
            found.append(ids[ids >= 0])
    return np.unique(np.concatenate(found)).astype(np.int64)
