"""The regular grid of light probes: where the probes sit, and how a grid is chosen.

Probe (i, j, k) sits at origin + (i, j, k) * spacing, i along X, j along Y, k along Z; arrays
of per-probe values are (NZ, NY, NX, ...) in C order, so x varies fastest (the order a 3D
texture of width NX, height NY and depth NZ is uploaded in).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import setting, validate_fields
from ..errors import PatchlightError, SettingError

MAX_PROBES = 10_000_000  # beyond this the bake takes hours and the volume gigabytes
PROBES_ALONG_LONGEST = 16  # the default spacing puts this many probes along the longest side


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


@dataclass
class GridSettings:
    """Where the probes go (table: docs/settings.md): every `spacing` metres, or `dims` probes
    (not both), over `bounds` (X0, Y0, Z0, X1, Y1, Z1 metres) or the scene's bounds."""

    spacing: float | None = setting(None, "m", "distance between probes", lo=0, lo_open=True,
                                    none=f"the longest side / {PROBES_ALONG_LONGEST - 1}")
    dims: tuple | None = setting(None, "probes", "probe counts along X, Y and Z, from face to face", lo=1,
                                 whole=True, length=3, none="from the spacing")
    bounds: tuple | None = setting(None, "m", "the box filled with probes: X0, Y0, Z0, X1, Y1, Z1", length=6,
                                   none="the scene's bounds")

    def validate(self) -> None:
        validate_fields(self)
        if self.spacing is not None and self.dims is not None:
            raise PatchlightError("give `spacing` or `dims`, not both")
        if self.bounds is not None:
            values = np.asarray(self.bounds, np.float64)
            lo, hi = values[:3], values[3:]
            if np.any(hi < lo):
                raise SettingError("bounds", self.bounds, "must be at least X0, Y0, Z0 in each of X1, Y1, Z1")
            with np.errstate(over="ignore"):  # probes are traced in float32: corners and size must fit
                if not (np.all(np.isfinite(values.astype(np.float32)))
                        and np.all(np.isfinite((hi - lo).astype(np.float32)))):
                    raise SettingError("bounds", self.bounds, "are too large for float32 positions (beyond 3.4e38 m)")

    def grid(self, scene_lo, scene_hi) -> ProbeGrid:
        """The grid these settings give in a scene of bounds scene_lo, scene_hi (3,) metres;
        SettingError when the bounds lie outside the scene."""
        self.validate()
        lo, hi = np.asarray(scene_lo, np.float64), np.asarray(scene_hi, np.float64)
        if self.bounds is not None:
            box = np.asarray(self.bounds, np.float64)
            if np.any(box[3:] < lo) or np.any(box[:3] > hi):
                scene = ",".join(f"{v:g}" for v in [*lo, *hi])
                raise SettingError("bounds", self.bounds, f"lie outside the scene, whose bounds are {scene}")
            lo, hi = box[:3], box[3:]
        if self.dims is not None:
            return grid_over(lo, hi, dims=self.dims)
        spacing = self.spacing
        if spacing is None:
            spacing = max(float((hi - lo).max()), 1e-3) / (PROBES_ALONG_LONGEST - 1)
        return grid_over(lo, hi, spacing=spacing)


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
    GridSettings(spacing=spacing, dims=None if dims is None else tuple(dims)).validate()
    if spacing is not None:
        with np.errstate(over="ignore"):
            along = extent / spacing  # inf for a tiny spacing: no whole number to round to
        if not np.all(along < MAX_PROBES):
            axis = int(np.argmax(along))
            many = f"{float(along[axis]):.3g}" if math.isfinite(along[axis]) else "more than 1e308"
            raise SettingError("spacing", spacing, f"is too small: {many} probes along {'XYZ'[axis]} alone "
                               f"({float(extent[axis]):g} m), more than the limit of {MAX_PROBES:,}")
        counts = [max(1, math.ceil(a - 1e-9)) for a in along]
        step = np.full(3, float(spacing))
    else:
        counts = [int(n) for n in dims]
        flat = [axis for axis in range(3) if counts[axis] > 1 and extent[axis] <= 0]
        if flat:
            raise SettingError("dims", tuple(counts), f"put {counts[flat[0]]} probes along {'XYZ'[flat[0]]}, where "
                               f"the box has no extent; use 1 there")
        step = np.array([e / (n - 1) if n > 1 else 1.0 for e, n in zip(extent, counts)])
    total = math.prod(counts)
    if total > MAX_PROBES:
        raise PatchlightError(f"{counts[0]} x {counts[1]} x {counts[2]} = {total:,} probes is more than "
                              f"the limit of {MAX_PROBES:,}; use a larger `spacing` or smaller `dims`")
    origin = (lo + hi) / 2 - step * (np.array(counts) - 1) / 2
    return ProbeGrid(tuple(map(float, origin)), tuple(map(float, step)), tuple(counts))
