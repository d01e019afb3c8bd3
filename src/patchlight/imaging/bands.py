"""Elementwise work on an image in bands of rows: the float64 temporaries of a 4096 x 4096
map then take a band's memory, not the map's (writing a bake's pictures and lightmap
encodings beside texels.npz)."""
from __future__ import annotations

import numpy as np

BAND_ROWS = 256


def banded(fn, image: np.ndarray, dtype, shape: tuple | None = None) -> np.ndarray:
    """fn(rows) for bands of BAND_ROWS rows of image, cast into one array of dtype and shape
    (default: image's), as astype would cast the whole."""
    out = np.empty(image.shape if shape is None else shape, dtype)
    for first in range(0, image.shape[0], BAND_ROWS):
        out[first:first + BAND_ROWS] = fn(image[first:first + BAND_ROWS])
    return out
