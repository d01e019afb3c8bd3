"""Filling probe values that lie inside geometry from valid neighbours.

A probe inside a wall sees only the wall's back faces, and a probe exactly on a wall's face
sees them on the axes that point into it; those values are meaningless, and a moving object
beside the wall interpolates between them and the probes in the room. So each invalid value
(probe, axis) takes the mean of the valid values of the same axis among the probe's 26
neighbours, weighted by 1 / distance^2 in grid steps (faces 1, edges 1/2, corners 1/3).
Rings grow inwards until every value is known: at most the grid's longest side in rings, as
each ring reaches one probe further. A value no ring reaches (an axis with no valid value
anywhere in the grid) takes the mean of every known value.

A probe with some valid axes (on a wall's face) has an open side, the mean direction of
its rays that met no back face: only neighbours within OPEN_SIDE_ANGLE of it count, so a
probe on a wall's inner face takes the room's light and not the light outside (a neighbour
across the wall, even nearly sideways, can be a hundred times brighter).

A probe whose every axis is invalid lies inside geometry, between places that may differ a
hundredfold (a dark room and the sunlit outside) with nothing to tell which one its values
stand for; its open side, if any, is no guide (rays leak through coincident faces where
two solid boxes touch, and point into the other box). So all 26 neighbours count, each
weight divided by the square of that neighbour's luminance (the mean over its known axes):
where the neighbours agree this is their mean; where they differ the dim side's light wins
(with room probes at L and outside ones at 100 L, the outside adds L / 100 per neighbour).
Sunlight leaking into an interior shows far more than a dim guess. Sampling reads these
values only where no valid probe is near (it weights each probe by its validity, 0 inside
geometry; patchlight.volumes.io, "Sampling"): deep inside geometry, or on a surface lying
on a plane of probes that are all inside geometry.
"""
from __future__ import annotations

import itertools

import numpy as np

from ..errors import PatchlightError
from ..shading.environment import LUMINANCE

OPEN_SIDE_ANGLE = 70.0  # degrees; face and diagonal neighbours into the room, none across the wall
DIM_FLOOR = 1e-3        # luminances below this x the mean one weigh as this: black is no infinity
_NEIGHBOURS = np.array([d for d in itertools.product((-1, 0, 1), repeat=3) if d != (0, 0, 0)])  # (dz, dy, dx)


def fill_invalid(cube: np.ndarray, invalid: np.ndarray, open_side: np.ndarray) -> np.ndarray:
    """cube (6, NZ, NY, NX, 3) with every value where invalid (6, NZ, NY, NX) is True replaced
    from its neighbours; open_side (NZ, NY, NX, 3): unit (x, y, z) direction into the open
    from each probe, or zero where it has none. Returns a new array."""
    known = ~invalid
    if not known.any():
        raise PatchlightError("every probe lies inside geometry: move `bounds` into the open part of the scene")
    if not np.isfinite(cube[known]).all():
        raise PatchlightError("probe values are not finite: the lightmap, sky or lights hold NaN or infinity")
    values = np.where(known[..., None], cube, 0.0).astype(np.float32)
    inside = invalid.all(axis=0)  # (NZ, NY, NX)
    side = [_side_weight(open_side, offset) * ~inside for offset in _NEIGHBOURS]  # inside: no open side
    _, nz, ny, nx = known.shape
    scale = float((values @ LUMINANCE)[known].mean()) or 1.0  # luminances relative to the mean known one
    for _ in range(max(nz, ny, nx)):
        if known.all():
            break
        # unknown values hold zeros, so they add nothing to the sums
        padded_known = np.pad(known.astype(np.float32), ((0, 0), (1, 1), (1, 1), (1, 1)))
        padded_values = np.pad(values, ((0, 0), (1, 1), (1, 1), (1, 1), (0, 0)))
        padded_dim = np.pad(_inverse_square_luminance(values, known, scale), 1)
        sums = {kind: (np.zeros_like(values), np.zeros(known.shape, np.float32)) for kind in ("open", "any")}
        for (dz, dy, dx), s in zip(_NEIGHBOURS, side):
            window = (slice(1 + dz, 1 + dz + nz), slice(1 + dy, 1 + dy + ny), slice(1 + dx, 1 + dx + nx))
            k, v = padded_known[(slice(None), *window)], padded_values[(slice(None), *window)]
            w = np.float32(1.0 / (dz * dz + dy * dy + dx * dx))
            lean = np.where(inside, padded_dim[window], np.float32(1))  # inside geometry: lean to the dim side
            for kind, factor in (("open", w * s), ("any", w * lean)):
                total, weight = sums[kind]
                total += factor[..., None] * v
                weight += factor * k
        (open_total, open_weight), (any_total, any_weight) = sums["open"], sums["any"]
        use_open = open_weight > 0
        total = np.where(use_open[..., None], open_total, any_total)
        weight = np.where(use_open, open_weight, any_weight)
        new = ~known & (weight > 0)
        values[new] = total[new] / weight[new][:, None]
        known = known | new
    values[~known] = values[known].mean(axis=0)  # unreached: no valid value on that axis anywhere
    return values


def _side_weight(open_side: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """(NZ, NY, NX) f32: 1 where the neighbour at `offset` (dz, dy, dx) lies within
    OPEN_SIDE_ANGLE of the probe's open side, or the probe has none; else 0."""
    direction = offset[::-1] / np.linalg.norm(offset)  # (x, y, z)
    within = open_side @ direction > np.cos(np.radians(OPEN_SIDE_ANGLE))
    none = ~np.any(open_side != 0, axis=-1)
    return (within | none).astype(np.float32)


def _inverse_square_luminance(values: np.ndarray, known: np.ndarray, scale: float) -> np.ndarray:
    """(NZ, NY, NX) f32: 1 / the square of the mean luminance of each probe's known values
    (6, NZ, NY, NX, 3) over `scale`, taken as at least DIM_FLOOR; 0 where it has none."""
    count = known.sum(axis=0)
    mean = (values @ LUMINANCE).sum(axis=0) / np.maximum(count, 1) / scale  # unknown values are zeros
    return np.where(count > 0, 1 / np.maximum(mean, DIM_FLOOR) ** 2, 0).astype(np.float32)
