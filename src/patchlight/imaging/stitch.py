"""Seam stitching: texels on both sides of a chart seam made to agree by least squares.

Along each seam (`patchlight.atlas.seams`) points are taken every half texel; at each, the
bilinear lookup (texel centres at (i + 0.5) / size, edges clamped: what the runtime's lightmap
sampler reads) on one side should equal the lookup on the other. The texels those lookups
touch are solved for, per channel, minimising

    sum_texels keep (x - x0)^2 + STRENGTH sum_points (lookup_a(x) - lookup_b(x))^2

so every other texel stays exactly as it was and the seam texels move as little as agreement
allows (Sloan's "stitching"). keep is 1 for valid texels and KEEP_INVALID for texels that hold
no light of their own (dilated margins, texels inside geometry), which simply follow.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import factorized

STRENGTH = 1e3        # weight of a seam point's disagreement against a texel's change
KEEP_INVALID = 1e-3   # weight keeping a texel without light of its own at its value
POINTS_PER_TEXEL = 2  # seam points per texel of seam length (on the longer side)


def seam_points(uv_a: np.ndarray, uv_b: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(P, 2) matching lightmap UVs on side a and side b of the seams (S, 2, 2)."""
    scale = np.array([width, height], np.float64)
    length = np.maximum(np.linalg.norm((uv_a[:, 1] - uv_a[:, 0]) * scale, axis=1),
                        np.linalg.norm((uv_b[:, 1] - uv_b[:, 0]) * scale, axis=1))
    n = np.maximum(1, np.ceil(length * POINTS_PER_TEXEL)).astype(np.int64)
    seam = np.repeat(np.arange(len(n)), n)
    t = ((np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) + 0.5) / n[seam]
    lerp = lambda uv: uv[seam, 0] + t[:, None] * (uv[seam, 1] - uv[seam, 0])  # noqa: E731
    return lerp(uv_a), lerp(uv_b)


def bilinear_weights(uv: np.ndarray, width: int, height: int) -> sp.csr_matrix:
    """(P, H W) sparse: row p holds the bilinear weights of the texels a lookup at uv[p] reads."""
    x = uv[:, 0] * width - 0.5
    y = uv[:, 1] * height - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    rows, cols, vals = [], [], []
    for dy, wy in ((0, 1 - fy), (1, fy)):
        for dx, wx in ((0, 1 - fx), (1, fx)):
            xi = np.clip(x0 + dx, 0, width - 1).astype(np.int64)
            yi = np.clip(y0 + dy, 0, height - 1).astype(np.int64)
            rows.append(np.arange(len(uv)))
            cols.append(yi * width + xi)
            vals.append(wx * wy)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(len(uv), width * height))


def seam_differences(image: np.ndarray, uv_a: np.ndarray, uv_b: np.ndarray) -> np.ndarray:
    """(P,) relative difference |a - b| / mean(a, b) of the lookups across the seams (luminance
    of the channel means; points where both sides are dark, below 1e-6, count as 0)."""
    h, w = image.shape[:2]
    pa, pb = seam_points(uv_a, uv_b, w, h)
    flat = image.reshape(h * w, -1)
    a = _lookups(bilinear_weights(pa, w, h), flat).mean(axis=1)
    b = _lookups(bilinear_weights(pb, w, h), flat).mean(axis=1)
    mean = 0.5 * (np.abs(a) + np.abs(b))
    return np.divide(np.abs(a - b), mean, out=np.zeros_like(mean), where=mean > 1e-6)


def _lookups(weights: sp.csr_matrix, flat: np.ndarray) -> np.ndarray:
    """(P, C) f64 weights (P, H W) @ flat (H W, C), reading (in float64) only the texels
    the weights touch: not a float64 copy of the whole image."""
    texels = np.unique(weights.indices)
    return weights[:, texels] @ flat[texels].astype(np.float64)


def stitch(image: np.ndarray, uv_a: np.ndarray, uv_b: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """image (H, W, C) with its seams (S, 2, 2) stitched; valid (H, W) bool: texels holding
    light of their own. Returns a new float32 array."""
    h, w = image.shape[:2]
    out = np.array(image, np.float32)
    if len(uv_a) == 0:
        return out
    pa, pb = seam_points(uv_a, uv_b, w, h)
    D = (bilinear_weights(pa, w, h) - bilinear_weights(pb, w, h)).tocsc()
    touched = np.flatnonzero(np.diff(D.indptr))
    D = D[:, touched]
    keep = np.where(valid.ravel()[touched], 1.0, KEEP_INVALID)
    solve = factorized((sp.diags(keep) + STRENGTH * (D.T @ D)).tocsc())
    flat = out.reshape(h * w, -1)
    for c in range(flat.shape[1]):
        flat[touched, c] = solve(keep * flat[touched, c].astype(np.float64))
    return out
