"""Numba kernels of imaging/: dilation, and Radiance RGBE scanlines (run-length coded and flat).

Byte layout (Radiance's picture format): a scanline of width 8..32767 may start with the
marker 2, 2, W >> 8, W & 255; then each of the four components (R, G, B, E) follows as runs:
a count byte c > 128 repeats the next byte c - 128 times, a count 1..128 is followed by c
literal bytes.  Any other scanline is flat: W pixels of 4 bytes, where the old-style pixel
(1, 1, 1, n) repeats the previous pixel n << shift times (shift grows by 8 for each
consecutive run pixel).
"""
from __future__ import annotations

import numba
import numpy as np

RING = np.array([[0, -1], [0, 1], [-1, 0], [1, 0], [-1, -1], [-1, 1], [1, -1], [1, 1]], np.int64)  # sides, corners

# Status codes returned by decode_scanlines instead of a positive byte offset.
TRUNCATED = -1
BAD_LENGTH = -2
BAD_RUN = -3

MIN_RUN = 4  # shorter repeats are cheaper as literals
MAX_RUN = 127
MAX_LITERAL = 128


@numba.njit(cache=True)
def decode_scanlines(data, pos, out):
    """Decode H scanlines of (H, W, 4) uint8 RGBE `out` from uint8 `data` starting at byte `pos`.

    Returns the byte offset after the last scanline, or a negative status code.
    """
    n = data.shape[0]
    height, width = out.shape[0], out.shape[1]
    for y in range(height):
        if pos + 4 > n:
            return TRUNCATED
        is_rle = (8 <= width <= 0x7FFF and data[pos] == 2 and data[pos + 1] == 2
                  and data[pos + 2] < 128)
        if is_rle:
            if (data[pos + 2] << 8 | data[pos + 3]) != width:
                return BAD_LENGTH
            pos += 4
            for c in range(4):
                x = 0
                while x < width:
                    if pos >= n:
                        return TRUNCATED
                    count = np.int64(data[pos])
                    pos += 1
                    if count > 128:
                        count -= 128
                        if x + count > width:
                            return BAD_RUN
                        if pos >= n:
                            return TRUNCATED
                        out[y, x:x + count, c] = data[pos]
                        pos += 1
                    else:
                        if count == 0 or x + count > width:
                            return BAD_RUN
                        if pos + count > n:
                            return TRUNCATED
                        out[y, x:x + count, c] = data[pos:pos + count]
                        pos += count
                    x += count
        else:
            x = 0
            shift = 0
            while x < width:
                if pos + 4 > n:
                    return TRUNCATED
                if data[pos] == 1 and data[pos + 1] == 1 and data[pos + 2] == 1:
                    count = np.int64(data[pos + 3]) << shift
                    if x == 0 or x + count > width:
                        return BAD_RUN
                    for k in range(count):
                        out[y, x + k] = out[y, x - 1]
                    x += count
                    shift += 8
                else:
                    out[y, x] = data[pos:pos + 4]
                    x += 1
                    shift = 0
                pos += 4
    return pos


@numba.njit(cache=True)
def _encode_component(values, out, pos):
    """Run-length code one component of one scanline into `out` at `pos`; returns the new pos."""
    width = values.shape[0]
    x = 0
    while x < width:
        # Find the next run of at least MIN_RUN equal bytes at or after x.
        begin = x
        run = 0
        while begin < width:
            run = 1
            while begin + run < width and run < MAX_RUN and values[begin + run] == values[begin]:
                run += 1
            if run >= MIN_RUN:
                break
            begin += run
        literal_end = begin if begin < width else width
        while x < literal_end:
            count = min(MAX_LITERAL, literal_end - x)
            out[pos] = count
            out[pos + 1:pos + 1 + count] = values[x:x + count]
            pos += 1 + count
            x += count
        if begin < width:
            out[pos] = 128 + run
            out[pos + 1] = values[begin]
            pos += 2
            x = begin + run
    return pos


@numba.njit(cache=True)
def encode_scanlines(rgbe):
    """Run-length code (H, W, 4) uint8 RGBE (8 <= W <= 32767) into a new uint8 byte array."""
    height, width = rgbe.shape[0], rgbe.shape[1]
    worst = height * (4 + 4 * (width + (width + MAX_LITERAL - 1) // MAX_LITERAL))
    out = np.empty(worst, np.uint8)
    pos = 0
    for y in range(height):
        out[pos] = 2
        out[pos + 1] = 2
        out[pos + 2] = width >> 8
        out[pos + 3] = width & 255
        pos += 4
        for c in range(4):
            pos = _encode_component(rgbe[y, :, c], out, pos)
    return out[:pos]


@numba.njit(cache=True, nogil=True)
def dilation_plan(known, allowed, rings):
    """How `rings` rings grow an image (H, W) from its `known` texels: each unknown texel in
    `allowed` next to known ones takes the mean of its known side neighbours, or, with none,
    of its known corner neighbours: the nearest texels (so padding beside a dark texel at a
    wall's foot copies it, not the lit texel diagonally across the wall). All texels of a ring
    are filled from the rings before it. Returns the filled texels in order, targets (K,) i64
    flat indices, their sources (K, 4) i64 flat indices (-1 past the last), and the grown
    `known` mask; the values are worked out by `apply_dilation`, for as many images as need
    the same growth."""
    h, w = known.shape
    known = known.copy()
    targets = np.empty(16, np.int64)
    sources = np.empty((16, 4), np.int64)
    found = np.empty(4, np.int64)  # the neighbours a texel fills from, -1 past the last
    count = 0
    for _ in range(rings):
        grown = known.copy()
        any_grown = False
        for y in range(h):
            for x in range(w):
                if known[y, x] or not allowed[y, x]:
                    continue
                found[:] = -1
                for first, last in ((0, 4), (4, 8)):  # sides, then corners
                    n = 0
                    for k in range(first, last):
                        yy, xx = y + RING[k, 0], x + RING[k, 1]
                        if 0 <= yy < h and 0 <= xx < w and known[yy, xx]:
                            found[n] = yy * w + xx
                            n += 1
                    if n > 0:
                        break
                if n == 0:
                    continue
                if count == targets.shape[0]:
                    targets = np.concatenate((targets, np.empty_like(targets)))
                    sources = np.concatenate((sources, np.empty_like(sources)))
                targets[count] = y * w + x
                sources[count, :] = found
                count += 1
                grown[y, x] = True
                any_grown = True
        known = grown
        if not any_grown:
            break
    return targets[:count], sources[:count], known


@numba.njit(cache=True, nogil=True)
def apply_dilation(image, targets, sources):
    """Fill image (H, W, C) f32 in place as a `dilation_plan` says: each target, in order, the
    mean of its sources, summed in float64 in their order."""
    w = image.shape[1]
    for i in range(targets.shape[0]):
        n = 0
        while n < 4 and sources[i, n] >= 0:
            n += 1
        y, x = targets[i] // w, targets[i] % w
        for ch in range(image.shape[2]):
            total = 0.0
            for k in range(n):
                total += image[sources[i, k] // w, sources[i, k] % w, ch]
            image[y, x, ch] = total / n
