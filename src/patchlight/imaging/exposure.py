"""Exposure: maps physical light to displayable values like a film, 1 - exp(-k x)."""
from __future__ import annotations

import numpy as np

AUTO_PERCENTILE = 90.0  # auto exposure puts this percentile of the lit values ...
AUTO_TARGET = 0.8       # ... at this display value


def auto_exposure(values: np.ndarray) -> float:
    """k such that the 90th percentile of the positive luminances maps to 0.8."""
    lum = np.asarray(values, np.float64).reshape(-1, 3) @ np.array([0.2126, 0.7152, 0.0722])
    lit = lum[lum > 0]
    if lit.size == 0:
        return 1.0
    return float(-np.log(1.0 - AUTO_TARGET) / np.percentile(lit, AUTO_PERCENTILE))


def expose(values: np.ndarray, k: float) -> np.ndarray:
    """Linear display value in [0, 1): 1 - exp(-k x), elementwise."""
    return 1.0 - np.exp(-k * np.maximum(np.asarray(values, np.float64), 0.0))


def to_srgb8(display: np.ndarray) -> np.ndarray:
    """uint8 sRGB encoding of linear display values in [0, 1]."""
    x = np.clip(display, 0.0, 1.0)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.round(srgb * 255).astype(np.uint8)


def exposed_png_pixels(values: np.ndarray, k: float) -> np.ndarray:
    """(H, W, 3) uint8 sRGB picture of linear values exposed with k."""
    return to_srgb8(expose(values, k))


def rgbm_encode(values: np.ndarray, value_range: float) -> np.ndarray:
    """(H, W, 4) uint8 RGBM: rgb = value / (m range), m = alpha in (0, 1], all linear.
    Decode: value = rgb * a * range."""
    v = np.maximum(np.asarray(values, np.float64), 0.0) / value_range
    m = np.clip(v.max(axis=-1, keepdims=True), 1e-6, 1.0)
    m = np.ceil(m * 255) / 255
    rgb = np.clip(v / m, 0.0, 1.0)
    return np.round(np.concatenate([rgb, m], -1) * 255).astype(np.uint8)
