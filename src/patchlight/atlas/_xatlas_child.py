"""What a forked child process runs: xatlas, which can crash (SIGSEGV) on some meshes.

`packed_npz` takes positions (V, 3) f32, indices (T, 3) u32, padding, texels_per_unit (0:
none) and resolution (0: none) and returns the bytes of an npz with vmapping (V',) u32
(source vertex of each output vertex), indices (T, 3) u32, uv (V', 2) f64 in texel units,
width, height, texels_per_unit, charts. With a resolution, texels_per_unit is searched so
the charts fill one page of that size. `die_with_parent` asks the kernel to kill the child
when its parent dies (PR_SET_PDEATHSIG), and exits at once if the parent is already gone.

For tests of the parent's fallback paths: PATCHLIGHT_XATLAS_CHILD_CRASH=1 makes the child
kill itself with SIGSEGV, PATCHLIGHT_XATLAS_CHILD_HANG=1 makes it wait for ever.
"""
from __future__ import annotations

import io
import os
import signal
import sys

import numpy as np

PR_SET_PDEATHSIG = 1  # linux/prctl.h
SHRINK_ATTEMPTS = 12
BISECTIONS = 4


def _pack_options(padding, texels_per_unit, resolution):
    import xatlas

    pack = xatlas.PackOptions()
    pack.padding = padding
    pack.bilinear = True
    pack.blockAlign = False
    pack.texels_per_unit = texels_per_unit
    pack.resolution = resolution
    return pack


class _Packing:
    """One packing's result: vmapping (V',) source vertex of each output vertex, indices
    (T, 3), uv (V', 2) in texel units, width, height, pages, texels_per_unit, charts."""

    def __init__(self, atlas, vmapping=None):
        own_vmapping, self.indices, uv = atlas[0]
        self.vmapping = own_vmapping if vmapping is None else vmapping[own_vmapping]
        self.width, self.height, self.pages = int(atlas.width), int(atlas.height), int(atlas.atlas_count)
        self.uv = uv.astype(np.float64) * np.array([self.width, self.height], np.float64)
        self.texels_per_unit, self.charts = float(atlas.texels_per_unit), int(atlas.chart_count)

    def fits(self, resolution) -> bool:
        return self.pages == 1 and self.width <= resolution and self.height <= resolution

    def overflow(self, resolution) -> float:
        return max(self.width / resolution, self.height / resolution, np.sqrt(self.pages))


def _generate(positions, indices, padding, texels_per_unit, resolution) -> _Packing:
    """xatlas's charts of the mesh, packed."""
    import xatlas

    atlas = xatlas.Atlas()
    atlas.add_mesh(positions, indices)
    atlas.generate(xatlas.ChartOptions(), _pack_options(padding, texels_per_unit, resolution))
    return _Packing(atlas)


def _repacker(first: _Packing, positions, padding, resolution):
    """Packs the charts of `first` again at another density, without computing them again:
    its charts as a UV mesh in metres (`_chart_shapes`; positions (V, 3) the mesh's), whose
    connected pieces are the charts. Charting took 0.43 s of each 0.46 s packing of a town
    of 11,340 triangles."""
    import xatlas

    uv_world = _chart_shapes(first, positions).astype(np.float32)
    indices = np.ascontiguousarray(first.indices, np.uint32)

    def pack(texels_per_unit):
        atlas = xatlas.Atlas()
        atlas.add_uv_mesh(uv_world, indices)
        atlas.generate(xatlas.ChartOptions(), _pack_options(padding, texels_per_unit, resolution))
        return _Packing(atlas, first.vmapping)
    return pack


def _chart_shapes(packing: _Packing, positions) -> np.ndarray:
    """(V', 2) f64 the packing's UVs in metres, chart by chart: each chart's texel UVs times
    the square root of its `_metrics`. xatlas rounds each chart's size up to whole texels,
    axis by axis, and shrinks a chart larger than the page: the UVs over the density alone
    would carry that stretch into every later packing, which adds its own."""
    indices = packing.indices.astype(np.int64)
    _, welded = np.unique(packing.uv, axis=0, return_inverse=True)  # a chart's triangles meet at equal UVs
    chart = _pieces(welded.reshape(-1)[indices], len(packing.uv))
    world = np.asarray(positions, np.float64)[packing.vmapping][indices]  # (T, 3, 3)
    uv = packing.uv[indices]
    du = (np.roll(uv, -1, axis=1) - uv).reshape(-1, 2)  # edges 01, 12, 20
    length2 = np.square(np.roll(world, -1, axis=1) - world).sum(axis=2).reshape(-1)
    fallback = np.eye(2) / packing.texels_per_unit ** 2
    values, vectors = np.linalg.eigh(_metrics(du, length2, np.repeat(chart, 3), int(chart.max(initial=-1)) + 1,
                                              fallback))
    root = vectors @ (np.sqrt(values)[:, :, None] * vectors.transpose(0, 2, 1))
    vertex_chart = np.zeros(len(packing.uv), np.int64)
    vertex_chart[indices.reshape(-1)] = np.repeat(chart, 3)
    return np.einsum("vij,vj->vi", root[vertex_chart], packing.uv)


def _metrics(du, length2, edge_chart, charts, fallback) -> np.ndarray:
    """(charts, 2, 2) per chart the symmetric positive metric M that best gives its edges du
    (E, 2) in texels their squared lengths length2 (E,) in square metres, du M du = length2
    (least squares on the relative error; linear in M's three entries), edge_chart (E,) each
    edge's chart; fallback (2, 2) where the fit has no unique or no positive answer."""
    used = length2 > 0
    rows = np.stack([du[:, 0] ** 2, 2 * du[:, 0] * du[:, 1], du[:, 1] ** 2], axis=1)[used] / length2[used, None]
    normal, rhs = np.zeros((charts, 3, 3)), np.zeros((charts, 3))
    np.add.at(normal, edge_chart[used], rows[:, :, None] * rows[:, None, :])
    np.add.at(rhs, edge_chart[used], rows)
    metric = np.broadcast_to(fallback, (charts, 2, 2)).copy()
    solvable = np.linalg.det(normal) > 1e-9 * (np.trace(normal, axis1=1, axis2=2) / 3) ** 3
    m = np.linalg.solve(normal[solvable], rhs[solvable][:, :, None])[:, :, 0]
    positive = (m[:, 0] > 0) & (m[:, 0] * m[:, 2] > m[:, 1] ** 2)
    metric[np.flatnonzero(solvable)[positive]] = np.stack([m[:, :2], m[:, 1:]], axis=1)[positive]  # [[a, b], [b, c]]
    return metric


def _pieces(indices, count) -> np.ndarray:
    """(T,) the connected piece (triangles that share vertices) of each triangle of indices
    (T, 3) over count vertices, numbered 0..: each vertex takes the lowest label of its
    triangles' vertices, labels jumping to their own label's, until nothing changes."""
    label = np.arange(count)
    while True:
        low = label[indices].min(axis=1)
        lower = label.copy()
        np.minimum.at(lower, indices.reshape(-1), np.repeat(low, 3))
        lower = lower[lower]
        if np.array_equal(lower, label):
            break
        label = lower
    return np.unique(label[indices[:, 0]], return_inverse=True)[1]


def _fitted(positions, indices, padding, resolution) -> _Packing:
    """The packing of the largest texel density found whose charts fit one resolution-sized
    page: xatlas's own estimate, shrunk (or grown) until it fits (or fails), then bisected;
    the charts are made once, by the first packing."""
    atlas = _generate(positions, indices, padding, 0.0, resolution)
    repack = _repacker(atlas, positions, padding, resolution)
    fitting, failing = None, None
    density = atlas.texels_per_unit
    for _ in range(SHRINK_ATTEMPTS):
        if atlas.fits(resolution):
            fitting = (density, atlas)
            break
        failing = density
        density *= min(0.9, 0.98 / atlas.overflow(resolution))
        atlas = repack(density)
    if fitting is None:
        raise SystemExit(f"xatlas could not fit the charts in {resolution}x{resolution}")
    limit = 64 * density
    while failing is None and density < limit:  # the estimate fitted: grow until it fails
        density *= 1.25
        atlas = repack(density)
        if atlas.fits(resolution):
            fitting = (density, atlas)
        else:
            failing = density
    for _ in range(BISECTIONS if failing is not None else 0):
        density = 0.5 * (fitting[0] + failing)
        atlas = repack(density)
        if atlas.fits(resolution):
            fitting = (density, atlas)
        else:
            failing = density
    return fitting[1]


def die_with_parent(parent: int) -> None:
    """SIGKILL from the kernel when the parent dies (Linux); exit now if it already has."""
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent:
        raise SystemExit("the parent process is gone")


def packed_npz(positions, indices, padding: int, texels_per_unit: float, resolution: int) -> bytes:
    """The npz bytes of xatlas's packing of the mesh (module docstring)."""
    if os.environ.get("PATCHLIGHT_XATLAS_CHILD_CRASH") == "1":
        os.kill(os.getpid(), signal.SIGSEGV)
    if os.environ.get("PATCHLIGHT_XATLAS_CHILD_HANG") == "1":
        signal.pause()
    if resolution > 0:
        packing = _fitted(positions, indices, padding, resolution)
    else:
        packing = _generate(positions, indices, padding, texels_per_unit, 0)
    out = io.BytesIO()
    np.savez(out, vmapping=packing.vmapping, indices=packing.indices, uv=packing.uv, width=packing.width,
             height=packing.height, texels_per_unit=packing.texels_per_unit, charts=packing.charts)
    return out.getvalue()
