"""Filling texels from their neighbours: dilation past chart borders, and texels inside
geometry filled from valid ones."""
from __future__ import annotations

import numpy as np

_OFFSETS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


def _shift(a: np.ndarray, dy: int, dx: int) -> np.ndarray:
    """a moved by (dy, dx), zero-filled at the border."""
    out = np.zeros_like(a)
    h, w = a.shape[:2]
    out[max(dy, 0):h + min(dy, 0), max(dx, 0):w + min(dx, 0)] = a[max(-dy, 0):h - max(dy, 0), max(-dx, 0):w - max(dx, 0)]
    return out


def dilate(image: np.ndarray, known: np.ndarray, texels: int, allowed: np.ndarray | None = None):
    """Grow `image` (H, W, C) outward from the `known` (H, W) texels by `texels` rings: each
    unknown texel (within `allowed`, if given) next to known ones takes their mean.
    Returns (image, known) as new arrays."""
    image = image.copy()
    known = known.copy()
    for _ in range(texels):
        total = np.zeros_like(image, dtype=np.float64)
        count = np.zeros(known.shape, np.float64)
        for dy, dx in _OFFSETS:
            k = _shift(known, dy, dx)
            total += _shift(image * known[..., None], dy, dx)
            count += k
        grow = ~known & (count > 0)
        if allowed is not None:
            grow &= allowed
        if not grow.any():
            break
        image[grow] = (total[grow] / count[grow][:, None]).astype(image.dtype)
        known = known | grow
    return image, known
