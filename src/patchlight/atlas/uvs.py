"""Lightmap UVs (TEXCOORD_1): keep the scene's own, else make them with xatlas, else pack planar charts.

ensure_lightmap_uvs parameters:

| name            | type         | meaning                                                      | default |
|-----------------|--------------|--------------------------------------------------------------|---------|
| texels_per_unit | float > 0    | lightmap texels per metre of surface                          | 16      |
| resolution      | int 16..8192 | square lightmap size; overrides texels_per_unit               | None    |
| padding         | int >= 0     | empty texels between charts (and around the atlas edge)       | 2       |
| densities       | {name: T}    | texels per metre of the objects so named (over their extras)  | None    |
| max_atlas       | int 64..8192 | the largest atlas edge; charts that need more go to several   | 4096    |

Several atlases: when the packed charts do not fit one max_atlas x max_atlas atlas, they are
moved, by whole texels and unchanged in shape, onto as many atlases of one size as they need
(shelf-packed, largest group first, into the first atlas with room). The charts of one object
and material go to one atlas together (a glTF primitive's material references one lightmap
texture), as does a chart that spans several. The atlases are stacked along v in uv1
(`scene.model.stacked_uv1`; Scene.atlases says how many), so the bake works on one image of
width x (atlases x height) texels; the bake directory and scene.glb split it again.

Per-object density: each object's positions go to the packer scaled about their centre by
its density over the base one, so its charts come out that much larger; `info["objects"]`
gives each object's density as measured from the UVs made.

xatlas runs in a forked child process (it can crash on some closed meshes); when it dies, times out
or is missing, a simple in-process packer takes over and `info["warnings"]` says so once.
All triangles of the scene go to xatlas as ONE mesh: a lightmap does not care about
materials, and one mesh lets xatlas share the page between every chart.
UV convention: uv1 in [0, 1], texel (row y, column x) covers v in [y/H, (y+1)/H]: v = 0 is
the image's top row, as glTF has it.
"""
from __future__ import annotations

import dataclasses
import faulthandler
import importlib.util
import io
import math
import os
import selectors
import signal
import time
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..config import BakeSettings
from ..errors import PatchlightError
from ..imaging.packing import shelf_pack
from ..scene.model import Scene, face_normals, stacked_uv1
from . import _kernels, _xatlas_child

DEFAULT_TEXELS_PER_UNIT = BakeSettings.texels_per_unit  # texels per metre (config.py)
MIN_SIZE, MAX_SIZE = 16, 8192   # lightmap edge in texels
MAX_ATLAS = BakeSettings.max_atlas  # default largest atlas edge (config.py)
MAX_TEXELS = 8192 * 8192
PLANAR_COS = 0.99999            # fallback charts: normals within ~0.26 degrees of the seed's
CELL_MARGIN = 0.01              # texels kept free inside a chart's cell, so float32 uv1 rounding
                                # (5e-4 texel at 8192) never spills a chart into the next texel
CHILD_TIMEOUT_BASE_S = 60.0     # xatlas child timeout = base + per-triangle x T
CHILD_TIMEOUT_PER_TRIANGLE_S = 2e-3


@dataclass
class _Packing:
    """Generated lightmap UVs: output vertex i copies source vertex vmapping[i]."""

    vmapping: np.ndarray   # (V',) int64
    indices: np.ndarray    # (T, 3) int32
    uv_texels: np.ndarray  # (V', 2) f64, texel units
    width: int
    height: int
    texels_per_unit: float
    charts: int


class _XatlasFailed(Exception):
    """xatlas could not run or died; the message is the first half of the warning line."""


def ensure_lightmap_uvs(scene: Scene, texels_per_unit: float | None = None, resolution: int | None = None,
                        padding: int = 2, densities: dict[str, float] | None = None,
                        max_atlas: int = MAX_ATLAS) -> tuple[Scene, int, int, dict]:
    """Give the scene lightmap UVs and choose the lightmap size.

    Returns (scene, width, height, info).  A scene with uv1 comes back unchanged; otherwise
    a new Scene whose vertices are split along chart seams (every per-vertex array remapped)
    with uv1 set (over `scene.atlases` stacked atlases; width x height is the stack).  info:
    uv_source ("TEXCOORD_1" | "xatlas" | "fallback"), charts, width, height, atlases (count,
    width, height of each), texels_per_unit (the density the charts were packed at; for
    TEXCOORD_1 the mean over the surface), objects (each object's name and texels per metre),
    warnings (list of str, at most one line about the packer and one about densities a kept
    TEXCOORD_1 ignores).
    """
    _check_options(texels_per_unit, resolution, padding)
    if resolution is not None and resolution > max_atlas:
        raise PatchlightError(f"`resolution` {resolution} is larger than the atlas limit {max_atlas} "
                              f"(`max_atlas`); raise it or lower `resolution`")
    density = float(texels_per_unit) if texels_per_unit is not None else DEFAULT_TEXELS_PER_UNIT
    names, triangle, scale = _object_scales(scene, density, densities or {})
    if scene.uv1 is not None:
        return _keep_texcoord1(scene, texels_per_unit, resolution, names, triangle, scale)
    if resolution is None:
        _check_density(scene, density * scale[triangle])
    warnings = []
    packed = _scaled_objects(scene, triangle, scale)
    try:
        packing = _xatlas_in_child(packed, density, resolution, padding)
        source = "xatlas"
    except _XatlasFailed as failure:
        warnings.append(f"{failure}; used the simple planar-chart packer")
        packing = pack_planar_charts(packed, density, resolution, padding)
        source = "fallback"
    width, height = _final_size(packing, resolution)
    _check_size(width, height, scene)
    uv1 = (packing.uv_texels / np.array([width, height], np.float64)).astype(np.float32)
    out = _split_vertices(scene, packing.vmapping, packing.indices, uv1)
    if max(width, height) > max_atlas:
        out, width, height = _into_atlases(out, packing.uv_texels, _units(out, triangle), max_atlas, padding)
    atlases = {"count": out.atlases, "width": width, "height": height // out.atlases}
    info = {"uv_source": source, "charts": packing.charts, "width": width, "height": height, "atlases": atlases,
            "texels_per_unit": packing.texels_per_unit, "warnings": warnings,
            "objects": _object_report(out, width, height, names, triangle)}
    return out, width, height, info


def _units(scene: Scene, triangle: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """The unit of each triangle (T,) i64 that must stay on one atlas (its object and its
    material: a glTF primitive) and a name for each unit, for messages."""
    materials = len(scene.materials)
    key = triangle.astype(np.int64) * materials + scene.material_ids
    unique, unit = np.unique(key, return_inverse=True)
    objects = scene.objects.names if scene.objects is not None else [scene.name]
    names = [f"{objects[k // materials]!r} (material {scene.materials[k % materials].name!r})" for k in unique]
    return unit.ravel(), names


def _into_atlases(scene: Scene, uv_texels: np.ndarray, units: tuple[np.ndarray, list[str]], limit: int,
                  padding: int) -> tuple[Scene, int, int]:
    """The scene with its charts moved onto several atlases (module docstring): returns it
    (uv1 over the stack, `atlases` set), the width and the stack's height in texels.
    uv_texels (V, 2) f64: the packed charts in texels."""
    unit, unit_names = units
    chart, charts = uv_charts(uv_texels.astype(np.float32), scene.indices)
    group = _chart_groups(chart, charts, unit)
    vertex_chart = np.zeros(len(uv_texels), np.int64)
    vertex_chart[scene.indices] = chart[:, None]
    lo = np.full((charts, 2), np.inf)
    hi = np.full((charts, 2), -np.inf)
    np.minimum.at(lo, vertex_chart, uv_texels)
    np.maximum.at(hi, vertex_chart, uv_texels)
    lo = np.floor(lo)
    cells = np.maximum(np.ceil(hi) - lo, 1).astype(np.int64)
    edge = limit - limit % 4
    border = max(int(padding), 1)  # a texel at least along each atlas's edges (`atlas_uv1`)
    atlas_of = np.full(charts, -1, np.int64)
    at = np.zeros((charts, 2), np.int64)
    used = []  # per atlas: (width, height)
    groups = [np.flatnonzero(group == g) for g in range(int(group.max()) + 1)]
    area = cells[:, 0] * cells[:, 1]
    for members in sorted(groups, key=lambda m: -int(area[m].sum())):
        for k in [*range(len(used)), len(used)]:
            mine = np.concatenate([np.flatnonzero(atlas_of == k), members])
            order = np.argsort(-cells[mine, 1], kind="stable")
            x_at, y_at, width, height = shelf_pack(cells[mine, 0], cells[mine, 1], order, border, edge)
            if width <= edge and height <= edge:
                break
            if k == len(used):
                name = unit_names[unit[np.flatnonzero(np.isin(chart, members))[0]]]
                raise PatchlightError(f"{scene.label}: the charts of {name} need more than one "
                                      f"{limit}x{limit} atlas; raise `max_atlas` or lower its density")
        atlas_of[mine], at[mine] = k, np.stack([x_at, y_at], axis=1)
        used[k:k + 1] = [(int(width), int(height))]
    width = max(MIN_SIZE, _round_up4(max(w for w, _ in used)))
    height = max(MIN_SIZE, _round_up4(max(h for _, h in used)))
    moved = uv_texels - lo[vertex_chart] + at[vertex_chart]
    local = (moved / np.array([width, height], np.float64)).astype(np.float32)
    uv1 = stacked_uv1(local, atlas_of[vertex_chart], len(used))
    stacked = dataclasses.replace(scene, uv1=uv1, atlases=len(used))
    _check_size(width, height * len(used), scene)
    return stacked, width, height * len(used)


def _chart_groups(chart: np.ndarray, charts: int, unit: np.ndarray) -> np.ndarray:
    """(C,) the group of each chart: charts joined by a unit (object and material) they share."""
    units = int(unit.max()) + 1
    graph = coo_matrix((np.ones(len(chart), np.int8), (chart, charts + unit)), shape=(charts + units,) * 2)
    return connected_components(graph, directed=False)[1][:charts]


def _object_scales(scene: Scene, density: float, asked: dict[str, float]) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(names (K,), object of each triangle (T,) i32, density of each object over `density`
    (K,) f64): `asked` by name first, then the file's extras, else 1. A scene without
    objects is one object named after the scene."""
    objects = scene.objects
    if objects is None:
        names, triangle, from_file = [scene.name], np.zeros(scene.n_triangles, np.int32), np.full(1, math.nan)
    else:
        names, triangle, from_file = objects.names, objects.triangle, objects.texels_per_unit
    unknown = sorted(set(asked) - set(names))
    if unknown:
        raise PatchlightError(f"{scene.label}: `density` names {', '.join(map(repr, unknown))}, which no object "
                              f"is called (objects: {', '.join(map(repr, sorted(set(names))[:8]))}"
                              f"{' ...' if len(set(names)) > 8 else ''})")
    for name, value in asked.items():
        _check_options(value, None, 0)
    wanted = np.array([asked.get(name, f) for name, f in zip(names, from_file)], np.float64)
    return names, triangle, np.where(np.isnan(wanted), density, wanted) / density


def _scaled_objects(scene: Scene, triangle: np.ndarray, scale: np.ndarray) -> Scene:
    """The scene with each object's vertices scaled by its factor about the object's centre
    (for the packer only). A vertex shared by objects takes the largest factor."""
    if np.all(scale == 1.0):
        return scene
    vertex_scale = np.zeros(len(scene.positions), np.float64)
    vertex_object = np.zeros(len(scene.positions), np.int64)
    order = np.argsort(scale[triangle], kind="stable")  # the largest factor written last
    corners = scene.indices[order]
    vertex_scale[corners] = scale[triangle[order]][:, None]
    vertex_object[corners] = triangle[order][:, None]
    positions = np.asarray(scene.positions, np.float64)
    count = np.bincount(vertex_object, minlength=len(scale)).astype(np.float64)
    centre = np.stack([np.bincount(vertex_object, positions[:, a], len(scale)) for a in range(3)], axis=1)
    centre /= np.maximum(count, 1.0)[:, None]
    origin = centre[vertex_object]
    scaled = origin + (positions - origin) * vertex_scale[:, None]
    return dataclasses.replace(scene, positions=scaled.astype(np.float32), provenance=None, objects=None)


def _object_report(scene: Scene, width: int, height: int, names: list[str], triangle: np.ndarray) -> list[dict]:
    """bake.json's list of objects: name and lightmap texels per metre, measured from the
    lightmap UVs (the square root of its texels over its area)."""
    area = np.bincount(triangle, face_normals(scene.positions, scene.indices)[1], len(names))
    texels = np.bincount(triangle, _uv_areas(scene.uv1, scene.indices), len(names)) * (width * height)
    density = np.sqrt(texels / np.maximum(area, 1e-30))
    return [{"name": name, "texels_per_unit": float(t)} for name, t in zip(names, density)]


def uv_charts(uv1: np.ndarray, indices: np.ndarray) -> tuple[np.ndarray, int]:
    """Chart id (T,) i32 of each triangle and the chart count: connected components of
    triangles sharing a UV edge (both end points with bit-identical uv1)."""
    if len(indices) == 0:
        return np.zeros(0, np.int32), 0
    return _shared_edge_components(_uv_keys(uv1, indices))


def uv_boundary_edges(uv1: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """(T, 3) bool: edge k of triangle t (corner k to corner k+1) is on a chart's rim, that
    is no other triangle has the same UV edge."""
    if len(indices) == 0:
        return np.zeros((0, 3), bool)
    code = edge_codes(_uv_keys(uv1, indices)).ravel()
    count = np.unique(code, return_inverse=True, return_counts=True)
    return (count[2][count[1]] == 1).reshape(-1, 3)


def _uv_keys(uv1, indices):
    """(T, 3) i64 key per corner, equal for bit-identical uv1 values (-0 counted as +0)."""
    corner_uv = np.ascontiguousarray(uv1[indices].reshape(-1, 2), np.float32) + np.float32(0.0)
    return np.unique(corner_uv.view(np.int64).ravel(), return_inverse=True)[1].reshape(-1, 3)


def edge_codes(keys):
    """(T, 3) i64 code of each triangle edge k (corner k to k+1), independent of direction."""
    edges = np.sort(np.stack([keys[:, [0, 1]], keys[:, [1, 2]], keys[:, [2, 0]]], axis=1), axis=2)
    return edges[..., 0].astype(np.int64) * (int(keys.max()) + 1) + edges[..., 1]


# ----------------------------------------------------------------------------------------
# TEXCOORD_1 kept
# ----------------------------------------------------------------------------------------

def _keep_texcoord1(scene, texels_per_unit, resolution, names, triangle, scale):
    uv1 = scene.uv1
    where = scene.label
    if uv1.ndim != 2 or uv1.shape != (len(scene.positions), 2):
        raise PatchlightError(f"{where}: TEXCOORD_1 has shape {uv1.shape}, expected ({len(scene.positions)}, 2)")
    if not np.all(np.isfinite(uv1)):
        raise PatchlightError(f"{where}: TEXCOORD_1 holds NaN or infinite values")
    world_area = float(face_normals(scene.positions, scene.indices)[1].astype(np.float64).sum())
    uv_area = float(_uv_areas(uv1, scene.indices).sum())
    if uv_area <= 0.0 or world_area <= 0.0:
        raise PatchlightError(f"{where}: TEXCOORD_1 covers no area; remove it to let patchlight make lightmap UVs")
    count = scene.atlases  # each atlas is size x size, stacked along v: uv_area spans all of them
    if resolution is not None:
        size = int(resolution)
    else:
        density = float(texels_per_unit) if texels_per_unit is not None else DEFAULT_TEXELS_PER_UNIT
        # count W^2 * uv_area texels must hold world_area * density^2
        size = max(_round_up4(density * math.sqrt(world_area / (count * uv_area))), MIN_SIZE)
        if size > MAX_SIZE:
            raise PatchlightError(f"{where}: its TEXCOORD_1 at {density:g} texels per metre needs a {size}x{size} "
                                  f"lightmap (limit {MAX_SIZE}); lower `texels_per_unit` or set `resolution`")
    _, charts = uv_charts(uv1, scene.indices)
    warnings = _outside_unit_square(uv1, scene)
    if np.any(scale != 1.0):
        warnings.append(f"{scene.label}: its own TEXCOORD_1 is kept, so the per-object densities asked are not applied")
    info = {"uv_source": "TEXCOORD_1", "charts": charts, "width": size, "height": count * size,
            "atlases": {"count": count, "width": size, "height": size},
            "texels_per_unit": size * math.sqrt(count * uv_area / world_area), "warnings": warnings,
            "objects": _object_report(scene, size, count * size, names, triangle)}
    return scene, size, count * size, info


def _outside_unit_square(uv1, scene) -> list[str]:
    """One warning line when TEXCOORD_1 strays outside [0, 1], where no texel is."""
    corners = uv1[scene.indices]
    outside = np.any((corners < 0) | (corners > 1), axis=(1, 2))
    if not outside.any():
        return []
    return [f"{scene.label}: {int(outside.sum())} triangles reach outside TEXCOORD_1's [0, 1] square; "
            f"their parts outside get no lightmap texels"]


def _uv_areas(uv, indices):
    """(T,) f64 area of each triangle in normalised UV space."""
    tri = uv[indices].astype(np.float64)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    return 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


# ----------------------------------------------------------------------------------------
# xatlas, in a child process
# ----------------------------------------------------------------------------------------

def _xatlas_in_child(scene, texels_per_unit, resolution, padding):
    """Packing from xatlas in a child process (`_run_in_child`). The positions go centred and
    scaled to a unit extent (xatlas ran for minutes and gigabytes on coordinates of 1e12),
    the density scaled to match."""
    if not _xatlas_installed():
        raise _XatlasFailed("xatlas is not installed")
    positions = np.asarray(scene.positions, np.float64)
    low, high = positions.min(axis=0), positions.max(axis=0)
    extent = float(np.max(high - low))
    if not (math.isfinite(extent) and extent > 0):
        raise PatchlightError(f"{scene.label}: its positions span {extent:g} m; they must be finite and not all equal")
    unit_positions = np.ascontiguousarray((positions - 0.5 * (low + high)) / extent, np.float32)
    indices = np.ascontiguousarray(scene.indices, np.uint32)
    timeout = CHILD_TIMEOUT_BASE_S + CHILD_TIMEOUT_PER_TRIANGLE_S * scene.n_triangles
    result = _run_in_child(lambda: _xatlas_child.packed_npz(unit_positions, indices, int(padding),
                                                            float(texels_per_unit) * extent, int(resolution or 0)),
                           timeout)
    with np.load(io.BytesIO(result)) as data:
        if data["indices"].shape != (scene.n_triangles, 3):
            raise _XatlasFailed(f"xatlas returned {len(data['indices'])} of {scene.n_triangles} triangles")
        return _Packing(vmapping=data["vmapping"].astype(np.int64), indices=data["indices"].astype(np.int32),
                        uv_texels=data["uv"].astype(np.float64), width=int(data["width"]),
                        height=int(data["height"]), texels_per_unit=float(data["texels_per_unit"]) / extent,
                        charts=int(data["charts"]))


def _run_in_child(work, timeout: float) -> bytes:
    """What work() -> bytes returns, run in a forked child process that may crash, hang or
    fail without harm to this one: raises _XatlasFailed saying how it ended otherwise, or
    that it could not start. The
    child inherits what this process has imported (a fresh interpreter took 0.1 s to import
    NumPy and xatlas), writes its result into a pipe and its output into another, ignores
    Ctrl-C (this process handles it, and kills the child) and is killed by the kernel if this
    process dies. Killed after `timeout` seconds."""
    parent = os.getpid()
    result_read, result_write = os.pipe()
    output_read, output_write = os.pipe()
    try:
        pid = os.fork()
    except OSError as error:  # no memory or no process left for a child
        for fd in (result_read, result_write, output_read, output_write):
            os.close(fd)
        raise _XatlasFailed(f"xatlas's process could not start ({error.strerror or error})") from None
    if pid == 0:  # the child: never returns
        status = 1
        try:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            faulthandler.disable()  # a crash is reported by its exit status, not by a dump on the parent's stderr
            os.close(result_read)
            os.close(output_read)
            os.dup2(output_write, 1)  # anything xatlas prints goes to the output pipe
            os.dup2(output_write, 2)
            _xatlas_child.die_with_parent(parent)
            payload = work()
            with os.fdopen(result_write, "wb") as out:
                out.write(payload)
            status = 0
        except SystemExit as stop:
            os.write(2, f"{stop}\n".encode(errors="replace"))
        except BaseException as error:  # whatever happens, the child exits here
            os.write(2, f"{type(error).__name__}: {error}\n".encode(errors="replace"))
        finally:
            os._exit(status)
    os.close(result_write)
    os.close(output_write)
    reaped = False
    try:
        try:
            result, output = _read_until_closed((result_read, output_read), time.monotonic() + timeout)
        except TimeoutError:
            raise _XatlasFailed(f"xatlas took longer than {timeout:.0f} s") from None
        _, wait_status = os.waitpid(pid, 0)
        reaped = True
    finally:
        if not reaped:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
    if os.WIFSIGNALED(wait_status):
        raise _XatlasFailed(f"xatlas crashed ({_signal_name(os.WTERMSIG(wait_status))})")
    code = os.waitstatus_to_exitcode(wait_status)
    if code != 0:
        last = (output.decode(errors="replace").strip().splitlines() or ["no message"])[-1]
        raise _XatlasFailed(f"xatlas failed (exit status {code}: {last})")
    return result


def _read_until_closed(fds: tuple[int, ...], deadline: float) -> list[bytes]:
    """Everything written into each pipe of `fds` (read ends, closed here) until its writer
    closes it; TimeoutError at time.monotonic() `deadline`."""
    chunks = {fd: [] for fd in fds}
    with selectors.DefaultSelector() as selector:
        for fd in fds:
            selector.register(fd, selectors.EVENT_READ)
        try:
            while selector.get_map():
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError
                for key, _ in selector.select(left):
                    data = os.read(key.fd, 1 << 20)
                    if data:
                        chunks[key.fd].append(data)
                    else:
                        selector.unregister(key.fd)
        finally:
            for fd in fds:
                os.close(fd)
    return [b"".join(chunks[fd]) for fd in fds]


def _xatlas_installed():
    return importlib.util.find_spec("xatlas") is not None


def _signal_name(number):
    try:
        return f"signal {number}, {signal.Signals(number).name}"
    except ValueError:
        return f"signal {number}"


# ----------------------------------------------------------------------------------------
# Fallback: planar charts, projected onto their plane and shelf-packed
# ----------------------------------------------------------------------------------------

def pack_planar_charts(scene: Scene, texels_per_unit: float, resolution: int | None, padding: int) -> _Packing:
    """The in-process packer: charts are edge-connected triangles within PLANAR_COS of their
    seed's normal, projected onto the seed's plane (bounding rectangle minimised over a few
    in-plane axes), scaled to texels_per_unit and shelf-packed tallest first with `padding`
    empty texels between charts and around the border.  With a resolution, the density is
    searched so the charts fill one resolution x resolution page."""
    positions = np.asarray(scene.positions, np.float64)
    normal, area = face_normals(scene.positions, scene.indices)
    if float(area.astype(np.float64).sum()) <= 0.0:
        raise PatchlightError(f"{scene.label}: no triangle has any area to lightmap")
    chart, charts = _planar_charts(positions, scene.indices, normal.astype(np.float64))
    order = np.argsort(chart, kind="stable")
    start = np.searchsorted(chart[order], np.arange(charts + 1))
    chart_normal = normal[order[start[:-1]]].astype(np.float64)
    local, extent = _kernels.project_charts(positions[scene.indices], chart_normal, order, start, 12)
    if resolution is None:
        placed = _shelf_pack(extent, texels_per_unit, padding, None)
    else:
        texels_per_unit, placed = _fit_density(extent, float(area.sum()), int(resolution), padding, scene)
    x_at, y_at, cells_w, cells_h, width, height = placed
    # centre each chart in its whole-texel cell
    offset = np.stack([x_at + (cells_w - extent[:, 0] * texels_per_unit) / 2,
                       y_at + (cells_h - extent[:, 1] * texels_per_unit) / 2], axis=1)
    corner_uv = local * texels_per_unit + offset[chart][:, None, :]
    vertex_count = len(scene.positions)
    keys = chart.astype(np.int64)[:, None] * vertex_count + scene.indices
    unique, first, inverse = np.unique(keys.ravel(), return_index=True, return_inverse=True)
    return _Packing(vmapping=unique % vertex_count, indices=inverse.reshape(-1, 3).astype(np.int32),
                    uv_texels=corner_uv.reshape(-1, 2)[first], width=width, height=height,
                    texels_per_unit=float(texels_per_unit), charts=int(charts))


def _planar_charts(positions, indices, normal):
    """Chart id (T,) and count: region growing over triangles sharing an edge (by position)."""
    welded = np.unique(positions, axis=0, return_inverse=True)[1].ravel()[indices]
    code = edge_codes(welded)
    triangle = np.repeat(np.arange(len(indices)), 3)
    order = np.argsort(code.ravel(), kind="stable")
    code, triangle = code.ravel()[order], triangle[order]
    first, count = np.unique(code, return_index=True, return_counts=True)[1:]
    pairs = [np.stack([triangle[first[count == 2]], triangle[first[count == 2] + 1]], axis=1)]
    for start, size in zip(first[count > 2], count[count > 2]):  # non-manifold edges: rare
        group = triangle[start:start + size]
        a, b = np.triu_indices(size, 1)
        pairs.append(np.stack([group[a], group[b]], axis=1))
    pairs = np.concatenate(pairs)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    both = np.concatenate([pairs, pairs[:, ::-1]])
    both = both[np.lexsort((both[:, 1], both[:, 0]))]
    neighbour_start = np.searchsorted(both[:, 0], np.arange(len(indices) + 1))
    chart, charts = _kernels.grow_planar_charts(normal, neighbour_start, both[:, 1].copy(), PLANAR_COS)
    return chart, int(charts)


def _shelf_pack(extent, texels_per_unit, padding, shelf_width):
    """Whole-texel cells of each chart placed on shelves; shelf_width None = about square."""
    cells = np.maximum(1, np.ceil(extent * texels_per_unit + 2 * CELL_MARGIN)).astype(np.int64)
    cells_w, cells_h = cells[:, 0], cells[:, 1]
    if shelf_width is None:
        shelf_width = max(int(cells_w.max()) + 2 * padding,
                          int(math.ceil(math.sqrt(float(((cells_w + padding) * (cells_h + padding)).sum())))))
    order = np.argsort(-cells_h, kind="stable")
    x_at, y_at, width, height = shelf_pack(cells_w, cells_h, order, padding, shelf_width)
    return x_at, y_at, cells_w, cells_h, int(width), int(height)


def _fit_density(extent, world_area, resolution, padding, scene):
    """Largest texel density (searched) whose shelf packing fits resolution x resolution."""
    def fits(density):
        placed = _shelf_pack(extent, density, padding, resolution)
        return placed[4] <= resolution and placed[5] <= resolution, placed

    density = resolution * math.sqrt(0.5 / world_area)
    ok, placed = fits(density)
    lo, hi = (density, None) if ok else (None, density)
    for _ in range(60):  # bracket: grow or shrink by 2x
        if (lo is None) == (hi is None):
            break
        density = lo * 2 if hi is None else hi / 2
        ok, attempt = fits(density)
        if ok:
            lo, placed = density, attempt
        else:
            hi = density
    if lo is None or hi is None:
        raise PatchlightError(f"{scene.label}: {len(extent)} charts with {padding} texels of "
                              f"padding do not fit in {resolution}x{resolution}; raise `resolution`")
    for _ in range(12):  # refine between lo and 2 lo
        middle = 0.5 * (lo + hi)
        ok, attempt = fits(middle)
        if ok:
            lo, placed = middle, attempt
        else:
            hi = middle
    return lo, placed


# ----------------------------------------------------------------------------------------
# Shared helpers
# ----------------------------------------------------------------------------------------

def _final_size(packing, resolution):
    if resolution is not None:
        return int(resolution), int(resolution)
    return (max(_round_up4(packing.width), MIN_SIZE), max(_round_up4(packing.height), MIN_SIZE))


def _split_vertices(scene, vmapping, indices, uv1):
    """A new Scene whose vertex i copies scene vertex vmapping[i], with new indices and uv1
    (its provenance split the same way, so scene.glb can map the vertices back to the file's)."""
    def pick(array):
        return None if array is None else np.ascontiguousarray(array[vmapping])

    provenance = None if scene.provenance is None else scene.provenance.split(vmapping)
    return dataclasses.replace(scene, positions=pick(scene.positions), normals=pick(scene.normals),
                               uv0=pick(scene.uv0), tangents=pick(scene.tangents), colors=pick(scene.colors),
                               indices=np.ascontiguousarray(indices, np.int32), uv1=uv1, provenance=provenance)


def _shared_edge_components(keys):
    """Connected components (T,) i32 and count of triangles whose corners carry vertex keys
    (T, 3), linked when they share an edge (an unordered pair of keys)."""
    t_count = len(keys)
    edge_id = np.unique(edge_codes(keys).ravel(), return_inverse=True)[1].ravel()
    rows = np.repeat(np.arange(t_count), 3)
    graph = coo_matrix((np.ones(len(rows), np.int8), (rows, t_count + edge_id)),
                       shape=(t_count + edge_id.max() + 1,) * 2)
    labels = connected_components(graph, directed=False)[1][:t_count]
    unique, chart = np.unique(labels, return_inverse=True)
    return chart.astype(np.int32), len(unique)


def _check_options(texels_per_unit, resolution, padding):
    if texels_per_unit is not None and not (math.isfinite(texels_per_unit) and texels_per_unit > 0):
        raise PatchlightError(f"texels per unit: {texels_per_unit} is not a positive number")
    if resolution is not None and not (MIN_SIZE <= int(resolution) <= MAX_SIZE and int(resolution) == resolution):
        raise PatchlightError(f"resolution: {resolution} is not a whole number of texels in {MIN_SIZE}..{MAX_SIZE}")
    if not (int(padding) == padding and 0 <= padding <= 64):
        raise PatchlightError(f"padding: {padding} is not a whole number of texels in 0..64")


def _check_size(width, height, scene):
    if width * height > MAX_TEXELS:
        raise PatchlightError(f"{scene.label}: the lightmap would be {width}x{height} texels "
                              f"(limit {MAX_SIZE}x{MAX_SIZE}); lower `texels_per_unit` or set `resolution`")


def _check_density(scene, texels_per_unit):
    """Refuse before packing when the surface alone needs more than MAX_TEXELS texels at the
    density of each triangle (T,) texels per metre."""
    area = face_normals(scene.positions, scene.indices)[1].astype(np.float64)
    world_area = float(area.sum())
    needed = float((area * texels_per_unit ** 2).sum())
    if needed > MAX_TEXELS:
        at = (f"{float(texels_per_unit.min()):g}" if np.ptp(texels_per_unit) == 0
              else f"{float(texels_per_unit.min()):g}-{float(texels_per_unit.max()):g}")
        raise PatchlightError(f"{scene.label}: {world_area:.4g} m^2 at {at} texels per "
                              f"metre needs {needed:.3g} texels (limit {MAX_TEXELS}); lower `texels_per_unit` "
                              f"or set `resolution`")


def _round_up4(value):
    return int(math.ceil(value / 4.0)) * 4
