"""Numba kernel for the barycentric interpolation of per-vertex arrays (surface.interpolate)."""
from __future__ import annotations

import numba


@numba.njit(parallel=True, cache=True)
def interpolate_rows(values, corners, bary, out):
    """out[n] = sum_k bary[n, k] values[corners[n, k]] for values (V, C), corners (N, 3) int,
    bary (N, 3) and out (N, C), all float32 except corners."""
    n, c = out.shape
    for i in numba.prange(n):
        a, b, d = corners[i, 0], corners[i, 1], corners[i, 2]
        wa, wb, wd = bary[i, 0], bary[i, 1], bary[i, 2]
        for j in range(c):
            out[i, j] = values[a, j] * wa + values[b, j] * wb + values[d, j] * wd
