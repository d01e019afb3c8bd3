"""Run xatlas in a child process, because it can crash (SIGSEGV) on some meshes.

Usage: python _xatlas_child.py IN.npz OUT.npz
IN holds positions (V, 3) f32, indices (T, 3) u32, padding, texels_per_unit (0: none) and
resolution (0: none).  OUT gets vmapping (V',) u32 (source vertex of each output vertex),
indices (T, 3) u32, uv (V', 2) f64 in texel units, width, height, texels_per_unit, charts.

With a resolution, texels_per_unit is searched so the charts fill one page of that size.
Setting PATCHLIGHT_XATLAS_CHILD_CRASH=1 makes the child kill itself with SIGSEGV (for tests
of the parent's fallback path).
"""
from __future__ import annotations

import os
import signal
import sys

import numpy as np

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


def main(argv):
    if os.environ.get("PATCHLIGHT_XATLAS_CHILD_CRASH") == "1":
        os.kill(os.getpid(), signal.SIGSEGV)
    source, target = argv
    with np.load(source) as data:
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
    partial = target + ".part"
    with open(partial, "wb") as stream:
        np.savez(stream, vmapping=vmapping, indices=out_indices, uv=uv_texels, width=width, height=height,
                 texels_per_unit=float(atlas.texels_per_unit), charts=int(atlas.chart_count))
    os.replace(partial, target)


if __name__ == "__main__":
    main(sys.argv[1:])
