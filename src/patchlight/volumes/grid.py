"""The regular grid of light probes: where the probes sit, and how a grid is chosen.

Probe (i, j, k) sits at origin + (i, j, k) * spacing, i along X, j along Y, k along Z; arrays
of per-probe values are (NZ, NY, NX, ...) in C order, so x varies fastest (the order a 3D
texture of width NX, height NY and depth NZ is uploaded in).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import PatchlightError

MAX_PROBES = 10_000_000  # beyond this the bake takes hours and the volume gigabytes


@dataclass(frozen=True)
class ProbeGrid:
    """origin (3,) metres: the first probe; spacing (3,) metres between neighbours along X, Y,
    Z (> 0); dims (3,) probe counts (NX, NY, NZ), each >= 1."""

    origin: tuple[float, float, float]
    spacing: tuple[float, float, float]
    dims: tuple[int, int, int]

    @property
    def count(self) -> int:
        nx, ny, nz = self.dims
        return nx * ny * nz

    @property
    def shape(self) -> tuple[int, int, int]:
        """(NZ, NY, NX): the leading shape of per-probe arrays."""
        return self.dims[::-1]

    def positions(self) -> np.ndarray:
        """(NZ * NY * NX, 3) float32 probe positions, x fastest."""
        axes = [np.float64(o) + np.float64(s) * np.arange(n) for o, s, n in zip(self.origin, self.spacing, self.dims)]
        z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
        return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1).astype(np.float32)

    def to_json(self) -> dict:
        return {"origin": list(map(float, self.origin)), "spacing": list(map(float, self.spacing)),
                "dims": list(map(int, self.dims))}


def grid_over(lo, hi, spacing: float | None = None, dims=None) -> ProbeGrid:
    """The grid covering the box [lo, hi] (each (3,), metres).

    spacing: metres between probes, which sit at the centres of the cells that tile the box
    (centred on it, overhanging by less than one spacing): a floor or wall a whole number of
    spacings from a face of the box lies halfway between two layers of probes, never on one,
    where half of a probe's rays would meet back faces and its validity would flip between
    neighbours. dims: (NX, NY, NZ) probes from face to face (a single probe along an axis sits
    in the middle). Exactly one of the two is given. Refuses more than
    MAX_PROBES probes, saying how many were asked for."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    extent = hi - lo
    if (spacing is None) == (dims is None):
        raise ValueError("grid_over: give spacing or dims, not both")
    if spacing is not None:
        if not (spacing > 0 and math.isfinite(spacing)):
            raise PatchlightError(f"--spacing {spacing}: must be a positive number of metres")
        with np.errstate(over="ignore"):
            along = extent / spacing  # inf for a tiny spacing: no whole number to round to
        if not np.all(along < MAX_PROBES):
            axis = int(np.argmax(along))
            many = f"{float(along[axis]):.3g}" if math.isfinite(along[axis]) else "more than 1e308"
            raise PatchlightError(f"--spacing {spacing}: {many} probes along {'XYZ'[axis]} alone ({float(extent[axis]):g} m) "
                                  f"is more than the limit of {MAX_PROBES:,}; use a larger --spacing")
        counts = [max(1, math.ceil(a - 1e-9)) for a in along]
        step = np.full(3, float(spacing))
    else:
        counts = [int(n) for n in dims]
        if len(counts) != 3 or min(counts) < 1:
            raise PatchlightError(f"--dims {','.join(map(str, dims))}: expected three probe counts >= 1")
        flat = [axis for axis in range(3) if counts[axis] > 1 and extent[axis] <= 0]
        if flat:
            raise PatchlightError(f"--dims {','.join(map(str, counts))}: {counts[flat[0]]} probes along "
                                  f"{'XYZ'[flat[0]]}, where the box has no extent; use 1 there")
        step = np.array([e / (n - 1) if n > 1 else 1.0 for e, n in zip(extent, counts)])
    total = math.prod(counts)
    if total > MAX_PROBES:
        raise PatchlightError(f"{counts[0]} x {counts[1]} x {counts[2]} = {total:,} probes is more than "
                              f"the limit of {MAX_PROBES:,}; use a larger --spacing or smaller --dims")
    origin = (lo + hi) / 2 - step * (np.array(counts) - 1) / 2
    return ProbeGrid(tuple(map(float, origin)), tuple(map(float, step)), tuple(counts))


def check_overlap(lo, hi, scene_lo, scene_hi) -> None:
    """PatchlightError when the box [lo, hi] and the scene's bounds share no point."""
    if np.any(np.asarray(hi) < scene_lo) or np.any(np.asarray(lo) > scene_hi):
        box = ",".join(f"{v:g}" for v in [*lo, *hi])
        scene = ",".join(f"{v:g}" for v in [*scene_lo, *scene_hi])
        raise PatchlightError(f"--bounds {box}: outside the scene, whose bounds are {scene}")
