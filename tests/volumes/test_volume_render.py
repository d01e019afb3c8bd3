"""The ambient-cube model through the CPU renderer: a flat-shaded sphere in a uniform volume
shades flat with the squared weights and in bands with the naive ones; without a volume the
sky and ground stand in as one probe."""
from __future__ import annotations

import numpy as np
import pytest
from render_scenes import scene_from_parts, uv_sphere

from patchlight.render import Camera, Renderer, Target, target_settings
from patchlight.scene.model import Material, face_normals
from patchlight.shading.models import ShadingSettings, light_surface
from patchlight.volumes import LightVolume, ProbeGrid

L = 0.6
CAMERA = Camera(np.array([2.0, 1.6, 2.4]), np.array([0.0, 0.0, 0.0]), 40.0)


def flat_sphere_target() -> Target:
    """A unit UV sphere with one normal per triangle (every facet a plane)."""
    positions, _, uv, indices = uv_sphere(16, 32)
    corners = positions[indices].reshape(-1, 3)
    normal, _ = face_normals(positions, indices)
    part = (corners, np.repeat(normal, 3, axis=0), uv[indices].reshape(-1, 2),
            np.arange(len(corners), dtype=np.int32).reshape(-1, 3))
    white = Material(name="white", base_color=np.ones(4, np.float32), reflectivity=0.0)
    return Target.from_scene(scene_from_parts([part], [white], [0]))


def uniform_volume() -> LightVolume:
    grid = ProbeGrid((-2.0, -2.0, -2.0), (2.0, 2.0, 2.0), (3, 3, 3))
    return LightVolume(grid, np.full((6, 3, 3, 3, 3), L, np.float32), np.zeros((3, 3, 3), bool))


@pytest.fixture(scope="module")
def sphere():
    target = flat_sphere_target()
    return target, Renderer(target)


def render(sphere, naive: bool) -> np.ndarray:
    target, renderer = sphere
    settings = target_settings(target, model="ambient-cube", volume=uniform_volume(), ambient_cube_naive=naive)
    result = renderer.render(settings, CAMERA, 96, 96)
    return result.radiance[result.covered][:, 0]


def test_squared_weights_shade_a_flat_sphere_evenly(sphere):
    shaded = render(sphere, naive=False)
    assert len(shaded) > 1000
    np.testing.assert_allclose(shaded, L, rtol=0.01)


def test_naive_weights_band_a_flat_sphere(sphere):
    """saturate(n) sums to |nx| + |ny| + |nz|: facets between the axes are up to sqrt(3) too bright."""
    shaded = render(sphere, naive=True)
    assert shaded.max() / shaded.min() > 1.5
    assert len(np.unique(np.round(shaded, 4))) > 20  # one brightness per facet: bands, not a flat disc


def test_without_a_volume_the_sky_and_ground_light_it():
    settings = ShadingSettings(model="ambient-cube", sky=np.array([1.0, 2.0, 3.0], np.float32),
                               ground=np.array([0.1, 0.2, 0.3], np.float32), ambient=np.full(3, 0.5, np.float32))
    N = np.array([[0, 1, 0], [0, -1, 0], [1, 0, 0], [0, 0, -1]], np.float32)
    lit = light_surface(settings, np.zeros((4, 3), np.float32), N, N, 1.0, 16.0, 0.0)
    np.testing.assert_allclose(lit.diffuse, [[1, 2, 3], [0.1, 0.2, 0.3], [0.5] * 3, [0.5] * 3], rtol=1e-6)
    np.testing.assert_array_equal(lit.specular, 0)


def test_specular_is_the_volume_along_the_reflection_vector():
    """Seen head-on, R = N, so the specular is reflectivity x the diffuse light."""
    cube = np.zeros((6, 1, 1, 1, 3), np.float32)
    cube[0] = (2.0, 1.0, 0.5)  # +X
    volume = LightVolume(ProbeGrid((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (1, 1, 1)), cube, np.zeros((1, 1, 1), bool))
    settings = ShadingSettings(model="ambient-cube", volume=volume)
    N = np.array([[1, 0, 0]], np.float32)
    lit = light_surface(settings, np.zeros((1, 3), np.float32), N, N, 1.0, 16.0, np.float32(0.3))
    np.testing.assert_allclose(lit.diffuse, [[2.0, 1.0, 0.5]])
    np.testing.assert_allclose(lit.specular, [[0.6, 0.3, 0.15]], rtol=1e-6)
