"""Known answers for the lighting terms of the NumPy reference (patchlight.shading.terms)."""
from __future__ import annotations

import numpy as np
import pytest

from patchlight.shading.terms import (blinn_phong_specular, decode_normal, display_encode, envmap_color,
                                      fresnel_term, hemisphere_light, lambert_diffuse, perturb_normal,
                                      phong_specular, reflect_view, self_shadow)


def unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def in_plane(angles):
    """Unit vectors in the x-y plane at `angles` (radians) from +y (the normal below)."""
    return np.stack([np.sin(angles), np.cos(angles), np.zeros_like(angles)], axis=-1)


N_UP = np.array([[0.0, 1.0, 0.0]])


def test_lambert_is_the_clamped_cosine():
    angles = np.linspace(-np.pi, np.pi, 73)
    L = in_plane(angles)
    np.testing.assert_allclose(lambert_diffuse(N_UP, L), np.maximum(np.cos(angles), 0), atol=1e-12)


def test_phong_and_blinn_peak_at_the_mirror_direction_with_their_own_lobes():
    """In the plane of incidence a view theta away from the mirror direction gives Phong
    cos(theta)^n and Blinn cos(theta/2)^n: the half vector is theta/2 off the normal."""
    n = 16.0
    L = in_plane(np.array([0.6]))
    mirror = -0.6
    theta = np.linspace(-0.5, 0.5, 41)
    V = in_plane(mirror + theta)
    phong = phong_specular(N_UP, L, V, n)
    blinn = blinn_phong_specular(N_UP, L, V, n)
    np.testing.assert_allclose(phong, np.cos(theta) ** n, atol=1e-12)
    np.testing.assert_allclose(blinn, np.cos(theta / 2) ** n, atol=1e-12)
    assert np.argmax(phong) == np.argmax(blinn) == 20
    assert phong[20] == pytest.approx(1.0) and blinn[20] == pytest.approx(1.0)


def test_phong_reflects_as_the_article_does_r_is_minus_l_behind_the_surface():
    """hlsl-lighting-models.txt: R = normalize(2 saturate(N.L) N - L). In front it is the
    mirror direction reflect(-L, N); behind (N.L < 0) saturate gives 0 and R = -L, so a view
    looking straight into the light sees (R.V)^n = 1 (GLSL's reflect would give 0.65^n)."""
    rng = np.random.default_rng(3)
    N = unit(rng.normal(size=(500, 3)))
    L = unit(rng.normal(size=(500, 3)))
    V = unit(rng.normal(size=(500, 3)))
    n_dot_l = np.einsum("ij,ij->i", N, L)
    R = np.where((n_dot_l > 0)[:, None], 2 * n_dot_l[:, None] * N - L, -L)
    expected = np.clip(np.einsum("ij,ij->i", R, V), 0, 1) ** 4.0
    np.testing.assert_allclose(phong_specular(N, L, V, 4.0), expected, atol=1e-12)
    below = in_plane(np.array([2.0]))  # 115 degrees from the normal: behind the surface
    assert phong_specular(N_UP, below, -below, 8.0)[0] == pytest.approx(1.0)


def test_phong_highlight_survives_behind_the_terminator_but_self_shadow_removes_it():
    """Light from just below the horizon, viewer on the far side: (R.V)^n > 0 although N.L < 0."""
    L = in_plane(np.array([1.7]))
    V = in_plane(np.array([-1.4]))
    assert lambert_diffuse(N_UP, L)[0] == 0
    assert phong_specular(N_UP, L, V, 8.0)[0] > 0.5
    assert self_shadow(N_UP, L)[0] == 0


def test_self_shadow_is_zero_exactly_where_n_dot_l_is_and_one_from_a_quarter():
    rng = np.random.default_rng(1)
    N = unit(rng.normal(size=(2000, 3)))
    L = unit(rng.normal(size=(2000, 3)))
    n_dot_l = np.einsum("ij,ij->i", N, L)
    s = self_shadow(N, L)
    assert np.array_equal(s == 0, n_dot_l <= 0)
    assert np.all(s[n_dot_l >= 0.25] == 1)
    np.testing.assert_allclose(s, np.clip(4 * n_dot_l, 0, 1))


def test_hemisphere_blends_ground_to_sky_by_the_up_component():
    sky, ground = np.array([0.2, 0.4, 1.0]), np.array([0.3, 0.2, 0.1])
    N = np.array([[0, 1.0, 0], [0, -1.0, 0], [1.0, 0, 0], unit([0, 1, 1])])
    out = hemisphere_light(N, sky, ground)
    np.testing.assert_allclose(out[0], sky)
    np.testing.assert_allclose(out[1], ground)
    np.testing.assert_allclose(out[2], (sky + ground) / 2)
    w = 0.5 + 0.5 / np.sqrt(2)
    np.testing.assert_allclose(out[3], ground + (sky - ground) * w)


def test_fresnel_grows_from_zero_head_on_to_the_reflectivity_at_grazing():
    V = in_plane(np.array([0.0, np.pi / 3, np.pi / 2]))
    np.testing.assert_allclose(fresnel_term(N_UP, V, 0.8), [0.0, 0.4, 0.8], atol=1e-12)


def test_reflect_view_mirrors_the_eye_direction():
    V = unit([[1.0, 1.0, 0.0]])
    np.testing.assert_allclose(reflect_view(N_UP, V), unit([[-1.0, 1.0, 0.0]]), atol=1e-12)


def test_envmap_color_tweens_by_fresnel_and_adds_the_alpha_highlight():
    lit = np.array([[0.5, 0.5, 0.5]])
    env = np.array([[1.0, 0.0, 0.0, 0.25]])
    out = envmap_color(lit, env, np.array([0.5]), np.array([0.8]))
    np.testing.assert_allclose(out, [[0.75 + 0.2, 0.25 + 0.2, 0.25 + 0.2]])


def test_decode_normal_maps_unit_interval_to_signed_and_flat_texel_keeps_the_normal():
    np.testing.assert_allclose(decode_normal(np.array([0.0, 0.5, 1.0])), [-1.0, 0.0, 1.0])
    N = unit(np.random.default_rng(2).normal(size=(50, 3)))
    T = np.concatenate([unit(np.cross(N, [0.3, 0.5, 0.8])), np.ones((50, 1))], axis=1)
    flat = decode_normal(np.tile([0.5, 0.5, 1.0], (50, 1)))
    np.testing.assert_allclose(perturb_normal(N, T, flat), N, atol=1e-12)


def test_perturb_normal_uses_tangent_bitangent_and_handedness():
    N = np.array([[0.0, 0.0, 1.0]] * 2)
    T = np.array([[1.0, 0.0, 0.0, 1.0], [1.0, 0.0, 0.0, -1.0]])
    along_t = perturb_normal(N, T, np.array([[1.0, 0.0, 0.0]] * 2))
    along_b = perturb_normal(N, T, np.array([[0.0, 1.0, 0.0]] * 2))
    np.testing.assert_allclose(along_t, [[1, 0, 0], [1, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(along_b, [[0, 1, 0], [0, -1, 0]], atol=1e-12)  # B = cross(N, T) w


def test_display_encode_is_film_exposure_then_srgb():
    x = np.array([0.0, 0.01, 1.0, 100.0])
    c = 1 - np.exp(-2.0 * x)
    srgb = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    np.testing.assert_allclose(display_encode(x, 2.0), srgb, atol=1e-12)



def lit_quad_points(front: bool, travel, n=200):
    """shade_fragments' Lambert radiance (n, 3) at random points of a horizontal double-sided
    quad (normal +y, tangent +x) with a normal map of random slopes, from its front or back,
    under a directional light travelling along `travel`."""
    from patchlight.scene.model import Material
    from patchlight.shading.lights import PunctualLight
    from patchlight.shading.models import Fragments, MaterialTable, ShadingSettings, shade_fragments

    rng = np.random.default_rng(7)  # the same points and map each call
    slopes = unit(np.stack([rng.uniform(-0.6, 0.6, 256), rng.uniform(-0.6, 0.6, 256), np.ones(256)], -1))
    material = Material(name="double", double_sided=True, normal_texture=(0.5 + 0.5 * slopes).reshape(16, 16, 3))
    frags = Fragments(position=np.c_[rng.uniform(-1, 1, n), np.zeros(n), rng.uniform(-1, 1, n)].astype(np.float32),
                      normal=np.tile(np.float32([0, 1, 0]), (n, 1)), tangent=np.tile(np.float32([1, 0, 0, 1]), (n, 1)),
                      uv0=rng.uniform(0, 1, (n, 2)).astype(np.float32), uv1=None, color=np.ones((n, 4), np.float32),
                      material=np.zeros(n, np.int32), front=np.full(n, front))
    sun = PunctualLight("directional", np.zeros(3, np.float32), np.asarray(travel, np.float32), np.ones(3, np.float32))
    settings = ShadingSettings(model="lambert", ambient=np.zeros(3, np.float32), lights=[sun], normal_map=True)
    return shade_fragments(settings, frags, MaterialTable.from_materials([material]), np.float32([0, 5, 0]))


def test_a_back_face_shows_the_front_faces_mapped_normal_negated_as_gltf_and_three_js():
    """glTF's double-sided back face negates tangent, bitangent and normal alike (three.js and
    Khronos' sample viewer do so): the normal-mapped normal flips whole, so a back face lit from
    a direction looks as the front lit from the opposite one. Flipping the bitangent alone
    (as the normal does, through B = N x T) leaves the tangent's share unflipped: 0.17 off."""
    down = unit([0.5, -0.6, 0.3])
    front = lit_quad_points(True, down)
    assert front.min() > 0.05  # every point lit: the comparison means something
    np.testing.assert_allclose(lit_quad_points(False, -down), front, atol=1e-6)
