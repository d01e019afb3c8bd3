"""float16 conversions: bit for bit NumPy's casts, over every float16 and over float32s of
every exponent, ties and specials included."""
import warnings

import numpy as np

from patchlight.imaging.halves import to_float16, to_float32


def test_every_float16_widens_as_numpy_widens_it():
    halves = np.arange(1 << 16, dtype=np.uint16).view(np.float16).reshape(256, 256)
    widened = to_float32(halves)
    assert widened.shape == (256, 256) and widened.dtype == np.float32
    assert np.array_equal(widened.view(np.uint32), halves.astype(np.float32).view(np.uint32))


def test_float32s_narrow_as_numpy_narrows_them():
    rng = np.random.default_rng(5)
    bits = rng.integers(0, 1 << 32, 200_000, dtype=np.uint64).astype(np.uint32)  # every exponent and sign
    exact = np.arange(1 << 16, dtype=np.uint16).view(np.float16).astype(np.float32)
    ties = exact.view(np.uint32) + np.uint32(1 << 12)  # halfway to the next float16 (NaNs from inf and NaN)
    specials = np.float32([0.0, -0.0, np.inf, -np.inf, np.nan, 65504, 65519.99, 65520, 6.1035156e-05, 5.9604645e-08,
                           2.9802322e-08, 2.9802326e-08, 1e-30, -1e-30])
    values = np.concatenate([bits.view(np.float32), exact, ties.view(np.float32), specials]).reshape(-1, 2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # NumPy warns of the overflow to inf
        expected = values.astype(np.float16)
    narrowed = to_float16(values)
    assert narrowed.shape == values.shape and narrowed.dtype == np.float16
    assert np.array_equal(narrowed.view(np.uint16), expected.view(np.uint16))
