"""float16 from and to float32 at memory speed, bit for bit as NumPy's casts (which took
2-4 ns a value: a bake's passes, stored as float16, are filled as float32 images and stored
again as float16 in texels.npz)."""
from __future__ import annotations

import numba as nb
import numpy as np

HALF_SUBNORMAL_MAGIC = np.float32(0.5)  # 2^-1: added to |x| < 2^-14, rounds it to a multiple of 2^-24, float16's last bit


@nb.njit(cache=True, inline="always")
def half_bits(x):
    """The bits (u16) of the float16 nearest to the f32 x, ties to even: what NumPy's cast
    to float16 gives (overflow to inf; a NaN keeps its sign and the top bits of its payload,
    at least one). Both ways are computed and one picked:
    normal results round by adding 0xFFF (+1 when the kept mantissa is odd) below the kept
    13 bits; subnormal ones by the float addition of a power of two that leaves 2^-24 as
    its last bit."""
    f = np.int64(np.float32(x).view(np.uint32))
    sign = (f >> 16) & 0x8000
    a = f & 0x7FFFFFFF
    normal = (a - (112 << 23) + 0xFFF + ((a >> 13) & 1)) >> 13  # exponent rebiased from 127 to 15
    rounded = np.float32(np.uint32(a).view(np.float32) + HALF_SUBNORMAL_MAGIC)  # |x| + 2^-1, added in f32
    subnormal = np.int64(rounded.view(np.uint32)) - (126 << 23)
    out = subnormal if a < (113 << 23) else normal
    if a >= (143 << 23):  # |x| >= 2^16: inf, or NaN
        out = 0x7C00 | max((a & 0x7FFFFF) >> 13, 1) if a > 0x7F800000 else 0x7C00
    return np.uint16(sign | out)


@nb.njit(cache=True, nogil=True)
def _halves(values, bits):
    for j in range(values.shape[0]):
        bits[j] = half_bits(values[j])


@nb.njit(cache=True, nogil=True)
def _floats(bits, table, values):
    for j in range(bits.shape[0]):
        values[j] = table[bits[j]]


_FLOAT_OF_HALF = np.arange(1 << 16, dtype=np.uint16).view(np.float16).astype(np.float32)  # by bits


def to_float16(values: np.ndarray) -> np.ndarray:
    """values (any shape) f32 as float16, the nearest (ties to even), as NumPy casts them."""
    flat = np.ascontiguousarray(values, np.float32).reshape(-1)
    out = np.empty(flat.shape, np.float16)
    _halves(flat, out.view(np.uint16))
    return out.reshape(np.shape(values))


def to_float32(values: np.ndarray) -> np.ndarray:
    """float16 values (any shape) as float32 (exact), from a table of all 2^16."""
    flat = np.ascontiguousarray(values, np.float16).reshape(-1)
    out = np.empty(flat.shape, np.float32)
    _floats(flat.view(np.uint16), _FLOAT_OF_HALF, out)
    return out.reshape(np.shape(values))
