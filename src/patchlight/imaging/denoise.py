"""Denoising a lightmap with Intel Open Image Denoise (its HDR lightmap filter)."""
from __future__ import annotations

import numpy as np


def denoise_lightmap(image: np.ndarray) -> np.ndarray:
    """(H, W, 3) f32 HDR lightmap denoised by OIDN's RTLightmap filter on the CPU."""
    import pyoidn

    clean = pyoidn.denoise(np.ascontiguousarray(image, np.float32), filter_type=pyoidn.OIDN_FILTER_TYPE_RT_LIGHTMAP)
    return np.maximum(clean, 0.0)
