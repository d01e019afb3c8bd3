"""Patches: one per covered lightmap texel, as a structure of arrays.

A patch is the radiosity article's patch of paint: it has emission, reflectance, and
(later, in radiosity/) incident and excident light. Rows are ordered by texel (y, x).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Patches:
    """N patches of a W x H lightmap.

    texel_y, texel_x: (N,) i32 texel row and column (row 0 is v = 0, the image top).
    position: (N, 3) f32 world-space point on the surface at the texel centre (on a chart's
    rim: the centroid of the texel's overlap with its triangle, see atlas/raster.py).  normal: (N, 3) f32 unit interpolated normal.
    triangle: (N,) i32 the triangle the texel samples.  rho: (N, 3) f32 reflectance (linear
    base colour, averaged over the texel's footprint).  emission: (N, 3) f32 radiance.
    chart: (N,) i32 UV chart id (texels of different charts are never interpolated together).
    size: (N,) f32 world-space edge length of the texel (for ray offsets).
    index: (H, W) i32 patch id of each texel, -1 where no triangle covers it.
    """

    width: int
    height: int
    texel_y: np.ndarray
    texel_x: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    triangle: np.ndarray
    rho: np.ndarray
    emission: np.ndarray
    chart: np.ndarray
    size: np.ndarray
    index: np.ndarray

    def __len__(self) -> int:
        return int(self.texel_y.shape[0])

    def to_image(self, values: np.ndarray, fill: float = 0.0) -> np.ndarray:
        """Scatter per-patch values (N, C) into an (H, W, C) image; uncovered texels = fill."""
        values = np.asarray(values)
        out = np.full((self.height, self.width) + values.shape[1:], fill, values.dtype)
        out[self.texel_y, self.texel_x] = values
        return out
