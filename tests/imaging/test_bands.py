"""Work in bands of rows gives what the whole image at once gives, the last short band included."""
import numpy as np

from patchlight.imaging import io
from patchlight.imaging.bands import BAND_ROWS, banded
from patchlight.imaging.color import linear_to_srgb
from patchlight.imaging.exposure import expose, exposed_png_pixels
from patchlight.imaging.lightmap import encode_lightmap


def test_banded_work_equals_the_whole_image_at_once():
    rng = np.random.default_rng(2)
    image = (rng.random((2 * BAND_ROWS + 17, 7, 3)) * 5 - 0.5).astype(np.float32)
    assert np.array_equal(banded(lambda rows: rows * 2.0 + 1.0, image, np.float64), image * 2.0 + 1.0)
    whole = np.round(linear_to_srgb(expose(image, 0.7)) * 255).astype(np.uint8)
    assert np.array_equal(exposed_png_pixels(image, 0.7), whole)
    relative = np.maximum(image.astype(np.float64), 0.0) / float(image.max())
    relative32 = relative.astype(np.float32)
    assert np.array_equal(io._float_to_rgbe(relative32), io._rgbe_rows(relative32))
    encoded = encode_lightmap(image)
    assert encoded.scale == float(image.max())
    assert encoded.hdr == io.encode_hdr(relative32)
    assert encoded.png == io.encode_png(np.round(np.clip(relative, 0.0, 1.0) * 255.0).astype(np.uint8))
