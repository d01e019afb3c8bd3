"""Filling probe values that lie inside geometry from valid neighbours.

A probe inside a wall sees only the wall's back faces, and a probe exactly on a wall's face
sees them on the axes that point into it; those values are meaningless, and a moving object
beside the wall interpolates between them and the probes in the room. So each invalid value
(probe, axis) takes the mean of the valid values of the same axis among the probe's 26
neighbours, weighted by 1 / distance^2 in grid steps (faces 1, edges 1/2, corners 1/3). When the probe has an open
side (the mean direction of its rays that met no back face), only neighbours within
OPEN_SIDE_ANGLE of it count, so a probe on a wall's inner face takes the room's light and
not the light outside (a neighbour across the wall, even nearly sideways, can be a hundred
times brighter). Rings grow inwards until every value is known.
"""
from __future__ import annotations

import itertools

import numpy as np

from ..errors import PatchlightError

OPEN_SIDE_ANGLE = 70.0  # degrees; face and diagonal neighbours into the room, none across the wall
_NEIGHBOURS = np.array([d for d in itertools.product((-1, 0, 1), repeat=3) if d != (0, 0, 0)])  # (dz, dy, dx)


def fill_invalid(cube: np.ndarray, invalid: np.ndarray, open_side: np.ndarray) -> np.ndarray:
    """cube (6, NZ, NY, NX, 3) with every value where invalid (6, NZ, NY, NX) is True replaced
    from its neighbours; open_side (NZ, NY, NX, 3): unit (x, y, z) direction into the open
    from each probe, or zero where it has none. Returns a new array."""
    known = ~invalid
    if not known.any():
        raise PatchlightError("every probe lies inside geometry: move --bounds into the open part of the scene")
    values = np.where(known[..., None], cube, 0.0).astype(np.float32)
    side = [_side_weight(open_side, offset) for offset in _NEIGHBOURS]
    _, nz, ny, nx = known.shape
    while not known.all():
        # unknown values hold zeros, so they add nothing to the sums
        padded_known = np.pad(known.astype(np.float32), ((0, 0), (1, 1), (1, 1), (1, 1)))
        padded_values = np.pad(values, ((0, 0), (1, 1), (1, 1), (1, 1), (0, 0)))
        sums = {kind: (np.zeros_like(values), np.zeros(known.shape, np.float32)) for kind in ("open", "any")}
        for (dz, dy, dx), s in zip(_NEIGHBOURS, side):
            window = (slice(None), slice(1 + dz, 1 + dz + nz), slice(1 + dy, 1 + dy + ny), slice(1 + dx, 1 + dx + nx))
            k, v = padded_known[window], padded_values[window]
            w = np.float32(1.0 / (dz * dz + dy * dy + dx * dx))
            for kind, factor in (("open", w * s), ("any", w)):
                total, weight = sums[kind]
                total += np.asarray(factor)[..., None] * v
                weight += factor * k
        (open_total, open_weight), (any_total, any_weight) = sums["open"], sums["any"]
        use_open = open_weight > 0
        total = np.where(use_open[..., None], open_total, any_total)
        weight = np.where(use_open, open_weight, any_weight)
        new = ~known & (weight > 0)
        values[new] = total[new] / weight[new][:, None]
        known = known | new
    return values


def _side_weight(open_side: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """(NZ, NY, NX) f32: 1 where the neighbour at `offset` (dz, dy, dx) lies within
    OPEN_SIDE_ANGLE of the probe's open side, or the probe has none; else 0."""
    direction = offset[::-1] / np.linalg.norm(offset)  # (x, y, z)
    within = open_side @ direction > np.cos(np.radians(OPEN_SIDE_ANGLE))
    none = ~np.any(open_side != 0, axis=-1)
    return (within | none).astype(np.float32)
