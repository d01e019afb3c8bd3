"""A light volume: a grid of ambient cubes, each the incident light from six axis directions.

The value of axis a at a probe is the incident light I (cosine-weighted mean
radiance) that a small patch at the probe facing along a would receive: a uniform
environment of radiance L gives L on all six axes. Axis order follows the article's two
vectors posLum and negLum: +X, +Y, +Z, then -X, -Y, -Z.

The compact form is the article's "light colour and six intensity values": intensity_a is
the Rec. 709 luminance of axis a's RGB, and the colour is the sum of the six RGB values over
the sum of the six intensities (so its luminance is 1). colour x intensity_a gives back axis
a's RGB exactly when all six share one chromaticity, as under a single light; otherwise the
six directions share the probe's mean chromaticity.

Validity says how far a probe's values may be trusted when a point between probes is lit:
1 for a probe in the open, 0 for one inside geometry, whose values are only guesses filled
in from its neighbours (a probe inside a wall between a dark room and the sunlit outside
sees neither). Sampling weights each of a cell's eight corners by its validity
(patchlight.shading.ambient_cube), so a point in the room beside the wall reads the room's
probes and not the wall's, as Unity's adaptive probe volumes do with their probe validity.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..shading.ambient_cube import sky_cube
from ..shading.environment import LUMINANCE
from .grid import ProbeGrid

AXES = ("+X", "+Y", "+Z", "-X", "-Y", "-Z")
AXIS_VECTORS = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [0, -1, 0], [0, 0, -1]], np.float32)


@dataclass
class LightVolume:
    """grid: where the probes are; cube (6, NZ, NY, NX, 3) f32 incident light per axis (AXES
    order); inside (NZ, NY, NX) bool: probes found inside geometry, whose values were filled
    in from valid neighbours; validity (NZ, NY, NX) f32 in [0, 1]: each probe's weight when
    points between probes are lit (module docstring), by default 0 inside geometry, else 1."""

    grid: ProbeGrid
    cube: np.ndarray
    inside: np.ndarray
    validity: np.ndarray | None = None

    def __post_init__(self):
        shape = self.grid.shape
        if self.validity is None:
            self.validity = np.where(self.inside, 0.0, 1.0).astype(np.float32)
        if self.cube.shape != (6, *shape, 3) or self.inside.shape != shape or self.validity.shape != shape:
            raise ValueError(f"LightVolume: cube {self.cube.shape} / inside {self.inside.shape} / validity "
                             f"{self.validity.shape} do not match the grid's {shape}")
        if not np.all((self.validity >= 0) & (self.validity <= 1)):
            raise ValueError("LightVolume: validity must lie in 0..1 (what read_volume accepts)")



def sky_volume(sky, ground, ambient) -> LightVolume:
    """The ambient-cube model's volume when none was baked: one probe holding
    patchlight.shading.ambient_cube.sky_cube(sky, ground, ambient)."""
    cube = sky_cube(sky, ground, ambient)[:, None, None, None, :]
    return LightVolume(ProbeGrid((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (1, 1, 1)), cube, np.zeros((1, 1, 1), bool))

def compact(cube: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The article's compact form of cube (6, ..., 3): colour (..., 3) with luminance 1 (white
    where the probe is black) and intensities (6, ...), the luminance of each axis."""
    intensity = (cube @ LUMINANCE).astype(np.float32)
    total = intensity.sum(axis=0)
    summed = cube.sum(axis=0)
    safe = np.where(total > 0, total, 1.0)[..., None]
    color = np.where(total[..., None] > 0, summed / safe, 1.0).astype(np.float32)
    return color, intensity


def expand(color: np.ndarray, intensity: np.ndarray) -> np.ndarray:
    """cube (6, ..., 3) from the compact form: colour (..., 3) x each axis' intensity (6, ...)."""
    return (color[None] * intensity[..., None]).astype(np.float32)
