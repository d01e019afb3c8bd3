"""The CPU renderer against closed forms: Lambert's cosine on a sphere, the specular peak at
the mirror point, the self-shadow terminator, the range falloff's edge, inverse-square units,
the lightmap model's albedo x I, and per-vertex against per-pixel lighting."""
from __future__ import annotations

import math

import numpy as np
import pytest
from render_scenes import _box, _quad, scene_from_parts, sphere_target

from patchlight.errors import PatchlightError
from patchlight.render import Camera, Renderer, Target, target_settings
from patchlight.render.output import display_pixels
from patchlight.scene.model import Light, Material
from patchlight.scene.sky import Sky

WHITE = Material(name="white", base_color=np.array([1.0, 1.0, 1.0, 1.0], np.float32), shininess=32.0)
BLACK = Material(name="black", base_color=np.array([0.0, 0.0, 0.0, 1.0], np.float32), shininess=400.0)
NO_AMBIENT = dict(ambient=(0, 0, 0), sky=(0, 0, 0), ground=(0, 0, 0))
SPHERE_CAMERA = Camera(np.array([0.0, 0.6, 4.0]), np.array([0.0, 0.0, 0.0]), 35.0)


def sun(direction_to_light, irradiance=math.pi):
    d = -np.asarray(direction_to_light, np.float32)
    return Light("directional", np.ones(3, np.float32), irradiance, direction=d / np.linalg.norm(d))


def sphere_hits(camera: Camera, size: int):
    """Analytic hit points on the unit sphere (size*size, 3) and a mask of rays that hit it."""
    o, d = camera.rays(size, size)
    o, d = o.astype(np.float64), d.astype(np.float64)
    b = np.einsum("ij,ij->i", o, d)
    disc = b * b - (np.einsum("ij,ij->i", o, o) - 1)
    t = -b - np.sqrt(np.maximum(disc, 0))
    return o + t[:, None] * d, disc > 0.02  # keep clear of the polygonal silhouette


def render(target, camera, size, **settings):
    return Renderer(target).render(target_settings(target, **settings), camera, size, size)


def test_lambert_on_a_sphere_follows_n_dot_l():
    L = np.array([0.5, 0.7, 0.5]) / np.linalg.norm([0.5, 0.7, 0.5])
    target = sphere_target(96, 192, [sun(L)], WHITE)
    result = render(target, SPHERE_CAMERA, 64, model="lambert", **NO_AMBIENT)
    points, hit = sphere_hits(SPHERE_CAMERA, 64)
    covered = result.covered.reshape(-1)
    assert np.all(covered[hit])
    expected = np.maximum(points[hit] @ L, 0)  # I = E / pi = 1
    got = result.radiance.reshape(-1, 3)[hit]
    np.testing.assert_allclose(got, np.repeat(expected[:, None], 3, axis=1), atol=2e-3)


@pytest.mark.parametrize("model", ["phong", "blinn-phong"])
def test_specular_peak_sits_at_the_mirror_point_of_a_plane(model):
    """A black plane under a sun shows only the highlight; it peaks where reflect(-L, N) (and so
    the half vector, N.H = 1) points at the eye, with (R.V)^n = 1 there."""
    L = np.array([0.3, 0.8, -0.5]) / np.linalg.norm([0.3, 0.8, -0.5])
    plane = _quad([[-6, 0, 6], [6, 0, 6], [6, 0, -6], [-6, 0, -6]], [0, 1, 0])
    target = Target.from_scene(scene_from_parts([plane], [BLACK], [0], [sun(L)]))
    camera = Camera(np.array([0.0, 2.0, 4.0]), np.array([0.5, 0.0, 2.0]), 60.0)
    size = 129
    result = render(target, camera, size, model=model, **NO_AMBIENT)
    R = np.array([-L[0], L[1], -L[2]])  # the sun mirrored in the plane
    mirror = camera.eye - camera.eye[1] / R[1] * R
    o, d = camera.rays(size, size)
    peak = int(np.argmax(result.radiance.reshape(-1, 3)[:, 0]))
    peak_point = o[peak] - o[peak, 1] / d[peak, 1] * d[peak]
    footprint = 2 * math.tan(math.radians(30)) * np.linalg.norm(camera.eye - mirror) / size
    assert np.linalg.norm(peak_point - mirror) < 1.5 * footprint / abs(d[peak] @ [0, 1, 0])
    assert result.radiance.reshape(-1, 3)[peak, 0] == pytest.approx(1.0, abs=0.05)  # I = 1, spec = 1


def test_self_shadow_vanishes_exactly_at_the_terminator_where_phong_still_glints():
    """Light from behind the sphere: Phong's (R.V)^n lights pixels past the terminator; the
    self-shadow term S = saturate(4 N.L) makes every pixel with N.L <= 0 exactly black."""
    L = np.array([0.5, 0.3, -0.8]) / np.linalg.norm([0.5, 0.3, -0.8])
    dull = Material(name="dull", base_color=np.ones(4, np.float32), shininess=8.0)
    target = sphere_target(96, 192, [sun(L)], dull)
    points, hit = sphere_hits(SPHERE_CAMERA, 96)
    n_dot_l = points @ L
    dark, lit = hit & (n_dot_l < -0.02), hit & (n_dot_l > 0.02)
    shadow = render(target, SPHERE_CAMERA, 96, model="self-shadow", **NO_AMBIENT).radiance.reshape(-1, 3)
    phong = render(target, SPHERE_CAMERA, 96, model="phong", **NO_AMBIENT).radiance.reshape(-1, 3)
    assert dark.sum() > 1000 and lit.sum() > 100
    assert np.all(shadow[dark] == 0)
    assert np.all(shadow[lit].max(axis=1) > 0)
    assert phong[dark].max() > 0.2


@pytest.mark.parametrize("falloff", ["range", "inverse-square"])
def test_a_lights_range_reaches_zero_at_the_range(falloff):
    """Both falloffs honour the light's range: nothing from r on. Inverse-square is the plain
    J cos / (pi d^2) well inside it (the window is within 1 % of 1 up to r / 4)."""
    r = 3.0
    plane = _quad([[-8, 0, 8], [8, 0, 8], [8, 0, -8], [-8, 0, -8]], [0, 1, 0])
    lamp = Light("point", np.ones(3, np.float32), 10.0, position=np.array([0.0, 0.5, 0.0], np.float32), range=r)
    target = Target.from_scene(scene_from_parts([plane], [WHITE], [0], [lamp]))
    camera = Camera(np.array([0.0, 9.0, 4.0]), np.array([0.0, 0.0, 0.0]), 60.0)
    result = render(target, camera, 96, model="lambert", falloff=falloff, **NO_AMBIENT)
    o, d = camera.rays(96, 96)
    ground = o - (o[:, 1] / d[:, 1])[:, None] * d
    distance = np.linalg.norm(ground - lamp.position, axis=1)
    radiance = result.radiance.reshape(-1, 3)[:, 0]
    covered = result.covered.reshape(-1)
    assert np.all(radiance[covered & (distance > r + 0.01)] == 0)
    assert np.all(radiance[covered & (distance < r - 0.05)] > 0)
    assert (covered & (distance > r + 0.01)).sum() > 500
    if falloff == "inverse-square":
        plain = 10.0 * (0.5 / distance) / (math.pi * distance ** 2)  # J cos / (pi d^2), cos = height / d
        window = np.clip(1 - (distance / r) ** 4, 0, 1) ** 2
        inside = covered & (distance < r)
        np.testing.assert_allclose(radiance[inside], (plain * window)[inside], rtol=2e-4, atol=1e-7)
        near = covered & (distance < r / 4)
        assert near.sum() > 20
        np.testing.assert_allclose(radiance[near], plain[near], rtol=0.01)


def test_point_light_units_are_intensity_over_pi_d_squared():
    plane = _quad([[-2, 0, 2], [2, 0, 2], [2, 0, -2], [-2, 0, -2]], [0, 1, 0])
    lamp = Light("point", np.ones(3, np.float32), 20.0, position=np.array([0.0, 2.0, 0.0], np.float32))
    grey = Material(base_color=np.array([0.5, 0.5, 0.5, 1.0], np.float32))
    target = Target.from_scene(scene_from_parts([plane], [grey], [0], [lamp]))
    camera = Camera(np.array([0.0, 3.0, 0.5]), np.array([0.0, 0.0, 0.0]), 10.0)
    result = render(target, camera, 33, model="lambert", **NO_AMBIENT)
    o, d = camera.rays(33, 33)
    centre = 16 * 33 + 16
    p = o[centre] - o[centre, 1] / d[centre, 1] * d[centre]
    to_light = lamp.position - p
    dist = np.linalg.norm(to_light)
    expected = 0.5 * 20.0 * (to_light[1] / dist) / (math.pi * dist * dist)
    assert result.radiance[16, 16, 0] == pytest.approx(expected, rel=1e-4)


def test_lightmap_model_shows_albedo_times_incident_light_with_row_zero_at_v_zero():
    plane = _quad([[-1, 0, 1], [1, 0, 1], [1, 0, -1], [-1, 0, -1]], [0, 1, 0])  # uv v = 0 at z = +1
    grey = Material(base_color=np.array([0.5, 0.5, 0.5, 1.0], np.float32))
    scene = scene_from_parts([plane], [grey], [0], uv1_boxes=[(0, 0, 1, 1)])
    lightmap = np.full((16, 16, 3), 0.2, np.float32)
    lightmap[:8] = 0.8  # rows 0..7: v < 0.5, the z > 0 half
    target = Target.from_scene(scene, lightmap)
    camera = Camera(np.array([0.0, 3.0, 0.01]), np.array([0.0, 0.0, 0.0]), 30.0)
    result = render(target, camera, 64, model="lightmap")
    o, d = camera.rays(64, 64)
    z = (o - (o[:, 1] / d[:, 1])[:, None] * d)[:, 2]
    radiance = result.radiance.reshape(-1, 3)[:, 0]
    covered = result.covered.reshape(-1)
    np.testing.assert_allclose(radiance[covered & (z > 0.1)], 0.4, rtol=1e-6)
    np.testing.assert_allclose(radiance[covered & (z < -0.1)], 0.1, rtol=1e-6)


def test_hemisphere_shows_sky_on_top_and_ground_below_and_nothing_else():
    """mix(ground, sky, 0.5 + 0.5 N.y) x colour alone: the scene's sun and lamp add nothing."""
    lamp = Light("point", np.ones(3, np.float32), 30.0, position=np.array([0.0, 2.0, 2.0], np.float32))
    target = sphere_target(48, 96, [sun([0.3, 0.8, 0.5]), lamp], WHITE)
    sky, ground = np.array([0.2, 0.4, 0.9]), np.array([0.3, 0.2, 0.1])
    side = Camera(np.array([0.0, 0.0, 4.0]), np.zeros(3), 35.0)
    result = render(target, side, 65, model="hemisphere", sky=sky, ground=ground)
    points, hit = sphere_hits(side, 65)
    expected = ground + (sky - ground) * (0.5 + 0.5 * points[hit, 1:2])
    np.testing.assert_allclose(result.radiance.reshape(-1, 3)[hit], expected, atol=2e-3)
    np.testing.assert_allclose(result.radiance[32, 32], (sky + ground) / 2, atol=1e-3)  # N.y = 0


def test_envmap_reflects_the_sky_by_the_fresnel_weight():
    """Black, perfectly reflective sphere under a uniform sky L: radiance = L (1 - N.V)."""
    mirror = Material(base_color=np.array([0.0, 0.0, 0.0, 1.0], np.float32), reflectivity=1.0)
    target = sphere_target(96, 192, [], mirror, sky=Sky.uniform([0.5, 1.0, 2.0]))
    result = render(target, SPHERE_CAMERA, 64, model="envmap", **NO_AMBIENT)
    points, hit = sphere_hits(SPHERE_CAMERA, 64)
    view = SPHERE_CAMERA.eye - points
    n_dot_v = np.einsum("ij,ij->i", points, view / np.linalg.norm(view, axis=1, keepdims=True))
    expected = (1 - n_dot_v[hit])[:, None] * [0.5, 1.0, 2.0]
    np.testing.assert_allclose(result.radiance.reshape(-1, 3)[hit], expected, atol=5e-3)


def display_difference(a, b):
    both = a.covered & b.covered
    return np.abs(display_pixels(a.radiance, 1.0)[both].astype(int) - display_pixels(b.radiance, 1.0)[both]).mean()


def test_per_vertex_matches_per_pixel_on_a_fine_sphere_and_not_on_a_coarse_one():
    L = np.array([0.4, 0.6, 0.7]) / np.linalg.norm([0.4, 0.6, 0.7])
    diffs = {}
    for lat, lon in ((6, 12), (96, 192)):
        target = sphere_target(lat, lon, [sun(L, 4.0)], WHITE)
        pixel = render(target, SPHERE_CAMERA, 64, model="blinn-phong")
        vertex = render(target, SPHERE_CAMERA, 64, model="blinn-phong", per_vertex=True)
        diffs[lat] = display_difference(pixel, vertex)
    assert diffs[96] < 0.5
    assert diffs[6] > 4.0


def test_envmap_rendered_from_a_point_sees_the_lit_walls_and_the_suns_highlight():
    """Inside a white box lit only by an ambient A, every wall shows radiance A (Lambert); the
    cube map rendered from the centre holds A in every texel, and alpha the sun's highlight,
    luminance(E / pi) in the sun's direction."""
    walls = Material(name="walls", base_color=np.ones(4, np.float32))
    scene = scene_from_parts(_box([-1, -1, -1], [1, 1, 1]), [walls], [0] * 6)
    scene.indices = scene.indices[:, ::-1].copy()  # faces and normals towards the inside
    scene.normals = -scene.normals
    target = Target.from_scene(scene)
    up = Light("directional", np.ones(3, np.float32), math.pi, direction=np.array([0, -1, 0], np.float32))
    settings = target_settings(target, model="envmap", lights=[up], ambient=(0.3, 0.3, 0.3))
    cube = Renderer(target, envmap_from=(0.0, 0.0, 0.0)).environment(settings, size=9)  # a texel centre on each axis
    np.testing.assert_allclose(cube[0, ..., :3], 0.3, atol=1e-6)  # +X wall: ambient only
    np.testing.assert_allclose(cube[3, ..., :3], 0.3 + 1.0, atol=1e-6)  # -Y face sees the floor: A + I N.L
    assert cube[..., 3].max() == pytest.approx(1.0, abs=0.01)  # luminance of I = 1 at the sun
    assert np.argmax(cube[..., 3].reshape(6, -1).max(axis=1)) == 2  # on the +Y face
    # outside the box, looking at it, a point sees through the near wall's back (culled, as in
    # the viewer) the inside of the far wall; looking away, nothing (no sky)
    outside = Renderer(target, envmap_from=(5.0, 0.0, 0.0)).environment(settings, size=9)
    np.testing.assert_allclose(outside[1, 4, 4, :3], 0.3, atol=1e-6)  # -X: the far wall, ambient only
    assert outside[0, ..., :3].max() == 0  # +X: away from the box
    with pytest.raises(PatchlightError, match="`envmap_from` 0,0,0 is inside geometry"):
        Renderer(sphere_target(8, 16), envmap_from=(0.0, 0.0, 0.0)).environment(settings)
