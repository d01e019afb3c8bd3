"""Filling texels from their neighbours: dilation past chart borders, and texels inside
geometry filled from valid ones."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _kernels


def dilate(image: np.ndarray, known: np.ndarray, texels: int, allowed: np.ndarray | None = None) -> np.ndarray:
    """Grow `image` (H, W, C) f32 in place outward from the `known` (H, W) texels by `texels`
    rings: each unknown texel (within `allowed`, if given) next to known ones takes their
    mean. Returns the grown known mask, a new array."""
    plan = Dilation.of(known, texels, allowed)
    plan.apply(image)
    return plan.known


@dataclass
class Dilation:
    """A dilation worked out once (`_kernels.dilation_plan`: which texels are filled, from
    which) and applied to any number of images of the same texels: targets (K,), sources
    (K, 4) flat texel indices, known (H, W) bool the grown mask."""

    targets: np.ndarray
    sources: np.ndarray
    known: np.ndarray

    @classmethod
    def of(cls, known: np.ndarray, texels: int, allowed: np.ndarray | None = None) -> Dilation:
        """The dilation of `dilate`: `texels` rings from the `known` (H, W) texels, within `allowed`."""
        allowed = np.ones(known.shape, bool) if allowed is None else np.asarray(allowed, bool)
        return cls(*_kernels.dilation_plan(np.asarray(known, bool), allowed, int(texels)))

    def apply(self, image: np.ndarray) -> None:
        """Fill image (H, W, C) f32 in place."""
        _kernels.apply_dilation(image, self.targets, self.sources)
