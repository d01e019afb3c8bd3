"""Run xatlas in a child process, because it can crash (SIGSEGV) on some meshes.

Usage: python _xatlas_child.py IN.npz OUT.npz
IN holds positions (V, 3) f32, indices (T, 3) u32, padding, texels_per_unit (0: none) and
resolution (0: none).  OUT gets vmapping (V',) u32 (source vertex of each output vertex),
indices (T, 3) u32, uv (V', 2) f64 in texel units, width, height, texels_per_unit, charts.

With a resolution, texels_per_unit is searched so the single atlas fits in it: xatlas's own
estimate first, then shrunk until the charts fit on one page no larger than the resolution.
Setting PATCHLIGHT_XATLAS_CHILD_CRASH=1 makes the child kill itself with SIGSEGV (for tests
of the parent's fallback path).
"""
from __future__ import annotations

import os
import signal
import sys

import numpy as np

FIT_ATTEMPTS = 12


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
    """The atlas with the largest tried texel density whose charts fit one page of the resolution."""
    atlas = _generate(positions, indices, padding, 0.0, resolution)
    density = float(atlas.texels_per_unit)
    for _ in range(FIT_ATTEMPTS):
        if _fits(atlas, resolution):
            return atlas
        overflow = max(atlas.width, atlas.height) / resolution
        shrink = min(0.97, 0.98 / overflow) if atlas.atlas_count == 1 else 0.9 / np.sqrt(atlas.atlas_count)
        density *= shrink
        atlas = _generate(positions, indices, padding, density, resolution)
    if not _fits(atlas, resolution):
        raise SystemExit(f"xatlas could not fit the charts in {resolution}x{resolution}")
    return atlas


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
