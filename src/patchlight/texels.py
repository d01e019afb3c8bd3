"""texels.npz: a bake's per-texel arrays, beside lightmap.exr in the bake directory.

The one owner of this file (writer and reader). It keeps what the viewer's pass slider,
value probe and patch view read, all (H, W, ...) in lightmap texels, row 0 at v = 0:

    passes    (P, H, W, 3) float16  incident light I after each pass, filled and dilated as
                                    lightmap.exr is, not seam-stitched (pass 1: direct + sky
                                    + emitters)
    status    (H, W) int8           STATUS_NAMES index: uncovered, gathered, interpolated, inside
    chart     (H, W) int32          UV chart id, -1 uncovered
    rho       (H, W, 3) float32     reflectance the bake gave the patch
    emission  (H, W, 3) float32     emitted radiance
    excident  (H, W, 3) float32     B = rho I + E of the final solution (what other patches see)

np.savez_compressed: uncovered texels are zeros, so the file stays small (the room at
128 x 128 with 19 passes: about 0.6 MB).
"""
from __future__ import annotations

import io
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import PatchlightError

TEXELS_FILE = "texels.npz"
STATUS_NAMES = ("uncovered", "gathered", "interpolated", "inside geometry")
UNCOVERED = 0  # status of a texel no triangle covers; 1.. are the sampler's COMPUTED, INTERPOLATED, INSIDE


@dataclass
class Texels:
    """The arrays of texels.npz (see the module docstring)."""

    passes: np.ndarray
    status: np.ndarray
    chart: np.ndarray
    rho: np.ndarray
    emission: np.ndarray
    excident: np.ndarray

    def to_bytes(self) -> bytes:
        buffer = io.BytesIO()
        np.savez_compressed(buffer, passes=self.passes.astype(np.float16), status=self.status.astype(np.int8),
                            chart=self.chart.astype(np.int32), rho=self.rho.astype(np.float32),
                            emission=self.emission.astype(np.float32), excident=self.excident.astype(np.float32))
        return buffer.getvalue()


def read_bake_texels(bake_dir: str | Path) -> Texels | None:
    """The bake's texels.npz, or None when the bake has none (written before it existed);
    PatchlightError when it is damaged."""
    path = Path(bake_dir) / TEXELS_FILE
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            texels = Texels(**{name: data[name] for name in Texels.__dataclass_fields__})
    except (OSError, KeyError, ValueError, zipfile.BadZipFile) as exc:
        raise PatchlightError(f"{path}: not a readable texels file ({exc})") from None
    h, w = texels.status.shape
    if texels.passes.ndim != 4 or texels.passes.shape[1:] != (h, w, 3) or texels.excident.shape != (h, w, 3):
        raise PatchlightError(f"{path}: arrays of mismatched shapes")
    if not all(np.isfinite(a).all() for a in (texels.passes, texels.rho, texels.emission, texels.excident)):
        raise PatchlightError(f"{path}: values that are not finite")
    if texels.status.min() < 0 or texels.status.max() >= len(STATUS_NAMES):
        raise PatchlightError(f"{path}: texel status outside 0..{len(STATUS_NAMES) - 1}")
    return texels
