"""Chart seams: one 3-D edge that lies in two places of the lightmap.

Two triangles share a 3-D edge when its end points have bit-identical positions; the edge is
a seam when the two triangles give those end points different lightmap UVs (the unwrap cut
the surface there) but the same normals (within SMOOTH): the surface runs on smoothly, so
lookups on either side should read the same light (`patchlight.imaging.stitch`). Where the
normals differ (a room's corner, a box's edge) the light differs rightly and the edge is no seam."""
from __future__ import annotations

import numpy as np

from .uvs import edge_codes

SMOOTH = 0.9998  # cosine between the two sides' normals at both end points (1.1 degrees)


def seam_edges(positions: np.ndarray, normals: np.ndarray, indices: np.ndarray,
               uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(uv_a, uv_b), each (S, 2, 2): the UVs of both end points of each seam on its two sides,
    end points in the same order on both sides. Edges met by more than two triangles are left out."""
    if len(indices) == 0:
        return np.zeros((0, 2, 2)), np.zeros((0, 2, 2))
    corner = np.ascontiguousarray(positions[indices].reshape(-1, 3), np.float32) + np.float32(0.0)
    keys = np.unique(corner.view(np.dtype((np.void, 12))).ravel(), return_inverse=True)[1].reshape(-1, 3)
    code = edge_codes(keys).ravel()                               # (T * 3,) edge k of triangle t
    order = np.argsort(code, kind="stable")
    sorted_code = code[order]
    starts = np.flatnonzero(np.r_[True, sorted_code[1:] != sorted_code[:-1]])
    counts = np.diff(np.r_[starts, len(code)])
    pairs = starts[counts == 2]
    first, second = order[pairs], order[pairs + 1]
    ends_a = _edge_ends(indices, keys, first)
    ends_b = _edge_ends(indices, keys, second)
    flip = keys.ravel()[ends_b[:, 0]] != keys.ravel()[ends_a[:, 0]]  # order b's end points as a's
    ends_b[flip] = ends_b[flip][:, ::-1]
    flat_uv = np.asarray(uv, np.float64)[indices].reshape(-1, 2)
    uv_a, uv_b = flat_uv[ends_a], flat_uv[ends_b]
    flat_normal = np.asarray(normals, np.float64)[indices].reshape(-1, 3)
    smooth = np.all(np.einsum("ijk,ijk->ij", flat_normal[ends_a], flat_normal[ends_b]) > SMOOTH, axis=1)
    seam = np.any(uv_a != uv_b, axis=(1, 2)) & smooth
    return uv_a[seam], uv_b[seam]


def _edge_ends(indices, keys, edge) -> np.ndarray:
    """(E, 2) flat corner numbers (t * 3 + k) of the end points of flat edges t * 3 + k."""
    t, k = edge // 3, edge % 3
    return np.stack([t * 3 + k, t * 3 + (k + 1) % 3], axis=1)
