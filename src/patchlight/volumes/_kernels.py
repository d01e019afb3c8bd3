"""Numba kernel of the probe gather: what each row's rays see, summed with their weights."""
from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True, inline="always")
def _lightmap_bilinear(lightmap, s, t, c):
    """Channel c of the lightmap (H, W, 3) at UV (s, t), bilinear with edges clamped: the
    lookup of patchlight.shading.textures.sample_bilinear(wrap="clamp")."""
    h, w = lightmap.shape[0], lightmap.shape[1]
    x = s * np.float32(w) - np.float32(0.5)
    y = t * np.float32(h) - np.float32(0.5)
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    xa = min(max(int(x0), 0), w - 1)
    xb = min(max(int(x0) + 1, 0), w - 1)
    ya = min(max(int(y0), 0), h - 1)
    yb = min(max(int(y0) + 1, 0), h - 1)
    top = lightmap[ya, xa, c] * (1 - fx) + lightmap[ya, xb, c] * fx
    bottom = lightmap[yb, xa, c] * (1 - fx) + lightmap[yb, xb, c] * fx
    return top * (1 - fy) + bottom * fy


@nb.njit(cache=True, parallel=True)
def sum_rows(tri, u, v, back, dirs, weights, tri_uv1, lightmap, tri_rho, tri_emission, textured):
    """For R rows of D rays each (ray i = row * D + j, weight weights[j]):

    light (R, 3): the weighted excident light B = rho I + E of hits on untextured triangles
    that are not back faces (back (R * D,) bool, rays.inside.back_faces; tri_rho,
    tri_emission (T, 3) per triangle, I from the lightmap at the hit's lightmap UV, tri_uv1
    (T, 3, 2)); the caller adds the sky and textured hits. open_side (R, 3): the weighted sum
    of the directions of the rays that met no back face."""
    d = weights.shape[0]
    rows = tri.shape[0] // d
    light = np.zeros((rows, 3), np.float32)
    open_side = np.zeros((rows, 3), np.float32)
    for r in nb.prange(rows):
        for j in range(d):
            i = r * d + j
            if back[i]:
                continue
            t = tri[i]
            w = weights[j]
            for c in range(3):
                open_side[r, c] += w * dirs[i, c]
            if t < 0 or textured[t]:
                continue
            w0 = 1 - u[i] - v[i]
            s = w0 * tri_uv1[t, 0, 0] + u[i] * tri_uv1[t, 1, 0] + v[i] * tri_uv1[t, 2, 0]
            tt = w0 * tri_uv1[t, 0, 1] + u[i] * tri_uv1[t, 1, 1] + v[i] * tri_uv1[t, 2, 1]
            for c in range(3):
                light[r, c] += w * (tri_rho[t, c] * _lightmap_bilinear(lightmap, s, tt, c) + tri_emission[t, c])
    return light, open_side
