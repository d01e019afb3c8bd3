"""The sky models' radiance by direction, with known answers."""
import numpy as np
import pytest

from patchlight.scene.sky import Sky


def test_image_sky_maps_minus_z_to_the_centre_column_and_the_zenith_to_the_top_row():
    h, w = 8, 16
    image = np.zeros((h, w, 3), np.float32)
    image[..., 0] = np.arange(w)[None, :]          # red = column
    image[..., 1] = np.arange(h)[:, None]          # green = row
    sky = Sky.from_image(image)
    dirs = np.array([[0, 0, -1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], np.float32)
    col_row = sky.radiance(dirs)[:, :2]
    # -Z: u = 0.5 (centre); +X: u = 0.75; -X: u = 0.25; +Y: top row; -Y: bottom row
    np.testing.assert_array_equal(col_row[:3, 0], [w // 2, 3 * w // 4, w // 4])
    np.testing.assert_array_equal(col_row[:3, 1], [h // 2] * 3)
    assert col_row[3, 1] == 0 and col_row[4, 1] == h - 1


def test_gradient_sky_is_linear_in_height_above_the_horizon_and_flat_below():
    sky = Sky.gradient((1.0, 2.0, 3.0), (0.0, 0.0, 0.0), (0.5, 0.5, 0.5))
    up = np.array([[0, 1, 0], [0.6, 0.8, 0], [0, -0.3, 0.95]], np.float32)
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    np.testing.assert_allclose(sky.radiance(up), [[1, 2, 3], [0.8, 1.6, 2.4], [0.5, 0.5, 0.5]], rtol=1e-6)


@pytest.mark.parametrize("sky, black", [(Sky.uniform((0, 0, 0)), True), (Sky.uniform((0, 0.1, 0)), False)])
def test_a_black_sky_lights_nothing(sky, black):
    assert sky.is_black() == black
