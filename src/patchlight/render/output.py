"""Writing renders: .exr holds linear float radiance (no exposure, no tone curve); .png the
display values (film exposure, then sRGB; display.glsl), 8 bits. Both written atomically."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import PatchlightError
from ..imaging.io import write_exr, write_png
from ..shading.terms import display_encode

OUTPUT_SUFFIXES = (".png", ".exr")


def check_output(path) -> Path:
    """`path` as a Path, or PatchlightError when its suffix or directory will not do."""
    path = Path(path)
    if path.suffix.lower() not in OUTPUT_SUFFIXES:
        raise PatchlightError(f"-o {path}: write .png (exposed sRGB) or .exr (linear radiance)")
    if not path.parent.resolve().is_dir():
        raise PatchlightError(f"-o {path}: directory {path.parent} does not exist")
    return path


def display_pixels(radiance: np.ndarray, exposure: float) -> np.ndarray:
    """(H, W, 3) uint8 display values of linear radiance, as the viewer's canvas holds them."""
    return np.round(display_encode(radiance, exposure) * 255).astype(np.uint8)


def write_render(path, radiance: np.ndarray, exposure: float) -> None:
    """Write (H, W, 3) radiance to a .exr (as is) or .png (display_pixels)."""
    path = check_output(path)
    if path.suffix.lower() == ".exr":
        write_exr(path, radiance)
    else:
        write_png(path, display_pixels(radiance, exposure))
