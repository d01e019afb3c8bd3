"""Numba kernels of the atlas stage: texel rasterisation, texel attributes, chart layout.

Every kernel takes and returns arrays only. Lightmap texel coordinates are (x, y) with
x = u * W and y = v * H, so texel (row y, column x) is the square [x, x+1] x [y, y+1] and
row 0 is v = 0 (the image top, as glTF UVs are).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

# |twice the signed area| <= DEGENERATE * (longest edge)^2 makes a triangle a segment or a point.
DEGENERATE = 1e-12
CENTRE_SCORE = 2.0  # beats any overlap area (at most 1 texel^2)
RASTER_BANDS = 16  # bands of texel rows rasterised in parallel


# ----------------------------------------------------------------------------------------
# Conservative rasterisation: which triangle owns each texel
# ----------------------------------------------------------------------------------------

@njit(cache=True)
def _edge_planes(tex, t, nx, ny, d):
    """Fill nx, ny, d (3,) with triangle t's outward edge normals: inside is n.p <= d."""
    sign = 1.0 if _area2(tex, t) > 0.0 else -1.0
    for k in range(3):
        px, py = tex[t, k, 0], tex[t, k, 1]
        qx, qy = tex[t, (k + 1) % 3, 0], tex[t, (k + 1) % 3, 1]
        nx[k] = sign * (qy - py)
        ny[k] = -sign * (qx - px)
        d[k] = nx[k] * px + ny[k] * py


@njit(cache=True)
def _clip_square(x, y, nx, ny, d, work):
    """Clip the texel square [x, x+1] x [y, y+1] by the half-planes n.p <= d (3 of them).

    work: (2, 2, 8) f64 scratch (two polygons, x/y, up to 7 vertices used).
    Returns (count, polygon): the result is work[polygon, :, :count] (count < 3: empty)."""
    src, dst = 0, 1
    work[src, 0, 0], work[src, 1, 0] = x, y
    work[src, 0, 1], work[src, 1, 1] = x + 1.0, y
    work[src, 0, 2], work[src, 1, 2] = x + 1.0, y + 1.0
    work[src, 0, 3], work[src, 1, 3] = x, y + 1.0
    count = 4
    for k in range(3):
        out = 0
        for i in range(count):
            j = (i + 1) % count
            px, py = work[src, 0, i], work[src, 1, i]
            qx, qy = work[src, 0, j], work[src, 1, j]
            fp = nx[k] * px + ny[k] * py - d[k]
            fq = nx[k] * qx + ny[k] * qy - d[k]
            if fp <= 0.0:
                work[dst, 0, out], work[dst, 1, out] = px, py
                out += 1
            if (fp < 0.0 < fq) or (fq < 0.0 < fp):
                s = fp / (fp - fq)
                work[dst, 0, out] = px + s * (qx - px)
                work[dst, 1, out] = py + s * (qy - py)
                out += 1
        count = out
        src, dst = dst, src
        if count < 3:
            return 0, src
    return count, src


@njit(cache=True)
def _polygon_moments(work, polygon, count):
    """(area, centroid x, centroid y) of work[polygon, :, :count]; area 0 when degenerate."""
    area2, mx, my = 0.0, 0.0, 0.0
    for i in range(count):
        j = (i + 1) % count
        px, py = work[polygon, 0, i], work[polygon, 1, i]
        qx, qy = work[polygon, 0, j], work[polygon, 1, j]
        cross = px * qy - qx * py
        area2 += cross
        mx += (px + qx) * cross
        my += (py + qy) * cross
    if abs(area2) < 1e-300:
        return 0.0, 0.0, 0.0
    return 0.5 * abs(area2), mx / (3.0 * area2), my / (3.0 * area2)


@njit(cache=True)
def _clipped_area(x, y, nx, ny, d, work):
    """Area of the texel square [x, x+1] x [y, y+1] inside the half-planes n.p <= d."""
    count, polygon = _clip_square(x, y, nx, ny, d, work)
    return _polygon_moments(work, polygon, count)[0] if count >= 3 else 0.0


@njit(cache=True)
def _claim(owner, best, x, y, t, score):
    if score > best[y, x]:
        best[y, x] = score
        owner[y, x] = t


@njit(cache=True, parallel=True)
def rasterize_owners(tex, live, width, height):
    """Conservatively rasterise triangles into a W x H texel grid.

    tex: (T, 3, 2) f64 corners in texel units.  live: (T,) bool, False skips a triangle.
    A texel is touched by a triangle when the interiors of the texel square and the triangle
    intersect (for a triangle of zero UV area, a segment or point: when it meets the closed
    square).  Among the triangles touching a texel the owner is the first one covering the
    texel centre, else the one overlapping it most; zero-area triangles win only texels nobody
    else touches.  Returns owner (H, W) i32, -1 where no triangle touches the texel.
    Bands of rows run in parallel, each taking the triangles in order over its own rows.
    """
    owner = np.empty((height, width), np.int32)
    best = np.empty((height, width))  # 2 = covers the centre, else overlap area, 0 = zero-area touch
    bands = min(height, RASTER_BANDS)
    for band in prange(bands):
        first, last = band * height // bands, (band + 1) * height // bands
        owner[first:last] = -1
        best[first:last] = -1.0
        _rasterize_rows(tex, live, width, first, last, owner, best)
    return owner


@njit(cache=True)
def _rasterize_rows(tex, live, width, first, last, owner, best):
    """`rasterize_owners` over texel rows first..last-1 only."""
    nx = np.empty(3)
    ny = np.empty(3)
    d = np.empty(3)
    work = np.empty((2, 2, 8))
    for t in range(tex.shape[0]):
        if not live[t]:
            continue
        ax, ay = tex[t, 0, 0], tex[t, 0, 1]
        bx, by = tex[t, 1, 0], tex[t, 1, 1]
        cx, cy = tex[t, 2, 0], tex[t, 2, 1]
        area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        longest2 = max((bx - ax) ** 2 + (by - ay) ** 2, (cx - bx) ** 2 + (cy - by) ** 2,
                       (ax - cx) ** 2 + (ay - cy) ** 2)
        minx, maxx = min(ax, bx, cx), max(ax, bx, cx)
        miny, maxy = min(ay, by, cy), max(ay, by, cy)
        if not (np.isfinite(area2) and np.isfinite(longest2)):
            continue
        degenerate = abs(area2) <= DEGENERATE * longest2
        if degenerate:  # closed square: every texel the segment or point meets
            x0, x1 = int(np.ceil(minx)) - 1, int(np.floor(maxx))
            y0, y1 = int(np.ceil(miny)) - 1, int(np.floor(maxy))
        else:  # open interiors: texels merely sharing a boundary line are not touched
            x0, x1 = int(np.floor(minx)), int(np.ceil(maxx)) - 1
            y0, y1 = int(np.floor(miny)), int(np.ceil(maxy)) - 1
        x0, x1 = max(x0, 0), min(x1, width - 1)
        y0, y1 = max(y0, first), min(y1, last - 1)
        if x0 > x1 or y0 > y1:
            continue
        if degenerate:
            _rasterize_segment(owner, best, t, tex, longest2, x0, x1, y0, y1)
            continue
        _edge_planes(tex, t, nx, ny, d)
        for y in range(y0, y1 + 1):
            for x in range(x0, x1 + 1):
                touched = True
                centre = True
                for k in range(3):
                    square_min = nx[k] * x + ny[k] * y + min(nx[k], 0.0) + min(ny[k], 0.0)
                    if square_min >= d[k]:
                        touched = False
                        break
                    if nx[k] * (x + 0.5) + ny[k] * (y + 0.5) > d[k]:
                        centre = False
                if not touched:
                    continue
                score = CENTRE_SCORE if centre else _clipped_area(x, y, nx, ny, d, work)
                _claim(owner, best, x, y, t, score)


@njit(cache=True, nogil=True)
def owned_texels(owner):
    """The texels of an `owner` (H, W) i32 grid (`rasterize_owners`) that a triangle owns, in
    (y, x) order: texel_y, texel_x, triangle (N,) i32, and index (H, W) i32, each texel's
    row in those (-1: no owner)."""
    height, width = owner.shape
    index = np.empty((height, width), np.int32)
    n = 0
    for y in range(height):
        for x in range(width):
            index[y, x] = n if owner[y, x] >= 0 else -1
            n += owner[y, x] >= 0
    texel_y = np.empty(n, np.int32)
    texel_x = np.empty(n, np.int32)
    triangle = np.empty(n, np.int32)
    for y in range(height):
        for x in range(width):
            row = index[y, x]
            if row >= 0:
                texel_y[row], texel_x[row], triangle[row] = y, x, owner[y, x]
    return texel_y, texel_x, triangle, index


@njit(cache=True, inline="always")
def _covered_and_not(s, excluded):
    """Whether a texel of patch s (-1: uncovered) is covered by a patch not `excluded` (N,) bool:
    the one rule of a texel with light of its own (excluded: inside geometry) and of one a
    fill may write (excluded: walled)."""
    return s >= 0 and not excluded[s]


@njit(cache=True, parallel=True)
def texels_covered_and_not(index, excluded):
    """(H, W) bool: `_covered_and_not` for every texel of the patch index (H, W) i32. Rows in parallel."""
    height, width = index.shape
    out = np.empty((height, width), np.bool_)
    for y in prange(height):
        for x in range(width):
            out[y, x] = _covered_and_not(index[y, x], excluded)
    return out


@njit(cache=True, parallel=True)
def lightmap_texels(index, values, inside, walled):
    """Per-patch values (N, C) as a lightmap image through the patch index (H, W) i32: image
    (H, W, C) f32 (0 where no patch), valid (H, W) bool the texels of patches not inside
    geometry (inside (N,) bool, as `texels_covered_and_not`) and fillable (H, W) bool those
    of patches not walled (walled (N,) bool). Rows in parallel."""
    height, width = index.shape
    image = np.empty((height, width, values.shape[1]), np.float32)
    valid = np.empty((height, width), np.bool_)
    fillable = np.empty((height, width), np.bool_)
    for y in prange(height):
        for x in range(width):
            s = index[y, x]
            for c in range(values.shape[1]):
                image[y, x, c] = values[s, c] if s >= 0 else 0.0
            valid[y, x] = _covered_and_not(s, inside)
            fillable[y, x] = _covered_and_not(s, walled)
    return image, valid, fillable


@njit(cache=True)
def _rasterize_segment(owner, best, t, tex, longest2, x0, x1, y0, y1):
    """Touch (score 0) the texels whose closed square meets a zero-area triangle."""
    # the longest edge carries the segment's line
    k_best, length_best = 0, -1.0
    for k in range(3):
        px, py = tex[t, k, 0], tex[t, k, 1]
        qx, qy = tex[t, (k + 1) % 3, 0], tex[t, (k + 1) % 3, 1]
        length = (qx - px) ** 2 + (qy - py) ** 2
        if length > length_best:
            k_best, length_best = k, length
    px, py = tex[t, k_best, 0], tex[t, k_best, 1]
    qx, qy = tex[t, (k_best + 1) % 3, 0], tex[t, (k_best + 1) % 3, 1]
    nx, ny = qy - py, -(qx - px)
    d = nx * px + ny * py
    for y in range(y0, y1 + 1):
        for x in range(x0, x1 + 1):
            if longest2 > 0.0:
                lo = nx * x + ny * y + min(nx, 0.0) + min(ny, 0.0)
                hi = nx * x + ny * y + max(nx, 0.0) + max(ny, 0.0)
                if lo > d or hi < d:
                    continue
            _claim(owner, best, x, y, t, 0.0)


# ----------------------------------------------------------------------------------------
# Texel attributes: position, normal, reflectance, emission
# ----------------------------------------------------------------------------------------

@njit(cache=True)
def clamped_barycentrics(px, py, ax, ay, bx, by, cx, cy):
    """Barycentrics (l0, l1, l2) of the point of triangle abc nearest to p (2D).

    Inside the triangle these are p's own barycentrics; outside (or for a zero-area
    triangle) p is projected onto the nearest point of the triangle's edges."""
    area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    longest2 = max((bx - ax) ** 2 + (by - ay) ** 2, (cx - bx) ** 2 + (cy - by) ** 2,
                   (ax - cx) ** 2 + (ay - cy) ** 2)
    if abs(area2) > DEGENERATE * longest2:
        l1 = ((px - ax) * (cy - ay) - (py - ay) * (cx - ax)) / area2
        l2 = ((bx - ax) * (py - ay) - (by - ay) * (px - ax)) / area2
        l0 = 1.0 - l1 - l2
        if l0 >= 0.0 and l1 >= 0.0 and l2 >= 0.0:
            return l0, l1, l2
    best = np.inf
    r0, r1, r2 = 1.0, 0.0, 0.0
    for k in range(3):
        if k == 0:
            sx, sy, ex, ey = ax, ay, bx, by
        elif k == 1:
            sx, sy, ex, ey = bx, by, cx, cy
        else:
            sx, sy, ex, ey = cx, cy, ax, ay
        length2 = (ex - sx) ** 2 + (ey - sy) ** 2
        s = 0.0
        if length2 > 0.0:
            s = min(max(((px - sx) * (ex - sx) + (py - sy) * (ey - sy)) / length2, 0.0), 1.0)
        dist2 = (sx + s * (ex - sx) - px) ** 2 + (sy + s * (ey - sy) - py) ** 2
        if dist2 < best:
            best = dist2
            if k == 0:
                r0, r1, r2 = 1.0 - s, s, 0.0
            elif k == 1:
                r0, r1, r2 = 0.0, 1.0 - s, s
            else:
                r0, r1, r2 = s, 0.0, 1.0 - s
    return r0, r1, r2


@njit(cache=True)
def texel_centre_barycentrics(tex, triangle, texel_y, texel_x):
    """(N, 3) clamped barycentrics of each texel centre on its triangle (tex (T, 3, 2) texel units)."""
    out = np.empty((triangle.shape[0], 3))
    for i in range(triangle.shape[0]):
        t = triangle[i]
        out[i, 0], out[i, 1], out[i, 2] = clamped_barycentrics(
            texel_x[i] + 0.5, texel_y[i] + 0.5, tex[t, 0, 0], tex[t, 0, 1], tex[t, 1, 0], tex[t, 1, 1],
            tex[t, 2, 0], tex[t, 2, 1])
    return out


@njit(cache=True)
def affine_barycentrics(px, py, ax, ay, bx, by, cx, cy):
    """Barycentrics of p extended affinely beyond triangle abc (may be negative); for a
    zero-area triangle, where no affine map exists, those of the nearest point."""
    area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    longest2 = max((bx - ax) ** 2 + (by - ay) ** 2, (cx - bx) ** 2 + (cy - by) ** 2,
                   (ax - cx) ** 2 + (ay - cy) ** 2)
    if abs(area2) <= DEGENERATE * longest2:
        return clamped_barycentrics(px, py, ax, ay, bx, by, cx, cy)
    l1 = ((px - ax) * (cy - ay) - (py - ay) * (cx - ax)) / area2
    l2 = ((bx - ax) * (py - ay) - (by - ay) * (px - ax)) / area2
    return 1.0 - l1 - l2, l1, l2


@njit(cache=True)
def _wrap(i, n):
    return ((i % n) + n) % n


@njit(cache=True)
def _fetch_bilinear(data, offset, width, height, u, v):
    """Bilinear RGB sample (r, g, b) at (u, v): repeat wrap, v = 0 is the top row."""
    if not (np.isfinite(u) and np.isfinite(v)):
        u, v = 0.0, 0.0
    fx = u * width - 0.5
    fy = v * height - 0.5
    x0f, y0f = np.floor(fx), np.floor(fy)
    wx, wy = fx - x0f, fy - y0f
    x0 = _wrap(np.int64(x0f), width)
    y0 = _wrap(np.int64(y0f), height)
    x1 = _wrap(x0 + 1, width)
    y1 = _wrap(y0 + 1, height)
    i00 = offset + y0 * width + x0
    i01 = offset + y0 * width + x1
    i10 = offset + y1 * width + x0
    i11 = offset + y1 * width + x1
    w00, w01 = (1.0 - wx) * (1.0 - wy), wx * (1.0 - wy)
    w10, w11 = (1.0 - wx) * wy, wx * wy
    r = w00 * data[i00, 0] + w01 * data[i01, 0] + w10 * data[i10, 0] + w11 * data[i11, 0]
    g = w00 * data[i00, 1] + w01 * data[i01, 1] + w10 * data[i10, 1] + w11 * data[i11, 1]
    b = w00 * data[i00, 2] + w01 * data[i01, 2] + w10 * data[i10, 2] + w11 * data[i11, 2]
    return r, g, b


@njit(cache=True)
def _footprint_mean(data, offset, width, height, texel_x, texel_y, samples, ax, ay, bx, by, cx, cy,
                    u0, v0, u1, v1, u2, v2):
    """Mean RGB of a texture over samples x samples points of a texel, each mapped to uv0
    through the triangle's affine uv1 -> uv0 map (corner uv0s (u0, v0) .. (u2, v2))."""
    r, g, b = 0.0, 0.0, 0.0
    for sy in range(samples):
        for sx in range(samples):
            px = texel_x + (sx + 0.5) / samples
            py = texel_y + (sy + 0.5) / samples
            s0, s1, s2 = affine_barycentrics(px, py, ax, ay, bx, by, cx, cy)
            dr, dg, db = _fetch_bilinear(data, offset, width, height, s0 * u0 + s1 * u1 + s2 * u2,
                                         s0 * v0 + s1 * v1 + s2 * v2)
            r, g, b = r + dr, g + dg, b + db
    count = samples * samples
    return r / count, g / count, b / count


@njit(cache=True)
def _sample_point(tex, t, boundary, x, y):
    """Where texel (y, x) samples triangle t, in texel units: the texel centre when it lies
    in t and the texel square lies within every chart-boundary edge of t (boundary (T, 3)
    bool, edge k runs from corner k to k+1); otherwise the centroid of the part of the texel
    t overlaps.  So a texel on a chart's rim samples the middle of its covered part, never a
    point on the rim itself (at a box's corner that would be the adjacent wall's plane)."""
    px, py = x + 0.5, y + 0.5
    sign = 1.0 if _area2(tex, t) > 0.0 else -1.0
    rim = not _inside(tex, t, px, py)
    for k in range(3):
        if boundary[t, k] and not rim:
            ax, ay = tex[t, k, 0], tex[t, k, 1]
            bx, by = tex[t, (k + 1) % 3, 0], tex[t, (k + 1) % 3, 1]
            nx, ny = sign * (by - ay), -sign * (bx - ax)
            rim = nx * x + ny * y + max(nx, 0.0) + max(ny, 0.0) > nx * ax + ny * ay
    if not rim:
        return px, py
    nx, ny, d = np.empty(3), np.empty(3), np.empty(3)
    work = np.empty((2, 2, 8))
    _edge_planes(tex, t, nx, ny, d)
    count, polygon = _clip_square(x, y, nx, ny, d, work)
    if count < 3:
        return px, py
    area, mx, my = _polygon_moments(work, polygon, count)
    return (mx, my) if area > 1e-12 else (px, py)


@njit(cache=True)
def _area2(tex, t):
    """Twice the signed texel-space area of triangle t."""
    ax, ay = tex[t, 0, 0], tex[t, 0, 1]
    return (tex[t, 1, 0] - ax) * (tex[t, 2, 1] - ay) - (tex[t, 1, 1] - ay) * (tex[t, 2, 0] - ax)


@njit(cache=True)
def _inside(tex, t, px, py):
    """p inside (or on) triangle t; False for zero-area triangles."""
    area2 = _area2(tex, t)
    if area2 == 0.0:
        return False
    ax, ay = tex[t, 0, 0], tex[t, 0, 1]
    bx, by = tex[t, 1, 0], tex[t, 1, 1]
    cx, cy = tex[t, 2, 0], tex[t, 2, 1]
    l1 = ((px - ax) * (cy - ay) - (py - ay) * (cx - ax)) / area2
    l2 = ((bx - ax) * (py - ay) - (by - ay) * (px - ax)) / area2
    return l1 >= 0.0 and l2 >= 0.0 and l1 + l2 <= 1.0


@njit(cache=True, parallel=True)
def texel_attributes(texel_y, texel_x, triangle, tex, boundary, positions, normals, uv0, colors, indices,
                     face_normal, material, base_factor, emissive_factor, base_texture,
                     emissive_texture, tex_data, tex_offset, tex_width, tex_height, samples):
    """Surface attributes of N owned texels.

    texel_y, texel_x, triangle: (N,) the texel and the triangle that owns it.  tex: (T, 3, 2)
    f64 texel-unit corners; boundary (T, 3) bool chart-rim edges.  positions (V, 3), normals (V, 3), uv0 (V, 2), colors (V, 4) (or
    (0, 4) for none) vertex arrays; indices (T, 3); face_normal (T, 3) unit; material (T,).
    base_factor, emissive_factor: (M, 3) linear RGB.  base_texture, emissive_texture: (M,) i64
    texture id or -1.  Textures are stacked RGB rows in tex_data (K, 3) f32; texture i starts at
    tex_offset[i] with tex_width[i] x tex_height[i] texels.  samples: grid points per texel axis
    for averaging over the texel footprint.
    Returns position, normal, rho, emission, each (N, 3) f32.  Position, normal and vertex
    colour use the barycentrics of `_sample_point` (the texel centre, or on a chart's rim the
    centroid of the texel's overlap with the triangle), clamped into the triangle; footprint
    texture samples use the owner's affine uv1 -> uv0 map unclamped, so a texel straddling two
    triangles of one continuous uv0 mapping averages exactly its own footprint.
    """
    n = texel_y.shape[0]
    position = np.empty((n, 3), np.float32)
    normal = np.empty((n, 3), np.float32)
    rho = np.empty((n, 3), np.float32)
    emission = np.empty((n, 3), np.float32)
    has_colors = colors.shape[0] > 0
    for i in prange(n):
        t = triangle[i]
        ax, ay = tex[t, 0, 0], tex[t, 0, 1]
        bx, by = tex[t, 1, 0], tex[t, 1, 1]
        cx, cy = tex[t, 2, 0], tex[t, 2, 1]
        i0, i1, i2 = indices[t, 0], indices[t, 1], indices[t, 2]
        px, py = _sample_point(tex, t, boundary, texel_x[i], texel_y[i])
        l0, l1, l2 = clamped_barycentrics(px, py, ax, ay, bx, by, cx, cy)
        for c in range(3):
            position[i, c] = l0 * positions[i0, c] + l1 * positions[i1, c] + l2 * positions[i2, c]
        nx = l0 * normals[i0, 0] + l1 * normals[i1, 0] + l2 * normals[i2, 0]
        ny = l0 * normals[i0, 1] + l1 * normals[i1, 1] + l2 * normals[i2, 1]
        nz = l0 * normals[i0, 2] + l1 * normals[i1, 2] + l2 * normals[i2, 2]
        length = np.sqrt(nx * nx + ny * ny + nz * nz)
        if length > 1e-12 and nx * face_normal[t, 0] + ny * face_normal[t, 1] + nz * face_normal[t, 2] > 0.0:
            normal[i, 0], normal[i, 1], normal[i, 2] = nx / length, ny / length, nz / length
        else:
            normal[i, 0], normal[i, 1], normal[i, 2] = face_normal[t, 0], face_normal[t, 1], face_normal[t, 2]
        # texture averages over the texel footprint, through the owner's uv1 -> uv0 affine map
        m = material[t]
        base = (1.0, 1.0, 1.0)
        glow = (1.0, 1.0, 1.0)
        for which in range(2):
            tid = base_texture[m] if which == 0 else emissive_texture[m]
            if tid < 0:
                continue
            mean = _footprint_mean(tex_data, tex_offset[tid], tex_width[tid], tex_height[tid], texel_x[i],
                                   texel_y[i], samples, ax, ay, bx, by, cx, cy, uv0[i0, 0], uv0[i0, 1],
                                   uv0[i1, 0], uv0[i1, 1], uv0[i2, 0], uv0[i2, 1])
            if which == 0:
                base = mean
            else:
                glow = mean
        for c in range(3):
            tint = l0 * colors[i0, c] + l1 * colors[i1, c] + l2 * colors[i2, c] if has_colors else 1.0
            rho[i, c] = base_factor[m, c] * base[c] * tint
            emission[i, c] = emissive_factor[m, c] * glow[c]
    return position, normal, rho, emission


# ----------------------------------------------------------------------------------------
# Fallback packer: planar charts, projected and shelf-packed
# ----------------------------------------------------------------------------------------

@njit(cache=True)
def grow_planar_charts(face_normal, neighbour_start, neighbours, cos_tolerance):
    """Region-grow charts of edge-connected triangles whose normals lie within the tolerance
    of the chart's seed normal.  face_normal (T, 3) unit (zero for degenerate triangles, which
    stay alone); neighbours in CSR form (neighbour_start (T+1,), neighbours (E,)).
    Returns chart (T,) i32 and the chart count."""
    t_count = face_normal.shape[0]
    chart = np.full(t_count, -1, np.int32)
    stack = np.empty(t_count, np.int64)
    charts = 0
    for seed in range(t_count):
        if chart[seed] >= 0:
            continue
        chart[seed] = charts
        top = 0
        stack[top] = seed
        top += 1
        while top > 0:
            top -= 1
            t = stack[top]
            for j in range(neighbour_start[t], neighbour_start[t + 1]):
                u = neighbours[j]
                if chart[u] >= 0:
                    continue
                cos = (face_normal[u, 0] * face_normal[seed, 0] + face_normal[u, 1] * face_normal[seed, 1]
                       + face_normal[u, 2] * face_normal[seed, 2])
                if cos >= cos_tolerance:
                    chart[u] = charts
                    stack[top] = u
                    top += 1
        charts += 1
    return chart, charts


@njit(cache=True)
def _bounding_area(corners, tri_order, start, end, tx, ty, tz, bx, by, bz):
    lo_u, hi_u, lo_v, hi_v = np.inf, -np.inf, np.inf, -np.inf
    for j in range(start, end):
        t = tri_order[j]
        for k in range(3):
            u = corners[t, k, 0] * tx + corners[t, k, 1] * ty + corners[t, k, 2] * tz
            v = corners[t, k, 0] * bx + corners[t, k, 1] * by + corners[t, k, 2] * bz
            lo_u, hi_u = min(lo_u, u), max(hi_u, u)
            lo_v, hi_v = min(lo_v, v), max(hi_v, v)
    return (hi_u - lo_u) * (hi_v - lo_v)


@njit(cache=True)
def project_charts(corners, chart_normal, tri_order, chart_start, max_candidates):
    """Project each chart onto its plane, in metres, with the bounding rectangle at the origin.

    corners (T, 3, 3) f64 world corners; chart_normal (C, 3) unit (zero: any plane);
    tri_order (T,) triangles sorted by chart with chart_start (C+1,) offsets.  The in-plane
    axis is the one (among a world-axis choice and the chart's first edge directions, at most
    max_candidates) giving the smallest bounding rectangle.
    Returns local (T, 3, 2) f64 corner coordinates and extent (C, 2) f64 rectangle sizes."""
    local = np.zeros((corners.shape[0], 3, 2))
    extent = np.zeros((chart_normal.shape[0], 2))
    for ch in range(chart_normal.shape[0]):
        nx, ny, nz = chart_normal[ch, 0], chart_normal[ch, 1], chart_normal[ch, 2]
        start, end = chart_start[ch], chart_start[ch + 1]
        if nx * nx + ny * ny + nz * nz < 0.5:  # degenerate triangle: any plane does
            tx, ty, tz, bx, by, bz = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0
        else:
            # first candidate: the world axis least aligned with the normal, made tangent
            ex, ey, ez = 1.0, 0.0, 0.0
            if abs(ny) < abs(nx) and abs(ny) <= abs(nz):
                ex, ey, ez = 0.0, 1.0, 0.0
            elif abs(nz) < abs(nx) and abs(nz) < abs(ny):
                ex, ey, ez = 0.0, 0.0, 1.0
            tx, ty, tz, bx, by, bz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            best = np.inf
            for candidate in range(max_candidates + 1):
                if candidate > 0:
                    j = start + (candidate - 1) // 3
                    if j >= end:
                        break
                    t, k = tri_order[j], (candidate - 1) % 3
                    ex = corners[t, (k + 1) % 3, 0] - corners[t, k, 0]
                    ey = corners[t, (k + 1) % 3, 1] - corners[t, k, 1]
                    ez = corners[t, (k + 1) % 3, 2] - corners[t, k, 2]
                # tangent = direction with the normal component removed
                along = ex * nx + ey * ny + ez * nz
                cx, cy, cz = ex - along * nx, ey - along * ny, ez - along * nz
                length = np.sqrt(cx * cx + cy * cy + cz * cz)
                if length < 1e-12:
                    continue
                cx, cy, cz = cx / length, cy / length, cz / length
                dx, dy, dz = ny * cz - nz * cy, nz * cx - nx * cz, nx * cy - ny * cx
                area = _bounding_area(corners, tri_order, start, end, cx, cy, cz, dx, dy, dz)
                if area < best * (1.0 - 1e-9):
                    best = area
                    tx, ty, tz, bx, by, bz = cx, cy, cz, dx, dy, dz
        lo_u, hi_u, lo_v, hi_v = np.inf, -np.inf, np.inf, -np.inf
        for j in range(start, end):
            t = tri_order[j]
            for k in range(3):
                u = corners[t, k, 0] * tx + corners[t, k, 1] * ty + corners[t, k, 2] * tz
                v = corners[t, k, 0] * bx + corners[t, k, 1] * by + corners[t, k, 2] * bz
                local[t, k, 0], local[t, k, 1] = u, v
                lo_u, hi_u = min(lo_u, u), max(hi_u, u)
                lo_v, hi_v = min(lo_v, v), max(hi_v, v)
        for j in range(start, end):
            t = tri_order[j]
            for k in range(3):
                local[t, k, 0] -= lo_u
                local[t, k, 1] -= lo_v
        extent[ch, 0], extent[ch, 1] = hi_u - lo_u, hi_v - lo_v
    return local, extent

