"""The ground map's planar mapping: world (x, y, z) to map (u, v), and back to texel centres.

The map looks straight down (-Y) with +X to the right, so +Z runs down the picture: column
j covers x in area [x0, x1], row i covers z in [z0, z1], and row 0 (v = 0, the top row of
the image, glTF's UV convention) lies along z = z0. The mapping is affine and ignores y:

    u = U . (x, y, z, 1),  U = (1 / (x1 - x0), 0, 0, -x0 / (x1 - x0))
    v = V . (x, y, z, 1),  V = (0, 0, 1 / (z1 - z0), -z0 / (z1 - z0))

U and V are the two rows the article's vertex shader dots the (offset) vertex position
with (Listing 1, VS_RADIOSITY_U and VS_RADIOSITY_V).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


MAX_SIZE = 16384  # texels per side; the largest 2D texture WebGL2 implementations commonly allow


@dataclass(frozen=True)
class GroundArea:
    """The rectangle x0 < x1, z0 < z1 (metres) that the map covers."""

    x0: float
    z0: float
    x1: float
    z1: float

    @property
    def U(self) -> np.ndarray:
        """(4,) float64 row with u = U . (x, y, z, 1)."""
        w = self.x1 - self.x0
        return np.array([1.0 / w, 0.0, 0.0, -self.x0 / w])

    @property
    def V(self) -> np.ndarray:
        """(4,) float64 row with v = V . (x, y, z, 1)."""
        d = self.z1 - self.z0
        return np.array([0.0, 0.0, 1.0 / d, -self.z0 / d])

    def texel_size(self, size: int) -> tuple[float, float]:
        """Metres per texel along x and z for a size x size map."""
        return (self.x1 - self.x0) / size, (self.z1 - self.z0) / size

    def texel_centres(self, size: int) -> np.ndarray:
        """(size, size, 2) float64 world (x, z) of each texel centre; [i, j] is row i, column j."""
        dx, dz = self.texel_size(size)
        x = self.x0 + (np.arange(size) + 0.5) * dx
        z = self.z0 + (np.arange(size) + 0.5) * dz
        zz, xx = np.meshgrid(z, x, indexing="ij")
        return np.stack([xx, zz], axis=-1)

    def to_json(self) -> list[float]:
        return [self.x0, self.z0, self.x1, self.z1]


def map_uv(area: GroundArea, points: np.ndarray) -> np.ndarray:
    """(N, 2) map (u, v) of world points (N, 3), by the U and V rows."""
    p = np.asarray(points, np.float64)
    h = np.concatenate([p, np.ones((len(p), 1))], axis=1)
    return np.stack([h @ area.U, h @ area.V], axis=1)


def square_area(lo: np.ndarray, hi: np.ndarray) -> GroundArea:
    """The square around the x, z extent of bounds (lo, hi) (3,), so texels are square."""
    cx, cz = (lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2
    half = max(hi[0] - lo[0], hi[2] - lo[2], 1e-3) / 2
    return GroundArea(float(cx - half), float(cz - half), float(cx + half), float(cz + half))
