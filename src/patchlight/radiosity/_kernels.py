"""Numba kernels of the gather: the item buffer lookup and the rows of F it makes."""
from __future__ import annotations

import numba as nb
import numpy as np

SKY = -1        # the ray escaped: it sees the sky
BACK_FACE = -2  # the ray hit a triangle from behind: the patch may lie inside geometry
LOST = -3       # the hit's lightmap texel is covered by no patch
NEIGHBOURS = np.array([[0, -1], [0, 1], [-1, 0], [1, 0], [-1, -1], [-1, 1], [1, -1], [1, 1]], np.int64)


@nb.njit(cache=True, nogil=True)
def resolve_hits(tri, u, v, front, tri_uv1, width, height, index):
    """The item buffer: the patch each ray sees, or SKY / BACK_FACE / LOST. (R,) i32.

    tri, u, v, front: the tracer's hits; tri_uv1: (T, 3, 2) lightmap UVs of each triangle's
    corners; index: (H, W) patch id per texel. A hit on an uncovered texel takes the nearest
    covered texel of its 3 x 3 neighbourhood.
    """
    out = np.empty(tri.shape[0], np.int32)
    for i in range(tri.shape[0]):
        t = tri[i]
        if t < 0:
            out[i] = SKY
            continue
        if not front[i]:
            out[i] = BACK_FACE
            continue
        w0 = 1.0 - u[i] - v[i]
        su = w0 * tri_uv1[t, 0, 0] + u[i] * tri_uv1[t, 1, 0] + v[i] * tri_uv1[t, 2, 0]
        sv = w0 * tri_uv1[t, 0, 1] + u[i] * tri_uv1[t, 1, 1] + v[i] * tri_uv1[t, 2, 1]
        x = min(max(int(su * width), 0), width - 1)
        y = min(max(int(sv * height), 0), height - 1)
        found = index[y, x]
        for k in range(8):  # nearest first: the four sides, then the corners
            if found >= 0:
                break
            yy, xx = y + NEIGHBOURS[k, 0], x + NEIGHBOURS[k, 1]
            if 0 <= yy < height and 0 <= xx < width:
                found = index[yy, xx]
        out[i] = found if found >= 0 else LOST
    return out


@nb.njit(cache=True)
def interpolate_in_order(G, status, targets, neighbours, computed, interpolated, inside):
    """Fill G (N, 3) in place at every non-computed target, in order, with the mean of its
    neighbours (K, 4; -1 = none) that already have values; none -> 0. Texels `inside` -> 0."""
    have = (status == computed) | (status == interpolated)
    for k in range(targets.shape[0]):
        t = targets[k]
        if status[t] == computed:
            continue
        count = 0
        acc0 = acc1 = acc2 = 0.0
        for j in range(neighbours.shape[1]):
            n = neighbours[k, j]
            if n >= 0 and have[n]:
                acc0 += G[n, 0]
                acc1 += G[n, 1]
                acc2 += G[n, 2]
                count += 1
        if count > 0:
            G[t, 0], G[t, 1], G[t, 2] = acc0 / count, acc1 / count, acc2 / count
            have[t] = True
        else:
            G[t, 0] = G[t, 1] = G[t, 2] = 0.0
    for i in range(G.shape[0]):
        if status[i] == inside:
            G[i, 0] = G[i, 1] = G[i, 2] = 0.0
    return G



@nb.njit(cache=True, nogil=True)
def item_buffer_rows(seen, weights, sky_radiance):
    """Turn the item buffer of R patches x D rays into their form-factor rows.

    seen: (R * D,) patch id or SKY / BACK_FACE / LOST per ray, patch by patch; weights: (D,)
    per-direction weights; sky_radiance: (number of SKY rays, 3) radiance seen, in ray order.
    Returns CSR (indptr (R+1,), indices, data; columns in first-seen order, duplicates
    summed), the sky term (R, 3) and the share of each patch's rays that hit back faces (R,).
    Duplicates meet in a hash table of 2 D slots, cleared per row: scratch space and work
    per ray stay constant however large the lightmap.
    """
    d = weights.shape[0]
    rows = seen.shape[0] // d
    size = 1
    while size < 2 * d:
        size *= 2
    keys = np.empty(size, np.int32)     # patch id in each slot, -1 = free
    slots = np.empty(size, np.int64)    # where that patch's entry is in indices / data
    indptr = np.zeros(rows + 1, np.int64)
    indices = np.empty(seen.shape[0], np.int32)
    data = np.empty(seen.shape[0], np.float32)
    sky = np.zeros((rows, 3), np.float32)
    back = np.zeros(rows, np.float32)
    nnz = 0
    k_sky = 0
    for r in range(rows):
        keys[:] = -1
        for j in range(d):
            s = seen[r * d + j]
            if s >= 0:
                h = (s * 2654435761) & (size - 1)  # Knuth's multiplicative hash
                while keys[h] != -1 and keys[h] != s:
                    h = (h + 1) & (size - 1)
                if keys[h] == s:
                    data[slots[h]] += weights[j]
                else:
                    keys[h] = s
                    slots[h] = nnz
                    indices[nnz] = s
                    data[nnz] = weights[j]
                    nnz += 1
            elif s == SKY:
                for c in range(3):
                    sky[r, c] += weights[j] * sky_radiance[k_sky, c]
                k_sky += 1
            elif s == BACK_FACE:
                back[r] += 1.0
        indptr[r + 1] = nnz
        back[r] /= d
    return indptr, indices[:nnz].copy(), data[:nnz].copy(), sky, back


@nb.njit(cache=True, nogil=True)
def item_buffer_times(seen, weights, B):
    """(R, 3) f32: each of R patches' weighted sum of the excident light B (N, 3) of the
    patches its D rays see (seen: (R * D,) as item_buffer_rows takes it), the row of F B
    straight from the item buffer, without storing F."""
    d = weights.shape[0]
    rows = seen.shape[0] // d
    out = np.zeros((rows, 3), np.float32)
    for r in range(rows):
        for j in range(d):
            s = seen[r * d + j]
            if s >= 0:
                for c in range(3):
                    out[r, c] += weights[j] * B[s, c]
    return out


@nb.njit(cache=True, nogil=True)
def csr_times_rgb(indptr, indices, data, B, first, last):
    """(last - first, 3) f32 product of rows first..last-1 of a CSR matrix (R x N, f32) with
    B (N, 3) f32, on the calling thread (the caller spreads row ranges over the cores).
    Accumulates in f32: rows hold a few hundred terms, far inside its precision."""
    out = np.zeros((last - first, 3), np.float32)
    for r in range(first, last):
        a0 = np.float32(0.0)
        a1 = np.float32(0.0)
        a2 = np.float32(0.0)
        for k in range(indptr[r], indptr[r + 1]):
            w = data[k]
            c = indices[k]
            a0 += w * B[c, 0]
            a1 += w * B[c, 1]
            a2 += w * B[c, 2]
        out[r - first, 0] = a0
        out[r - first, 1] = a1
        out[r - first, 2] = a2
    return out
