"""Texture lookups as WebGL2 does them with linear filtering and no mipmaps, so the CPU
reference reads the same values the shaders' `texture()` calls do.

2D: texel (i, j) has its centre at ((j + 0.5) / W, (i + 0.5) / H); row 0 is t = 0 (glTF's v = 0,
the image's top row, uploaded without a flip). Cube maps: the six faces in GL order +X, -X,
+Y, -Y, +Z, -Z, each (S, S, C) with row 0 at t = 0, addressed by the GL face table (OpenGL
ES 3.0 spec, table 3.21) and filtered seamlessly, as OpenGL ES 3.0 (so WebGL2) always does:
a bilinear footprint that runs over a face's edge takes its texels from the adjacent face,
and one over a corner, where three faces meet, the average of those three texels (the rule
of the OpenGL 4 spec's seamless cube maps, and what SwiftShader, the tests' WebGL, does).
"""
from __future__ import annotations

import numpy as np

# GL cube face table: for face f, the major axis, its sign, and (axis, sign) of sc and tc.
_CUBE_FACES = (
    (0, +1.0, (2, -1.0), (1, -1.0)),  # +X: sc = -rz, tc = -ry
    (0, -1.0, (2, +1.0), (1, -1.0)),  # -X: sc = +rz, tc = -ry
    (1, +1.0, (0, +1.0), (2, +1.0)),  # +Y: sc = +rx, tc = +rz
    (1, -1.0, (0, +1.0), (2, -1.0)),  # -Y: sc = +rx, tc = -rz
    (2, +1.0, (0, +1.0), (1, -1.0)),  # +Z: sc = +rx, tc = -ry
    (2, -1.0, (0, -1.0), (1, -1.0)),  # -Z: sc = -rx, tc = -ry
)


def _bilinear_taps(coord: np.ndarray, size: int, wrap: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices (lo, hi) and the weight of hi for texture coordinates `coord` along one axis;
    wrap "repeat", "clamp" (to the edge texel) or "border" (into a face padded by one texel all
    round, padded_cube)."""
    x = coord * np.float32(size) - np.float32(0.5)
    lo = np.floor(x)
    frac = (x - lo).astype(np.float32)
    lo = lo.astype(np.int64)
    hi = lo + 1
    if wrap == "repeat":
        return lo % size, hi % size, frac
    if wrap == "border":
        return np.clip(lo + 1, 0, size + 1), np.clip(hi + 1, 0, size + 1), frac
    return np.clip(lo, 0, size - 1), np.clip(hi, 0, size - 1), frac


def sample_bilinear(texture: np.ndarray, uv: np.ndarray, wrap: str = "repeat") -> np.ndarray:
    """Bilinear lookup of texture (H, W, C) at uv (N, 2); wrap "repeat" or "clamp". (N, C)."""
    h, w = texture.shape[:2]
    x0, x1, fx = _bilinear_taps(uv[:, 0], w, wrap)
    y0, y1, fy = _bilinear_taps(uv[:, 1], h, wrap)
    fx, fy = fx[:, None], fy[:, None]
    top = texture[y0, x0] * (1 - fx) + texture[y0, x1] * fx
    bottom = texture[y1, x0] * (1 - fx) + texture[y1, x1] * fx
    return (top * (1 - fy) + bottom * fy).astype(np.float32)


def cube_face_coords(directions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Face index (N,) and face coordinates s, t (N,) in [0, 1] of directions (N, 3) (any length)."""
    d = np.asarray(directions, np.float32)
    absd = np.abs(d)
    axis = np.argmax(absd, axis=1)  # ties go to the lower axis (x before y before z)
    positive = d[np.arange(len(d)), axis] >= 0
    face = (2 * axis + (~positive)).astype(np.int64)
    s = np.empty(len(d), np.float32)
    t = np.empty(len(d), np.float32)
    for f, (major, _, (sa, ss), (ta, ts)) in enumerate(_CUBE_FACES):
        sel = face == f
        ma = absd[sel, major]
        s[sel] = 0.5 * (ss * d[sel, sa] / ma + 1.0)
        t[sel] = 0.5 * (ts * d[sel, ta] / ma + 1.0)
    return face, s, t


def cube_directions(size: int) -> np.ndarray:
    """(6, size, size, 3) unit directions through the texel centres of each cube face."""
    c = (np.arange(size, dtype=np.float64) + 0.5) / size * 2.0 - 1.0
    tc, sc = np.meshgrid(c, c, indexing="ij")  # row index follows t, column index follows s
    out = np.empty((6, size, size, 3))
    for f, (major, sign, (sa, ss), (ta, ts)) in enumerate(_CUBE_FACES):
        out[f, ..., major] = sign
        out[f, ..., sa] = ss * sc
        out[f, ..., ta] = ts * tc
    out /= np.linalg.norm(out, axis=-1, keepdims=True)
    return out.astype(np.float32)


def padded_cube(faces: np.ndarray) -> np.ndarray:
    """(6, S + 2, S + 2, C): each face of faces (6, S, S, C) with a ring of the texels seamless
    filtering reads beyond its edges. An edge texel of the ring is the adjacent face's texel
    that a direction through its centre falls in; a corner is the mean of the three texels
    that meet there (the face's own corner and the two ring texels beside it)."""
    size = faces.shape[1]
    c = (np.arange(-1, size + 1, dtype=np.float64) + 0.5) / size * 2.0 - 1.0
    tc, sc = np.meshgrid(c, c, indexing="ij")
    ring = np.ones((size + 2, size + 2), bool)
    ring[1:-1, 1:-1] = False
    out = np.empty((6, size + 2, size + 2) + faces.shape[3:], faces.dtype)
    for f, (major, sign, (sa, ss), (ta, ts)) in enumerate(_CUBE_FACES):
        out[f, 1:-1, 1:-1] = faces[f]
        d = np.empty((int(ring.sum()), 3))
        d[:, major], d[:, sa], d[:, ta] = sign, ss * sc[ring], ts * tc[ring]
        face, s, t = cube_face_coords(d)
        x = np.clip(np.floor(s * size), 0, size - 1).astype(np.int64)
        y = np.clip(np.floor(t * size), 0, size - 1).astype(np.int64)
        out[f][ring] = faces[face, y, x]
        for row, col, dr, dc in ((0, 0, 1, 1), (0, -1, 1, -1), (-1, 0, -1, 1), (-1, -1, -1, -1)):
            out[f, row, col] = (out[f, row + dr, col] + out[f, row, col + dc] + out[f, row + dr, col + dc]) / 3
    return out


def sample_cube(faces: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Seamless bilinear lookup of a cube map faces (6, S, S, C) along directions (N, 3). (N, C)."""
    face, s, t = cube_face_coords(directions)
    size = faces.shape[1]
    padded = padded_cube(faces)
    x0, x1, fx = _bilinear_taps(s, size, "border")
    y0, y1, fy = _bilinear_taps(t, size, "border")
    fx, fy = fx[:, None], fy[:, None]
    top = padded[face, y0, x0] * (1 - fx) + padded[face, y0, x1] * fx
    bottom = padded[face, y1, x0] * (1 - fx) + padded[face, y1, x1] * fx
    return (top * (1 - fy) + bottom * fy).astype(np.float32)
