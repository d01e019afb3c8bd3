"""The sRGB transfer curves (IEC 61966-2-1), exact piecewise form.

Both functions take any float array (or scalar) and return an array of the same shape;
float32 input stays float32, anything else becomes float64.
"""
from __future__ import annotations

import numpy as np

# The two segments meet at encoded 0.04045 == linear 0.0031308 (to the standard's rounding).
_SRGB_KNEE = 0.04045
_LINEAR_KNEE = 0.0031308
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 / sRGB weights of linear R, G, B


def _float_array(a) -> np.ndarray:
    arr = np.asarray(a)
    return arr if arr.dtype == np.float32 else arr.astype(np.float64)


def srgb_to_linear(a) -> np.ndarray:
    """Decode sRGB-encoded values to linear: c/12.92 below the knee, ((c+0.055)/1.055)^2.4 above."""
    c = _float_array(a)
    curve = ((np.maximum(c, _SRGB_KNEE) + 0.055) / 1.055) ** 2.4
    return np.where(c <= _SRGB_KNEE, c / 12.92, curve).astype(c.dtype)


def linear_to_srgb(a) -> np.ndarray:
    """Encode linear values as sRGB: 12.92 c below the knee, 1.055 c^(1/2.4) - 0.055 above."""
    c = _float_array(a)
    curve = 1.055 * np.maximum(c, _LINEAR_KNEE) ** (1 / 2.4) - 0.055
    return np.where(c <= _LINEAR_KNEE, c * 12.92, curve).astype(c.dtype)
