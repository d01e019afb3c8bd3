"""The lightmap-directional model's known answers: the plain lightmap where the normal is the
surface's own, L1 of a single sun within the bound L1 allows, and the dominant direction."""
from __future__ import annotations

import numpy as np
import pytest

from patchlight.shading.directional import (Y00, Y1, DirectionalLightmap, directional_light, dominant_direction,
                                            sh_light)


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _sun_sh(direction, es, n_points=1):
    """L1 coefficients (4, N, 3) of a sun of irradiance es arriving from `direction` (a delta in radiance)."""
    l = _unit(direction)
    coeffs = np.array([Y00, Y1 * l[0], Y1 * l[1], Y1 * l[2]]) * es
    return np.broadcast_to(coeffs[:, None, None], (4, n_points, 3)).astype(np.float64)


def _normals(n, rng):
    return _unit(rng.normal(size=(n, 3)))


@pytest.mark.parametrize("mode", ["sh", "dominant"])
def test_the_surface_normal_reads_the_plain_lightmap(mode):
    rng = np.random.default_rng(1)
    n = 200
    N0 = _normals(n, rng)
    baked = rng.uniform(0.1, 2.0, (n, 3))
    if mode == "sh":
        c0 = rng.uniform(0.5, 2, (n, 3))  # light from the hemisphere above N0 keeps sh(N0) > 0
        texels = np.stack([c0] + [c0 * rng.uniform(-0.4, 0.4, (n, 3)) for _ in range(3)])
    else:
        texels = (_normals(n, rng) * rng.uniform(0, 1, (n, 1)))[None]
    assert np.allclose(directional_light(mode, texels, baked, N0, N0), baked, rtol=1e-6)


def test_l1_of_a_sun_is_the_clamped_cosines_projection_within_its_bound():
    """sh(n) = Es (1/4 + cos / 2) / pi: off the exact Es max(cos, 0) / pi by at most Es / (4 pi)."""
    rng = np.random.default_rng(2)
    es, sun = 3.0, _unit([0.3, 0.9, -0.2])
    N = _normals(2000, rng)
    cos = N @ sun
    got = sh_light(_sun_sh(sun, es, len(N)), N)[:, 0]
    assert np.allclose(got, es * (0.25 + 0.5 * cos) / np.pi, rtol=1e-6)
    error = np.abs(got - es * np.maximum(cos, 0) / np.pi)
    assert error.max() <= es / (4 * np.pi) * (1 + 1e-6)
    assert error.max() > 0.95 * es / (4 * np.pi)  # the bound is reached: L1 can do no better


def test_a_tilted_normal_under_a_sun_follows_the_l1_cosine_and_the_dominant_direction_is_the_sun():
    es, sun = 2.0, _unit([0.0, 1.0, 0.0])
    N0 = np.array([[0.0, 1.0, 0.0]])
    plain = np.full((1, 3), es / np.pi)  # the lightmap's I under an overhead sun
    texels = _sun_sh(sun, es)
    for tilt in (10, 30, 60):
        t = np.radians(tilt)
        N = np.array([[np.sin(t), np.cos(t), 0.0]])
        got = directional_light("sh", texels, plain, N, N0)[0, 0]
        # L1 gives I (1/4 + cos/2) / (3/4); the exact answer is I cos
        assert got == pytest.approx(es / np.pi * (0.25 + 0.5 * np.cos(t)) / 0.75, rel=1e-6)
        assert abs(got - es / np.pi * np.cos(t)) <= es / (4 * np.pi) / 0.75
    L, share = dominant_direction("sh", texels)
    assert np.degrees(np.arccos(np.clip(L[0] @ sun, -1, 1))) < 1e-4 and share[0] == pytest.approx(1.0)


def test_files_round_trip(tmp_path):
    from patchlight.bakedir import read_directional, write_directional

    rng = np.random.default_rng(3)
    for mode, k in (("sh", 4), ("dominant", 1)):
        maps = rng.normal(size=(k, 5, 7, 3)).astype(np.float32)
        folder = tmp_path / mode
        folder.mkdir()
        write_directional(folder, DirectionalLightmap(mode, maps))
        loaded = read_directional(folder)
        assert loaded.mode == mode and np.array_equal(loaded.maps, maps)
    assert read_directional(tmp_path) is None


def test_where_l1_saw_no_light_the_plain_lightmap_stays():
    texels = np.zeros((4, 3, 3))
    baked = np.full((3, 3), 0.7)
    N = _unit([[0.3, 1, 0], [1, 0, 0], [0, 1, 0]])
    N0 = np.tile([0.0, 1.0, 0.0], (3, 1))
    assert np.array_equal(directional_light("sh", texels, baked, N, N0), baked)
