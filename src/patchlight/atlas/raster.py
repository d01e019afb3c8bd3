"""Texel rasterisation: every lightmap texel a triangle touches becomes a patch.

Conservative: a texel belongs to the lightmap when any triangle's interior overlaps the texel
square, so thin and tiny triangles still get texels.  Among the triangles touching a texel,
the owner is the first (lowest index) covering the texel centre, else the one overlapping the
square most.  Triangles of zero world area are skipped: nothing can see or light them.

Per patch (see `Patches`): position at the texel centre on the owner triangle, except on a
chart's rim (the texel crosses an edge no other triangle shares in uv1, or the owner only
touches the texel) where it is the centroid of the texel's overlap with the owner: a point on
the triangle in the middle of what the texel covers, never on the rim itself, which at a
box's inner corner is the adjacent wall's plane and would leak half the gather's rays;
interpolated vertex normal (the face normal when that faces away); chart = connected
component of triangles sharing uv1 edges (`uv_charts`); size = world length of a texel edge on
the owner, sqrt(world area / texel area); rho = base colour factor x COLOR_0 (at the clamped
centre) x base-colour texture averaged over SAMPLES x SAMPLES points of the texel footprint
mapped through the owner's affine uv1 -> uv0 map (bilinear, repeat wrap, v = 0 top row);
emission = emissive factor x emissive texture averaged the same way.  RGB only.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..errors import PatchlightError
from ..scene.model import Scene, face_normals
from . import _kernels
from .patches import Patches
from .uvs import uv_boundary_edges, uv_charts

SAMPLES = 4  # footprint grid per texel axis for texture averages


def rasterize(scene: Scene, width: int, height: int) -> tuple[Patches, np.ndarray]:
    """Patches of a width x height lightmap over scene.uv1, rows ordered by texel (y, x).

    Returns (patches, chart_per_triangle (T,) i32)."""
    where = scene.label
    if scene.uv1 is None:
        raise PatchlightError(f"{where}: no lightmap UVs to rasterise (run ensure_lightmap_uvs first)")
    if not (int(width) == width > 0 and int(height) == height > 0):
        raise PatchlightError(f"{where}: lightmap size {width}x{height} is not positive whole texels")
    if scene.n_triangles and not (0 <= scene.material_ids.min() and scene.material_ids.max() < len(scene.materials)):
        raise PatchlightError(f"{where}: a triangle's material id points outside the material list")
    width, height = int(width), int(height)
    tex = _texel_corners(scene.uv1, scene.indices, width, height)
    normal, area = face_normals(scene.positions, scene.indices)
    texel_y, texel_x, triangle, index = _owned_texels(tex, area, width, height)
    chart_per_triangle, _ = uv_charts(scene.uv1, scene.indices)
    position, patch_normal, rho, emission = _attributes(scene, tex, texel_y, texel_x, triangle, normal)
    size = _texel_size(tex, area)[triangle]
    patches = Patches(width=width, height=height, texel_y=texel_y, texel_x=texel_x,
                      position=position, normal=patch_normal, triangle=triangle, rho=rho,
                      emission=emission, chart=chart_per_triangle[triangle], size=size, index=index)
    return patches, chart_per_triangle


def _texel_corners(uv, indices, width, height) -> np.ndarray:
    """(T, 3, 2) f64 triangle corners in texel units of a width x height map over `uv`."""
    return np.asarray(uv, np.float64)[indices] * np.array([width, height], np.float64)


def _owned_texels(tex, area, width, height):
    """texel_y, texel_x, owner triangle (N,) i32 of every texel a triangle of positive area
    touches, in (y, x) order, and the (H, W) i32 index of their rows (-1: untouched)."""
    return _kernels.owned_texels(_kernels.rasterize_owners(tex, area > 0, width, height))


def texel_surface_points(positions, indices, uv, width, height):
    """Where each texel of a width x height map over `uv` (V, 2) lies on the surface: the
    conservative rasterisation above, the texel centre clamped onto its owner triangle.
    Returns texel_y, texel_x, triangle (N,) and barycentrics (N, 3) f64 of the triangle's corners."""
    tex = _texel_corners(uv, indices, width, height)
    _, area = face_normals(positions, indices)
    texel_y, texel_x, triangle, _ = _owned_texels(tex, area, width, height)
    bary = _kernels.texel_centre_barycentrics(tex, triangle.astype(np.int64), texel_y.astype(np.float64),
                                              texel_x.astype(np.float64))
    return texel_y, texel_x, triangle, bary


def _attributes(scene, tex, texel_y, texel_x, triangle, face_normal):
    materials = scene.materials
    base_factor = np.array([np.asarray(m.base_color, np.float64)[:3] for m in materials]).reshape(-1, 3)
    emissive_factor = np.array([np.asarray(m.emissive, np.float64)[:3] for m in materials]).reshape(-1, 3)
    textures = []
    base_id = np.array([_register(textures, m.base_color_texture) for m in materials], np.int64)
    emissive_id = np.array([_register(textures, m.emissive_texture) for m in materials], np.int64)
    data, offset, tex_w, tex_h = _stack_textures(textures)
    colors = np.zeros((0, 4), np.float32) if scene.colors is None else np.asarray(scene.colors, np.float32)
    return _kernels.texel_attributes(
        texel_y, texel_x, triangle, tex,
        uv_boundary_edges(scene.uv1, scene.indices), np.asarray(scene.positions, np.float64), np.asarray(scene.normals, np.float64),
        np.asarray(scene.uv0, np.float64), colors, np.asarray(scene.indices, np.int64),
        face_normal.astype(np.float64), np.asarray(scene.material_ids, np.int64), base_factor, emissive_factor,
        base_id, emissive_id, data, offset, tex_w, tex_h, SAMPLES)


def _register(textures, image):
    """Index of image (H, W, >=3) in the textures list (appended), or -1 for None."""
    if image is None:
        return -1
    for i, known in enumerate(textures):
        if known is image:
            return i
    textures.append(image)
    return len(textures) - 1


def _stack_textures(textures):
    """RGB rows of every texture stacked: data (K, 3) f32, offset, width, height (n,) i64."""
    if not textures:
        return np.zeros((1, 3), np.float32), *(np.zeros(1, np.int64) for _ in range(3))
    rgb = [np.ascontiguousarray(np.asarray(t, np.float32)[..., :3]).reshape(-1, 3) for t in textures]
    sizes = np.array([len(r) for r in rgb], np.int64)
    offset = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    tex_w = np.array([t.shape[1] for t in textures], np.int64)
    tex_h = np.array([t.shape[0] for t in textures], np.int64)
    return np.concatenate(rgb), offset, tex_w, tex_h


def _texel_size(tex, world_area):
    """(T,) f32 world length of one texel edge on each triangle: sqrt(world / texel area).
    A triangle of no UV area counts as filling one texel: sqrt(world area)."""
    e1, e2 = tex[:, 1] - tex[:, 0], tex[:, 2] - tex[:, 0]
    texel_area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    world = world_area.astype(np.float64)
    size = np.sqrt(np.divide(world, texel_area, out=world.copy(), where=texel_area > 1e-12))
    return size.astype(np.float32)


@njit(cache=True)
def sub_texel_cells(n):
    """(2, n*n) f64 the x and y of the centres of an n x n grid of cells over a texel (texel
    units, 0..1), point k = i * n + j at ((i + 0.5) / n, (j + 0.5) / n)."""
    across = (np.arange(n) + 0.5) / n
    cells = np.empty((2, n * n))
    for i in range(n):
        for j in range(n):
            cells[0, i * n + j], cells[1, i * n + j] = across[i], across[j]
    return cells


@njit(cache=True, inline="always")
def texel_points(out, p, grid, cells):
    """Write into out (3, K) f64 the points of patch p at the K `sub_texel_cells` (2, K) of its
    texel, on the plane of its triangle (one loop over the K points, without branches); K = 1:
    the patch's own position, as `TexelPoints` gives for n = 1. Returns how many points took
    the patch's position; when none did, the points are an affine image of the cells' grid,
    inside the quadrilateral of its four corner points.

    grid: (texel_x, texel_y, triangle, position, tex, corners, rim) of `atlas.raster.TexelPoints`:
    the patches' texels and triangles, their own points (N, 3), taken where a point falls past
    a rim edge or the triangle has no UV area; tex (T, 3, 2) f64 corners in texel units;
    corners (T, 3, 3) f64 world corners; rim (T, 3) bool edges 01, 12, 20 on a chart's rim."""
    texel_x, texel_y, triangle, position, tex, corners, rim = grid
    t = triangle[p]
    ax, ay = tex[t, 0, 0], tex[t, 0, 1]
    e1x, e1y = tex[t, 1, 0] - ax, tex[t, 1, 1] - ay
    e2x, e2y = tex[t, 2, 0] - ax, tex[t, 2, 1] - ay
    det = e1x * e2y - e1y * e2x
    flat = abs(det) <= 1e-12
    safe = 1.0 if flat else det
    rim01, rim12, rim20 = rim[t, 0], rim[t, 1], rim[t, 2]
    x, y = texel_x[p], texel_y[p]
    p0, p1, p2 = position[p, 0], position[p, 1], position[p, 2]
    a0, a1, a2 = corners[t, 0, 0], corners[t, 0, 1], corners[t, 0, 2]
    b0, b1, b2 = corners[t, 1, 0], corners[t, 1, 1], corners[t, 1, 2]
    c0, c1, c2 = corners[t, 2, 0], corners[t, 2, 1], corners[t, 2, 2]
    single = out.shape[1] == 1
    taken = 0
    for k in range(out.shape[1]):
        dx = x + cells[0, k] - ax
        dy = y + cells[1, k] - ay
        w1 = (dx * e2y - dy * e2x) / safe
        w2 = (e1x * dy - e1y * dx) / safe
        w0 = 1.0 - w1 - w2
        past = single | flat | ((w0 < 0.0) & rim12) | ((w1 < 0.0) & rim20) | ((w2 < 0.0) & rim01)
        out[0, k] = p0 if past else w0 * a0 + w1 * b0 + w2 * c0
        out[1, k] = p1 if past else w0 * a1 + w1 * b1 + w2 * c1
        out[2, k] = p2 if past else w0 * a2 + w1 * b2 + w2 * c2
        taken += past
    return taken


@njit(cache=True, nogil=True)
def sub_texel_points(rows, grid, n):
    """(R, n*n, 3) f64 the `texel_points` of patches `rows` (R,) on an n x n grid."""
    out = np.empty((rows.shape[0], n * n, 3))
    cells = sub_texel_cells(n)
    for r in range(rows.shape[0]):
        texel_points(out[r].T, rows[r], grid, cells)
    return out


class TexelPoints:
    """Points spread over the footprint on its triangle of each texel, an n x n grid of
    sub-texel centres, for direct light without staircase shadow edges. A point past an edge
    its triangle shares with another of the chart continues the triangle's plane (exact on a
    flat chart, a texel's bend at most on a curved one); a point past the chart's rim is
    replaced by the patch's own position. Built once per bake; calls are thread-safe and
    release the GIL (a numba kernel), so callers make them chunk by chunk on their threads."""

    def __init__(self, scene: Scene, patches: Patches):
        self.patches = patches
        tex = scene.uv1[scene.indices] * np.array([patches.width, patches.height])  # (T, 3, 2) f64
        corners = scene.positions[scene.indices].astype(np.float64)                   # (T, 3, 3)
        rim = uv_boundary_edges(scene.uv1, scene.indices)                               # (T, 3): 01, 12, 20
        # what kernels read to make a texel's points themselves (`texel_points`)
        self.grid = (patches.texel_x, patches.texel_y, patches.triangle, patches.position, tex, corners, rim)

    def __call__(self, n: int, rows: np.ndarray | None = None) -> np.ndarray:
        """(R, n*n, 3) f64 the points of patches `rows` (default: all); n = 1: their positions."""
        rows = np.arange(len(self.patches)) if rows is None else np.asarray(rows)
        return sub_texel_points(rows.astype(np.int64), self.grid, max(n, 1))
