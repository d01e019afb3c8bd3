"""Run xatlas in a child process, because it can crash (SIGSEGV) on some meshes.

Usage: python _xatlas_child.py PARENT_PID < IN.npz > OUT.npz
IN holds positions (V, 3) f32, indices (T, 3) u32, padding, texels_per_unit (0: none) and
resolution (0: none).  OUT gets vmapping (V',) u32 (source vertex of each output vertex),
indices (T, 3) u32, uv (V', 2) f64 in texel units, width, height, texels_per_unit, charts.
The child asks the kernel to kill it when its parent dies (PR_SET_PDEATHSIG), and exits at
once if the parent is already gone; it writes no file.

With a resolution, texels_per_unit is searched so the charts fill one page of that size.
Setting PATCHLIGHT_XATLAS_CHILD_CRASH=1 makes the child kill itself with SIGSEGV (for tests
of the parent's fallback path).
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


def _generate(positions, indices, padding, texels_per_unit, resolution):
    import xatlas

    atlas = xatlas.Atlas()
    atlas.add_mesh(positions, indices)
    pack = xatlas.PackOptions()
    pack.padding = padding
    pack.bilinear = True
    pack.blockAlign = False
    pack.texels_per_unit = texels_per_unit
    pack.resolution = resolution
    atlas.generate(xatlas.ChartOptions(), pack)
    return atlas


def _fits(atlas, resolution):
    return atlas.atlas_count == 1 and atlas.width <= resolution and atlas.height <= resolution


def _fitted(positions, indices, padding, resolution):
    """The atlas of the largest texel density found whose charts fit one resolution-sized page:
    xatlas's own estimate, shrunk (or grown) until it fits (or fails), then bisected."""
    atlas = _generate(positions, indices, padding, 0.0, resolution)
    fitting, failing = None, None
    density = float(atlas.texels_per_unit)
    for _ in range(SHRINK_ATTEMPTS):
        if _fits(atlas, resolution):
            fitting = (density, atlas)
            break
        failing = density
        overflow = max(atlas.width / resolution, atlas.height / resolution, np.sqrt(atlas.atlas_count))
        density *= min(0.9, 0.98 / overflow)
        atlas = _generate(positions, indices, padding, density, resolution)
    if fitting is None:
        raise SystemExit(f"xatlas could not fit the charts in {resolution}x{resolution}")
    limit = 64 * density
    while failing is None and density < limit:  # the estimate fitted: grow until it fails
        density *= 1.25
        atlas = _generate(positions, indices, padding, density, resolution)
        if _fits(atlas, resolution):
            fitting = (density, atlas)
        else:
            failing = density
    for _ in range(BISECTIONS if failing is not None else 0):
        density = 0.5 * (fitting[0] + failing)
        atlas = _generate(positions, indices, padding, density, resolution)
        if _fits(atlas, resolution):
            fitting = (density, atlas)
        else:
            failing = density
    return fitting[1]


def _die_with_parent(parent: int) -> None:
    """SIGKILL from the kernel when the parent dies (Linux); exit now if it already has."""
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent:
        raise SystemExit("the parent process is gone")


def main(argv):
    _die_with_parent(int(argv[0]))
    if os.environ.get("PATCHLIGHT_XATLAS_CHILD_CRASH") == "1":
        os.kill(os.getpid(), signal.SIGSEGV)
    if os.environ.get("PATCHLIGHT_XATLAS_CHILD_HANG") == "1":  # tests: a child that never ends
        signal.pause()
    result = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # anything xatlas prints goes to stderr, not into the result
    with np.load(io.BytesIO(sys.stdin.buffer.read())) as data:
        positions = np.ascontiguousarray(data["positions"], np.float32)
        indices = np.ascontiguousarray(data["indices"], np.uint32)
        padding = int(data["padding"])
        texels_per_unit = float(data["texels_per_unit"])
        resolution = int(data["resolution"])
    if resolution > 0:
        atlas = _fitted(positions, indices, padding, resolution)
    else:
        atlas = _generate(positions, indices, padding, texels_per_unit, 0)
    vmapping, out_indices, uv = atlas[0]
    width, height = int(atlas.width), int(atlas.height)
    uv_texels = uv.astype(np.float64) * np.array([width, height], np.float64)
    with result:
        np.savez(result, vmapping=vmapping, indices=out_indices, uv=uv_texels, width=width, height=height,
                 texels_per_unit=float(atlas.texels_per_unit), charts=int(atlas.chart_count))


if __name__ == "__main__":
    main(sys.argv[1:])
