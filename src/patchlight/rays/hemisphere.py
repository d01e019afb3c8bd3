"""The hemisphere ray pattern every gatherer casts: one pattern of directions around the
normal, turned about it by a golden-ratio angle of each point's row, so neighbouring points look
through differently turned patterns and a pattern's aliasing becomes fine noise instead of bands
a texel high along whole walls (measured up to 30 % at hemicube 32 in the room); a re-gather of
the same row sees the same rays."""
from __future__ import annotations

import numba as nb
import numpy as np

GOLDEN = 0.6180339887498949  # the golden ratio's fractional part


@nb.njit(cache=True, inline="always")
def row_angle(row, seed):
    """The rotation (radians) of the pattern about the normal of row `row`: 2 pi times the
    fractional part of (row + seed) x golden ratio."""
    x = (np.float64(row) + seed) * GOLDEN
    return (2 * np.pi) * (x - np.floor(x))


@nb.njit(cache=True, inline="always")
def _basis(n):
    """Orthonormal tangent and bitangent for unit normal n (Duff et al. 2017), as tuples."""
    sign = 1.0 if n[2] >= 0.0 else -1.0
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return (1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]), (b, sign + n[1] * n[1] * a, -n[1])


@nb.njit(cache=True, nogil=True)
def hemisphere_rays(position, normal, offset, rows, local_dirs, seed):
    """Origins and directions (len(rows) * D, 3) f32 for the patches `rows`.

    position, normal: (N, 3); offset: (N,) distance to lift each origin along its normal;
    local_dirs: (D, 3) directions with z along the normal, turned about each patch's normal
    by its `row_angle` (of its row and `seed`).
    """
    d = local_dirs.shape[0]
    origins = np.empty((rows.shape[0] * d, 3), np.float32)
    dirs = np.empty((rows.shape[0] * d, 3), np.float32)
    local = local_dirs.astype(np.float64)
    lx, ly, lz = local[:, 0].copy(), local[:, 1].copy(), local[:, 2].copy()  # contiguous columns
    for k in range(rows.shape[0]):
        p = rows[k]
        n = (np.float64(normal[p, 0]), np.float64(normal[p, 1]), np.float64(normal[p, 2]))
        t, s = _basis(n)
        angle = row_angle(p, seed)
        c, si = np.cos(angle), np.sin(angle)
        tx, ty, tz = c * t[0] + si * s[0], c * t[1] + si * s[1], c * t[2] + si * s[2]  # t, s turned
        sx, sy, sz = -si * t[0] + c * s[0], -si * t[1] + c * s[1], -si * t[2] + c * s[2]
        nx, ny, nz = n[0], n[1], n[2]
        ox, oy, oz = (position[p, 0] + offset[p] * normal[p, 0], position[p, 1] + offset[p] * normal[p, 1],
                      position[p, 2] + offset[p] * normal[p, 2])
        first = k * d
        for i in range(first, first + d):  # origins, then directions: two simple loops run faster than one
            origins[i, 0], origins[i, 1], origins[i, 2] = ox, oy, oz
        for j in range(d):
            i = first + j
            dirs[i, 0] = lx[j] * tx + ly[j] * sx + lz[j] * nx
            dirs[i, 1] = lx[j] * ty + ly[j] * sy + lz[j] * ny
            dirs[i, 2] = lx[j] * tz + ly[j] * sz + lz[j] * nz
    return origins, dirs
