"""Exposure: maps physical light to displayable values like a film, 1 - exp(-k x)."""
from __future__ import annotations

import numpy as np

from .bands import banded
from .color import LUMINANCE, linear_to_srgb

AUTO_PERCENTILE = 90.0  # auto exposure puts this percentile of the lit values ...
AUTO_TARGET = 0.8       # ... at this display value


def auto_exposure(values: np.ndarray) -> float:
    """k such that the 90th percentile of the positive luminances maps to 0.8."""
    lum = np.asarray(values, np.float64).reshape(-1, 3) @ LUMINANCE
    lit = lum[lum > 0]
    if lit.size == 0:
        return 1.0
    return float(-np.log(1.0 - AUTO_TARGET) / np.percentile(lit, AUTO_PERCENTILE))


def expose(values: np.ndarray, k: float) -> np.ndarray:
    """Linear display value in [0, 1): 1 - exp(-k x), elementwise."""
    return 1.0 - np.exp(-k * np.maximum(np.asarray(values, np.float64), 0.0))


def exposed_png_pixels(values: np.ndarray, k: float) -> np.ndarray:
    """(H, W, 3) uint8 sRGB picture of linear values exposed with k (in bands of rows)."""
    return banded(lambda rows: np.round(linear_to_srgb(expose(rows, k)) * 255), np.asarray(values), np.uint8)
