"""Directional lightmaps from the bake (`--directional`): known answers under a sun, a lamp
and a uniform sky, and the runtime model fed by them end to end."""
from __future__ import annotations

import numpy as np
import pytest
from render_scenes import _box, _quad, normal_texture, scene_from_parts

from patchlight.bake import bake
from patchlight.bakedir import write_bake
from patchlight.cli.main import main
from patchlight.config import BakeSettings
from patchlight.imaging.io import read_exr
from patchlight.scene.model import Light, Material
from patchlight.scene.sky import Sky
from patchlight.shading.directional import Y00, Y1, dominant_direction, sh_light

SUN = np.array([-0.3, -0.8, -0.5]) / np.linalg.norm([-0.3, -0.8, -0.5])  # the way the sunlight travels
GREY = Material(base_color=np.array([0.7, 0.7, 0.7, 1], np.float32))


def _floor(lights, sky=None):
    floor = _quad([[-1, 0, 1], [1, 0, 1], [1, 0, -1], [-1, 0, -1]], [0, 1, 0])
    return scene_from_parts([floor], [GREY], [0], lights, sky, [(0.05, 0.05, 0.95, 0.95)])


def _texels(result):
    covered = result.patches.index >= 0
    return result.directional.maps[:, covered], result.lightmap[covered]


def _tilted(n, degrees):
    t = np.radians(degrees)
    return np.tile([np.sin(t), np.cos(t), 0.0], (n, 1))


@pytest.mark.parametrize("mode", ["sh", "dominant"])
def test_a_single_sun_points_the_dominant_direction_at_it(mode):
    sun = Light("directional", np.ones(3, np.float32), 3.0, direction=SUN.astype(np.float32))
    result = bake(_floor([sun]), BakeSettings(resolution=16, rays=16, directional=mode))
    texels, I = _texels(result)
    assert np.allclose(I, 3.0 * -SUN[1] / np.pi, rtol=1e-4)
    L, share = dominant_direction(mode, texels)
    assert np.degrees(np.arccos(np.clip(L @ -SUN, -1, 1))).max() < 2.0
    assert share.min() > 0.99
    if mode == "sh":  # L1 of a delta: Es (1/4 + cos/2) / pi, within Es / (4 pi) of Es max(cos, 0) / pi
        for tilt in (-60, -20, 0, 30, 80):
            n = _tilted(len(I), tilt)
            cos = n[0] @ -SUN
            got = sh_light(texels, n)[:, 0]
            assert np.allclose(got, 3.0 * (0.25 + 0.5 * cos) / np.pi, rtol=1e-3)
            assert np.abs(got - 3.0 * max(cos, 0) / np.pi).max() <= 3.0 / (4 * np.pi) * 1.001


def test_a_uniform_sky_gives_the_tilted_normals_exact_light():
    """An open floor under a sky of radiance L: a normal tilted by t from up sees I = L (1 + cos t) / 2,
    which L1 holds exactly."""
    result = bake(_floor([], Sky.uniform([0.5, 1.0, 2.0])), BakeSettings(resolution=16, rays=64, directional="sh"))
    texels, I = _texels(result)
    assert np.allclose(I, [0.5, 1.0, 2.0], rtol=1e-3)
    for tilt in (0, 45, 90, 135):
        expected = np.array([0.5, 1.0, 2.0]) * (1 + np.cos(np.radians(tilt))) / 2
        assert np.allclose(sh_light(texels, _tilted(len(I), tilt)), expected, rtol=1e-3)
    L, share = dominant_direction("sh", texels)
    assert np.degrees(np.arccos(np.clip(L[:, 1], -1, 1))).max() < 0.1 and share.max() < 0.6


def _hemisphere_sh(sky, normal, n=400):
    """L1 coefficients (4, 3) of the sky's radiance over the hemisphere about `normal`, by midpoint quadrature."""
    theta = (np.arange(n) + 0.5) / n * np.pi / 2
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    local = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    tangent = np.cross(normal, [0.0, 0.0, 1.0])
    tangent /= np.linalg.norm(tangent)
    dirs = local @ np.stack([tangent, np.cross(normal, tangent), normal])
    d_omega = (np.sin(t) * (np.pi / 2 / n) * (np.pi / n)).reshape(-1, 1)
    L = sky.radiance(dirs.astype(np.float32)) * d_omega
    return np.stack([Y00 * L.sum(0), *(Y1 * (L * dirs[:, k:k + 1]).sum(0) for k in range(3))])


def test_a_gradient_sky_on_a_tilted_plane_is_projected_like_the_quadrature():
    """A plane tilted 60 degrees sees sky and ground, unevenly around its normal and with a
    jump at the horizon, where the 1/cos of grazing rays is largest: at 256 rays the gathered
    L1 is within 4 % of a dense quadrature on average and 15 % at the worst texel, for normals
    up to 60 degrees off the plane's (measured 2-3 % and 8-13 %)."""
    sky = Sky.gradient([0.2, 0.4, 1.6], [1.2, 1.0, 0.8], [0.05, 0.05, 0.05])
    tilt = np.radians(60)
    normal = np.array([np.sin(tilt), np.cos(tilt), 0.0])
    c, s_ = np.cos(tilt), np.sin(tilt)
    corners = [[-c, s_, 1], [c, -s_, 1], [c, -s_, -1], [-c, s_, -1]]  # the floor turned about z
    plane = scene_from_parts([_quad(corners, normal)], [GREY], [0], [], sky, [(0.05, 0.05, 0.95, 0.95)])
    result = bake(plane, BakeSettings(resolution=16, rays=256, directional="sh"))
    texels, I = _texels(result)
    exact = np.broadcast_to(_hemisphere_sh(sky, normal)[:, None], (4, len(I), 3))
    for off in (0, 30, -30, 60, -60):
        t = tilt + np.radians(off)
        n = np.tile([np.sin(t), np.cos(t), 0.0], (len(I), 1))
        error = np.abs(sh_light(texels, n) / sh_light(exact, n) - 1)
        assert error.mean() < 0.04 and error.max() < 0.15


def test_a_lamp_is_the_dominant_direction_of_each_texel():
    lamp = Light("point", np.ones(3, np.float32), 5.0, position=np.array([0.3, 0.7, -0.2], np.float32))
    result = bake(_floor([lamp]), BakeSettings(resolution=16, rays=16, directional="dominant"))
    texels, _ = _texels(result)
    L, _ = dominant_direction("dominant", texels)
    covered = result.patches.index >= 0
    position = np.zeros((16, 16, 3))
    position[result.patches.texel_y, result.patches.texel_x] = result.patches.position
    to_lamp = lamp.position - position[covered]
    to_lamp /= np.linalg.norm(to_lamp, axis=1, keepdims=True)
    assert np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", L, to_lamp), -1, 1))).max() < 2.0


def test_bake_then_render_the_directional_model(tmp_path):
    """End to end: bake --directional writes the maps; without a normal map the model is the
    plain lightmap within 1 %, with one it shades the bumps."""
    sun = Light("directional", np.ones(3, np.float32), 3.0, direction=SUN.astype(np.float32))
    bumpy = Material(name="bumpy", base_color=np.array([0.7, 0.7, 0.7, 1], np.float32), normal_texture=normal_texture())
    floor = _quad([[-2, 0, 2], [2, 0, 2], [2, 0, -2], [-2, 0, -2]], [0, 1, 0])
    parts = [floor, *_box([-0.5, 0, -0.5], [0.5, 1, 0.5])]
    boxes = [(0.02, 0.02, 0.6, 0.6)] + [(0.65 + 0.05 * (k % 6), 0.65, 0.69 + 0.05 * (k % 6), 0.95) for k in range(6)]
    scene = scene_from_parts(parts, [bumpy, GREY], [0] + [1] * 6, [sun], Sky.uniform([0.3, 0.35, 0.5]), boxes)
    for mode, name in (("sh", "lightmap_sh.exr"), ("dominant", "lightmap_dir.exr")):
        out = tmp_path / mode
        result = bake(scene, BakeSettings(resolution=48, rays=64, directional=mode))
        write_bake(result, out, BakeSettings(resolution=48, rays=64, directional=mode))
        assert (out / name).exists()
        pictures = {}
        for model, extra in (("lightmap", []), ("lightmap-directional", []), ("lightmap-directional", ["--normal-map"]),
                             ("lightmap", ["--normal-map"])):
            png = tmp_path / f"{mode}-{model}-{len(extra)}.exr"
            assert main(["render", str(out), "--model", model, *extra, "--camera", "3,3,3", "0,0,0", "50",
                         "--size", "48x48", "-o", str(png)]) == 0
            pictures[model, len(extra)] = read_exr(png)
        plain, flat = pictures["lightmap", 0], pictures["lightmap-directional", 0]
        lit = (plain.max(axis=2) > 1e-3) & ~np.all(np.isclose(plain, [0.3, 0.35, 0.5]), axis=2)  # not the sky
        assert lit.mean() > 0.3
        assert np.abs(flat - plain)[lit].max() <= 0.01 * plain[lit].max()
        assert np.abs(flat[lit] / plain[lit] - 1).max() < 0.01
        bumped = pictures["lightmap-directional", 1]
        assert np.abs(bumped[lit] / plain[lit] - 1).mean() > 0.03  # the bumps show under baked light
        assert np.array_equal(pictures["lightmap", 1], plain)  # the plain lightmap ignores them


def test_an_emissive_panel_is_where_the_light_comes_from():
    """No lamp, no sky: a 0.5 m emissive panel 1 m above one end of the floor. Every floor
    texel's dominant direction points into the panel's cone, and its L1 light is brighter
    for a normal turned towards the panel than for one turned away."""
    glow = Material(name="glow", base_color=np.array([0.0, 0.0, 0.0, 1], np.float32),
                    emissive=np.array([4.0, 4.0, 4.0], np.float32))
    panel = _quad([[0.25, 1, -0.25], [0.75, 1, -0.25], [0.75, 1, 0.25], [0.25, 1, 0.25]], [0, -1, 0])
    floor = _quad([[-1, 0, 1], [1, 0, 1], [1, 0, -1], [-1, 0, -1]], [0, 1, 0])
    scene = scene_from_parts([floor, panel], [GREY, glow], [0, 1], [], None,
                             [(0.05, 0.05, 0.6, 0.95), (0.7, 0.05, 0.95, 0.3)])
    for mode in ("dominant", "sh"):
        result = bake(scene, BakeSettings(resolution=32, rays=256, directional=mode))
        on_floor = result.patches.triangle < 2
        texel = result.patches.texel_y[on_floor], result.patches.texel_x[on_floor]
        texels = result.directional.maps[:, texel[0], texel[1]]
        to_panel = np.array([0.5, 1.0, 0.0]) - result.patches.position[on_floor]
        distance = np.linalg.norm(to_panel, axis=1)
        to_panel /= distance[:, None]
        L, share = dominant_direction(mode, texels)
        cone = np.degrees(np.arctan(0.36 / distance)) + 3  # the panel's half-diagonal seen from the texel
        assert (np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", L, to_panel), -1, 1))) < cone).all()
        if mode == "sh":
            towards, away = sh_light(texels, to_panel), sh_light(texels, -to_panel)
            assert (towards[:, 0] > 2 * np.maximum(away[:, 0], 0)).all()
