"""Baking a light volume: each probe of a grid gathers the incident light from six axes.

For each axis a, a probe's value is what a small patch there facing a receives (the
incident light I): stratified cosine-weighted rays about a see the solved scene's excident
light B = rho I + E where they hit a front face, the sky's radiance where they escape, and
nothing where they hit a back face; the sun, point and spot lights are added by shadow rays
(`radiosity.direct.direct_light` with the axis as the normal), as the lightmap bake does.
A probe whose rays mostly hit back faces lies inside geometry: it is marked, given validity
0 (sampling then leaves it out wherever a valid probe is near, so no light leaks through
the wall it sits in), and its values are filled from valid neighbours (fill.py), as are
those of any axis whose own rays meet many back faces (a probe on a wall's face, looking
into the wall).

The settings (VolumeSettings) are declared with their units and ranges on the fields.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from ..config import FALLOFFS, setting, validate_fields
from ..progress import Progress
from ..radiosity.direct import direct_light
from ..radiosity.hemicube import stratified_directions
from ..rays.hemisphere import hemisphere_rays
from ..rays.inside import back_faces, back_share, is_inside, two_sided_triangles
from ..rays.tracer import Tracer
from ..solved import SolvedScene
from . import _kernels as _volume_kernels
from .fill import fill_invalid
from .grid import ProbeGrid
from .volume import AXIS_VECTORS, LightVolume

T_NEAR = 2e-4               # rays start this far along (x the scene's size): a probe on a face
                            # must not meet that face at t = 0 (Embree starts rays at t = 0)
OPEN_SIDE_MIN = 0.05        # below this length the rays' open directions cancel out: no open side
RAYS_PER_CHUNK = 1 << 20    # rays traced per batch: bounds memory at ~100 MB
MAX_RAYS = 16384            # rays per axis
MAX_SEED = 2**32 - 1        # numpy's seed range; row_angle's (row + seed) x golden ratio keeps its precision below it


@dataclass
class VolumeSettings:
    """How each probe gathers its light (table: docs/settings.md)."""

    rays: int = setting(1024, "rays / axis", "stratified rays, rounded down to a square", lo=1, hi=MAX_RAYS,
                        whole=True, typical="1024")
    sun_samples: int = setting(16, "rays / axis", "shadow rays over the sun's disc when its angle is > 0", lo=1,
                               whole=True, typical="16")
    sun_angle: float | None = setting(None, "degrees", "the sun's angular diameter (0 = hard shadows)", lo=0,
                                      hi=90, hi_open=True, typical="0.53 (the real sun)", none="each light's own")
    falloff: str = setting("inverse-square", "", "point/spot falloff for lights that name none", choices=FALLOFFS)
    seed: int = setting(1, "int", "the jitter of the ray pattern and its rotation per axis", lo=0, hi=MAX_SEED,
                        whole=True)

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        validate_fields(self)

    def to_json(self) -> dict:
        return asdict(self)


class IncidentGatherer:
    """Incident light I at free points facing given directions, from a solved scene."""

    def __init__(self, solved: SolvedScene, settings: VolumeSettings, tracer: Tracer | None = None):
        self.solved, self.settings = solved, settings
        scene = solved.scene
        self.tracer = tracer or Tracer(scene.positions, scene.indices)
        lo, hi = scene.bounds()
        self.t_near = np.float32(T_NEAR * float(np.max(hi - lo)))
        self.tri_uv1 = scene.triangle_uv1()
        materials = scene.materials
        self.tri_rho = np.array([m.base_color[:3] for m in materials], np.float32)[scene.material_ids]
        self.tri_emission = np.array([m.emissive[:3] for m in materials], np.float32)[scene.material_ids]
        textured = [m.base_color_texture is not None or m.emissive_texture is not None for m in materials]
        self.textured = np.array(textured, bool)[scene.material_ids]
        self.two_sided = two_sided_triangles(scene)
        self.lightmap = np.ascontiguousarray(solved.lightmap, np.float32)
        self.dirs, self.weights = stratified_directions(settings.rays, np.random.default_rng(settings.seed))

    @property
    def rays_per_point(self) -> int:
        return len(self.dirs)

    def gather(self, origins: np.ndarray, normals: np.ndarray, advance=None) -> tuple[np.ndarray, ...]:
        """At free points origins (N, 3), for patches facing unit normals (N, 3): incident light
        (N, 3) f32; (N,) the share of each one's rays that met a back face; (N, 3) the weighted
        sum of the directions of its other rays (where the open space lies). advance(n) reports
        progress."""
        light, back, open_side = self.trace(origins, normals, advance=advance)
        s = self.settings
        sun_angle = None if s.sun_angle is None else np.radians(s.sun_angle)
        light += direct_light(origins, normals, self.solved.scene.baked_lights, self.tracer, s.falloff, sun_angle,
                              s.sun_samples)
        return light, back, open_side

    def trace(self, origins: np.ndarray, normals: np.ndarray, offset: np.ndarray | None = None,
              advance=None) -> tuple[np.ndarray, ...]:
        """gather without the lights' direct share; offset (N,): lift each origin this far along
        its normal first (points on surfaces), default 0 (free points)."""
        origins = np.ascontiguousarray(origins, np.float32)
        normals = np.ascontiguousarray(normals, np.float32)
        offset = np.zeros(len(origins), np.float32) if offset is None else np.ascontiguousarray(offset, np.float32)
        per_chunk = max(1, RAYS_PER_CHUNK // self.rays_per_point)
        light = np.zeros((len(origins), 3), np.float32)
        back = np.zeros(len(origins), np.float32)
        open_side = np.zeros((len(origins), 3), np.float32)
        for start in range(0, len(origins), per_chunk):
            rows = np.arange(start, min(start + per_chunk, len(origins)), dtype=np.int64)
            light[rows], back[rows], open_side[rows] = self._gather_rows(origins, normals, offset, rows)
            if advance is not None:
                advance(len(rows))
        return light, back, open_side

    def _gather_rows(self, origins, normals, offset, rows) -> tuple[np.ndarray, ...]:
        """gather's results for `rows`; each row's ray pattern turned by its own angle."""
        d = self.rays_per_point
        o, dirs = hemisphere_rays(origins, normals, offset, rows, self.dirs, self.settings.seed)
        hits = self.tracer.intersect(o + self.t_near * dirs, dirs)
        back = back_faces(hits.tri, hits.front, self.two_sided)
        light, open_side = _volume_kernels.sum_rows(hits.tri, hits.u, hits.v, back, dirs, self.weights, self.tri_uv1,
                                                    self.lightmap, self.tri_rho, self.tri_emission, self.textured)
        row_of_ray = np.arange(len(o)) // d
        weight = np.tile(self.weights, len(rows))
        escaped = hits.tri < 0
        sky = self.solved.scene.sky
        if sky is not None and escaped.any():
            _add_rows(light, row_of_ray[escaped], sky.radiance(dirs[escaped]) * weight[escaped, None])
        textured = (hits.tri >= 0) & ~back & self.textured[np.maximum(hits.tri, 0)]
        if textured.any():
            B = self.solved.excident(hits.tri[textured], hits.u[textured], hits.v[textured])
            _add_rows(light, row_of_ray[textured], B * weight[textured, None])
        return light, back_share(back.reshape(len(rows), d)), open_side


def _add_rows(total: np.ndarray, rows: np.ndarray, values: np.ndarray) -> None:
    """total (R, 3) += the values (N, 3) summed into their rows (N,)."""
    for c in range(3):
        total[:, c] += np.bincount(rows, values[:, c], minlength=len(total)).astype(np.float32)


def bake_volume(solved: SolvedScene, grid: ProbeGrid, settings: VolumeSettings | None = None,
                quiet: bool = True) -> tuple[LightVolume, dict]:
    """The light volume of `solved` on `grid`, and its stats for volume.json."""
    settings = settings or VolumeSettings()
    start = time.perf_counter()
    with Progress(quiet) as progress:
        with progress.stage("tracer"):
            gatherer = IncidentGatherer(solved, settings)
        positions = grid.positions()
        origins = np.repeat(positions, 6, axis=0)
        normals = np.tile(AXIS_VECTORS, (len(positions), 1))
        with progress.stage("probes", total=len(origins)) as advance:
            light, back, open_side = gatherer.gather(origins, normals, advance)
        with progress.stage("fill"):
            cube, inside, invalid = _fill(grid, light, back, open_side)
    seconds = time.perf_counter() - start
    rays = gatherer.tracer.rays_traced
    stats = {"scene": solved.source, "settings": settings.to_json(), **grid.to_json(),
             "probes": grid.count, "inside_geometry_probes": int(inside.sum()),
             "filled_values": int(invalid.sum()),
             "rays_per_axis": gatherer.rays_per_point, "rays_traced": rays,
             "seconds_per_stage": dict(progress.seconds), "seconds": seconds,
             "probes_per_second": grid.count / max(seconds, 1e-9), "rays_per_second": rays / max(seconds, 1e-9)}
    return LightVolume(grid, np.ascontiguousarray(cube), inside), stats


def _fill(grid: ProbeGrid, light, back, open_side) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """From the gather's rows (probe-major, six axes each): cube (6, NZ, NY, NX, 3) with its
    invalid values filled, inside (NZ, NY, NX) and invalid (6, NZ, NY, NX) masks. A value is
    invalid when its probe is inside geometry or many of its own rays met back faces (a probe
    on a wall's face, looking into or along the wall)."""
    shape = grid.shape
    cube = light.reshape(*shape, 6, 3).transpose(3, 0, 1, 2, 4)
    back = back.reshape(*shape, 6)
    inside = is_inside(back.mean(axis=-1), "probe")
    invalid = inside[None] | is_inside(back.transpose(3, 0, 1, 2), "probe axis")
    side = open_side.reshape(*shape, 6, 3).sum(axis=-2)
    length = np.linalg.norm(side, axis=-1, keepdims=True)
    side = np.where(length > OPEN_SIDE_MIN, side / np.maximum(length, 1e-12), 0.0)
    return fill_invalid(cube, invalid, side), inside, invalid
