"""Filling texels from their neighbours: dilation past chart borders, and texels inside
geometry filled from valid ones."""
from __future__ import annotations

import numpy as np

from . import _kernels


def dilate(image: np.ndarray, known: np.ndarray, texels: int, allowed: np.ndarray | None = None) -> np.ndarray:
    """Grow `image` (H, W, C) f32 in place outward from the `known` (H, W) texels by `texels`
    rings: each unknown texel (within `allowed`, if given) next to known ones takes their
    mean. Returns the grown known mask, a new array."""
    allowed = np.ones(known.shape, bool) if allowed is None else np.asarray(allowed, bool)
    return _kernels.dilate_rings(image, np.asarray(known, bool), allowed, int(texels))
