"""Normal maps and ambient occlusion baked from a high-poly model onto a low-poly one.

Every texel of the low-poly model's uv0 map (conservatively rasterised, `texel_surface_points`)
casts one ray at the high-poly surface: from the cage (the texel's point on a cage mesh of the
low model's topology) towards the low surface, or, without a cage, from `distance` metres
above the low surface along its interpolated normal, straight down through it; the first hit
within twice that reach counts. The high model's interpolated normal there is stored

- in tangent space (glTF's convention, the frame the runtime's normal_map.glsl rebuilds: the
  interpolated vertex tangent made orthogonal to the interpolated normal N, B = cross(N, T) x w;
  the file's TANGENTs, else per-vertex tangents from the UVs, MikkTSpace-style, the ones the
  renderer uses), +X right, +Y green up the image (towards -v), +Z out of the surface;
- or in object space: the model's space as loaded (node transforms applied), +Y up.

Either is encoded 0.5 + 0.5 n. Ambient occlusion comes from the same hits: cosine-weighted rays
about the high normal, the share that travels `ao_distance` unoccluded (1 open, 0 shut).
Texels whose ray found nothing within reach, and texels no triangle covers, are filled from
their neighbours by `dilation` rings.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import setting, validate_fields
from .errors import PatchlightError
from .imaging.dilate import dilate
from .radiosity.hemicube import stratified_directions
from .rays.hemisphere import hemisphere_rays
from .rays.tracer import Tracer
from .scene.model import Scene, face_normals
from .shading.surface import SurfaceArrays, interpolate

SPACES = ("tangent", "object")
DEFAULT_REACH = 0.05  # ray reach without a cage or distance: this share of the low model's bounding-box diagonal
DEFAULT_AO_REACH = 0.1  # AO ray length by default: this share of the high model's diagonal
CHUNK = 65536  # texels per progress step
MAX_MAP_SIZE = 16384  # texels per side


@dataclass
class NormalMapSettings:
    """What map is baked and how its rays search (table: docs/settings.md)."""

    width: int = setting(512, "texels", "map width", lo=1, hi=MAX_MAP_SIZE, whole=True, typical="512-2048")
    height: int = setting(512, "texels", "map height", lo=1, hi=MAX_MAP_SIZE, whole=True, typical="512-2048")
    distance: float | None = setting(None, "m", "how far each side of the low surface a ray searches (unused with "
                                     "a cage)", lo=0, lo_open=True,
                                     none=f"{DEFAULT_REACH:g} of the low model's bounding-box diagonal")
    cage: Scene | None = setting(None, "", "a mesh of the low model's vertices and triangles, moved out: rays run "
                                 "from it towards the low surface", none="rays from distance above the surface")
    space: str = setting("tangent", "", "the normals' space", choices=SPACES)
    dilation: int = setting(8, "texels", "rings filled past the covered texels", lo=0, whole=True, typical="8")
    ao_rays: int = setting(0, "rays / texel", "ambient-occlusion rays (0: no AO map)", lo=0, whole=True,
                           typical="64")
    ao_distance: float | None = setting(None, "m", "AO ray length", lo=0, lo_open=True,
                                        none=f"{DEFAULT_AO_REACH:g} of the high model's diagonal")
    seed: int = setting(0, "int", "the AO ray pattern", lo=0, whole=True)

    def validate(self) -> None:
        validate_fields(self)


@dataclass
class NormalMap:
    """normal (H, W, 3) f32 unit vectors (tangent or object space), row 0 = v 0; ao (H, W) f32
    in [0, 1] or None; covered (H, W) bool: texels a low triangle covers; hit (H, W) bool:
    covered texels whose ray found the high surface."""

    normal: np.ndarray
    ao: np.ndarray | None
    covered: np.ndarray
    hit: np.ndarray

    def encoded(self) -> np.ndarray:
        """(H, W, 3) uint8: 0.5 + 0.5 n, rounded."""
        return np.clip(np.rint((0.5 + 0.5 * self.normal) * 255.0), 0, 255).astype(np.uint8)


def bake_normal_map(high: Scene, low: Scene, settings: NormalMapSettings, advance=None) -> NormalMap:
    """The high model's normals (and AO) on the low model's uv0 map; advance(n) reports texels done."""
    settings.validate()
    high.validate()
    low.validate()
    if not np.any(low.uv0):
        raise PatchlightError(f"{low.label}: no TEXCOORD_0 to bake a normal map into")
    w, h = settings.width, settings.height
    from .atlas.raster import texel_surface_points  # here: the command line reads NormalMapSettings at start

    surface = SurfaceArrays.from_scene(low)
    texel_y, texel_x, triangle, bary = texel_surface_points(low.positions, low.indices, low.uv0, w, h)
    if len(triangle) == 0:
        raise PatchlightError(f"{low.label}: its TEXCOORD_0 covers no texel of a {w}x{h} map")
    corners = surface.indices[triangle]
    bary = bary.astype(np.float32)
    position = interpolate(surface.positions, corners, bary)
    normal = _unit(interpolate(surface.normals, corners, bary))
    origin, direction, reach = _rays(settings, low, position, normal, corners, bary)
    tracer = Tracer(high.positions, high.indices)
    high_normals = SurfaceArrays.from_scene(high).normals
    n = len(position)
    found = np.zeros(n, bool)
    values = np.zeros((n, 3), np.float32)
    ao = np.ones(n, np.float32) if settings.ao_rays else None
    ao_reach = settings.ao_distance or DEFAULT_AO_REACH * _diagonal(high)
    for start in range(0, n, CHUNK):
        rows = slice(start, min(start + CHUNK, n))
        hits = tracer.intersect(origin[rows], direction[rows])
        ok = (hits.tri >= 0) & (hits.t <= reach[rows])
        tri = hits.tri[ok]
        hit_bary = np.stack([1 - hits.u[ok] - hits.v[ok], hits.u[ok], hits.v[ok]], 1).astype(np.float32)
        world = _unit(interpolate(high_normals, high.indices[tri], hit_bary))
        idx = np.arange(rows.start, rows.stop)[ok]
        found[idx] = True
        values[idx] = world if settings.space == "object" else _to_tangent(
            world, normal[idx], interpolate(surface.tangents, corners[idx], bary[idx]))
        if ao is not None and len(idx):
            points = origin[idx] + direction[idx] * hits.t[ok, None]
            ao[idx] = _occlusion(tracer, high, points, tri, direction[idx], world, settings, ao_reach, start)
        if advance is not None:
            advance(rows.stop - rows.start)
    if not found.any():
        raise PatchlightError(f"no ray from {low.label} met {high.label} within {float(reach.max()):.4g} m; "
                              "raise `distance` or give a `cage`")
    return _assemble(settings, texel_y, texel_x, found, values, ao)


def _rays(settings, low, position, normal, corners, bary):
    """origin, unit direction (N, 3) and reach (N,) of each texel's ray."""
    if settings.cage is not None:
        cage = settings.cage
        if cage.positions.shape != low.positions.shape or not np.array_equal(cage.indices, low.indices):
            raise PatchlightError(f"cage {cage.label}: needs the low model's vertices and triangles "
                                  f"({len(low.positions)} vertices, {low.n_triangles} triangles)")
        origin = interpolate(np.asarray(cage.positions, np.float32), corners, bary)
        offset = position - origin
        length = np.linalg.norm(offset, axis=1)
        direction = np.where(length[:, None] > 0, offset / np.maximum(length, 1e-30)[:, None], -normal)
        return origin, direction.astype(np.float32), (2 * length).astype(np.float32)
    reach = settings.distance or DEFAULT_REACH * _diagonal(low)
    origin = position + np.float32(reach) * normal
    return origin, -normal, np.full(len(position), 2 * reach, np.float32)


def _to_tangent(world, N, tangent):
    """world (N, 3) unit vectors in the frame (T, B, N) normal_map.glsl rebuilds from N and tangent (N, 4)."""
    T = _unit(tangent[:, :3] - N * np.einsum("ij,ij->i", N, tangent[:, :3])[:, None])
    B = np.cross(N, T) * np.where(tangent[:, 3:] < 0, -1.0, 1.0).astype(np.float32)
    out = np.stack([np.einsum("ij,ij->i", world, axis) for axis in (T, B, N)], 1)
    return _unit(out)


def _occlusion(tracer, high, points, tri, incoming, shading_normal, settings, reach, start):
    """(N,) share of cosine-weighted rays about the high normal that leave `points` unoccluded."""
    face, _ = face_normals(high.positions, high.indices[tri])
    face = np.where(np.einsum("ij,ij->i", face, incoming)[:, None] > 0, -face, face)  # the side the ray came from
    normal = np.where(np.einsum("ij,ij->i", shading_normal, face)[:, None] > 0, shading_normal, face)
    dirs, _ = stratified_directions(settings.ao_rays, np.random.default_rng(settings.seed))
    rows = np.arange(len(points), dtype=np.int64)
    lift = np.float32(1e-4 * reach) + 1e-5 * np.abs(points).max(axis=1)
    origin = (points + lift[:, None] * face).astype(np.float32)
    o, d = hemisphere_rays(origin, normal.astype(np.float32), np.zeros(len(points), np.float32), rows, dirs,
                           start)
    blocked = tracer.occluded(o, d, np.float32(reach)).reshape(len(points), len(dirs))
    return 1.0 - blocked.mean(axis=1)


def _assemble(settings, texel_y, texel_x, found, values, ao) -> NormalMap:
    """The maps from the texels' values, holes and margins dilated from the texels that hit."""
    shape = (settings.height, settings.width)
    covered = np.zeros(shape, bool)
    covered[texel_y, texel_x] = True
    hit = np.zeros(shape, bool)
    hit[texel_y[found], texel_x[found]] = True
    channels = np.zeros(shape + (4,), np.float32)
    channels[texel_y, texel_x, :3] = values
    if ao is not None:
        channels[texel_y, texel_x, 3] = ao
    known = dilate(channels, hit, settings.dilation)
    flat = (0.0, 0.0, 1.0) if settings.space == "tangent" else (0.0, 0.0, 0.0)
    normal = np.where(known[..., None], _unit(channels[..., :3].reshape(-1, 3)).reshape(shape + (3,)),
                      np.asarray(flat, np.float32))
    return NormalMap(normal.astype(np.float32), None if ao is None else np.where(known, channels[..., 3], 1.0),
                     covered, hit)


def _unit(v: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return (v / np.maximum(length, 1e-30)).astype(np.float32)


def _diagonal(scene: Scene) -> float:
    lo, hi = scene.bounds()
    return max(float(np.linalg.norm(hi - lo)), 1e-6)
