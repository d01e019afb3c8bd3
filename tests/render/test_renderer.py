"""The CPU renderer's camera, culling, inside-geometry check and default camera."""
from __future__ import annotations

import math

import numpy as np
import pytest
from render_scenes import _box, _quad, closed_sphere_under_a_sun, scene_from_parts, showcase_target, sphere_target

from patchlight.errors import PatchlightError
from patchlight.render import Camera, Renderer, Target, target_settings
from patchlight.scene import load_scene
from patchlight.scene.model import Light, Material


def test_rays_go_through_pixel_centres_with_the_vertical_fov_and_row_zero_on_top():
    camera = Camera(np.array([0.0, 0.0, 5.0]), np.zeros(3), 90.0)
    _, d = camera.rays(3, 3)
    np.testing.assert_allclose(d[4], [0, 0, -1], atol=1e-7)  # centre pixel looks at the target
    # top-left pixel centre: x = -2/3 tan(45), y = +2/3 tan(45) at unit distance
    np.testing.assert_allclose(d[0], np.array([-2 / 3, 2 / 3, -1]) / np.linalg.norm([2 / 3, 2 / 3, 1]), atol=1e-7)
    _, wide = Camera(np.array([0.0, 0.0, 5.0]), np.zeros(3), 60.0).rays(4, 2)
    assert np.arctan2(wide[0, 1], -wide[0, 2]) == pytest.approx(math.atan(0.5 * math.tan(math.radians(30))))


@pytest.mark.parametrize("bad", [dict(fov=0.0), dict(fov=180.0), dict(eye=np.zeros(3)),
                                 dict(eye=np.array([0.0, 5.0, 0.0]))])
def test_impossible_cameras_are_refused(bad):
    args = dict(eye=np.array([0.0, 0.0, 5.0]), target=np.zeros(3), fov=45.0) | bad
    with pytest.raises(PatchlightError):
        Camera(**args).rays(4, 4)


def plane_target(double_sided: bool) -> Target:
    plane = _quad([[-2, 0, 2], [2, 0, 2], [2, 0, -2], [-2, 0, -2]], [0, 1, 0])
    mat = Material(base_color=np.ones(4, np.float32), double_sided=double_sided)
    lamp = Light("point", np.ones(3, np.float32), 10.0, position=np.array([0.0, -1.0, 0.0], np.float32))
    return Target.from_scene(scene_from_parts([plane], [mat], [0], [lamp]))


def test_single_sided_back_faces_are_culled_and_double_sided_ones_lit_from_behind():
    """Below a single-sided plane the camera is not inside anything: it sees through the
    plane's back, as WebGL culls it, so nothing is covered."""
    below = Camera(np.array([0.3, -3.0, 0.5]), np.zeros(3), 40.0)
    settings = dict(model="lambert", ambient=(0, 0, 0))
    single = plane_target(False)
    assert not Renderer(single).render(target_settings(single, **settings), below, 16, 16).covered.any()
    double = plane_target(True)
    result = Renderer(double).render(target_settings(double, **settings), below, 16, 16)
    assert result.covered.all()
    assert result.radiance.min() > 0  # the lamp below lights the flipped normal


def test_rays_pass_through_culled_back_faces_to_what_lies_behind():
    """A single-sided quad facing away from the camera hides nothing in front of a second one."""
    back = _quad([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [0, 0, 1])
    front_facing_away = _quad([[-0.3, 0.3, 1], [0.3, 0.3, 1], [0.3, -0.3, 1], [-0.3, -0.3, 1]], [0, 0, -1])
    mats = [Material(name="back", base_color=np.array([1, 0, 0, 1], np.float32)),
            Material(name="away", base_color=np.array([0, 1, 0, 1], np.float32))]
    target = Target.from_scene(scene_from_parts([back, front_facing_away], mats, [0, 1]))
    result = Renderer(target).render(target_settings(target, model="unlit"),
                                     Camera(np.array([0.0, 0.0, 3.0]), np.zeros(3), 30.0), 15, 15)
    assert result.covered[7, 7]
    np.testing.assert_allclose(result.radiance[7, 7], [1, 0, 0])


def test_camera_inside_a_closed_sphere_is_refused_in_one_line():
    target = sphere_target(8, 16)
    with pytest.raises(PatchlightError) as err:
        Renderer(target).render(target_settings(target), Camera(np.zeros(3), np.array([0, 0, -1.0])), 8, 8)
    assert "inside geometry" in str(err.value) and "\n" not in str(err.value)


def test_a_camera_outside_behind_a_single_sided_wall_sees_the_box_through_it():
    """Behind the Cornell box's back wall (single-sided, facing in) the camera is outside: the
    few directions that meet the box meet back faces, most meet nothing. It sees the inside of
    the box through the culled wall, as the viewer does."""
    target = Target.from_scene(load_scene("cornell"))
    renderer = Renderer(target)
    eye = np.array([0.278, 0.27, 1.5])
    assert renderer.inside_share(eye) < 0.1 and not renderer.is_inside(eye)
    result = renderer.render(target_settings(target), Camera(eye, np.array([0.278, 0.27, 0.0]), 40.0), 32, 32)
    assert 0.3 < result.covered.mean() < 1 and result.radiance[result.covered].max() > 0


def test_a_camera_inside_a_solid_wall_is_refused():
    """The room's walls are solid single-sided boxes: inside one, every direction meets a back face."""
    target = Target.from_scene(load_scene("room"))
    renderer = Renderer(target)
    eye = np.array([4.0, 0.45, -0.2])  # inside the front wall, below the middle window
    assert renderer.inside_share(eye) > 0.75  # not 1: faces the wall shares with its neighbours
    assert renderer.inside_share(eye + [0.0, 1.15, 0.0]) == 0  # in the window's opening
    with pytest.raises(PatchlightError, match=r"camera at \(4, 0.45, -0.2\) is inside geometry.*choose another `camera`"):
        renderer.render(target_settings(target), Camera(eye, np.array([4.0, 1.5, 3.0])), 8, 8)


def test_the_environment_cube_of_a_closed_object_is_rendered_from_the_default_cameras_eye():
    target = closed_sphere_under_a_sun()
    renderer = Renderer(target)
    assert renderer.is_inside(renderer.center)
    np.testing.assert_allclose(renderer.environment_point(), renderer.default_camera().eye, rtol=1e-6)
    settings = target_settings(target, model="envmap")
    env = renderer.environment(settings)
    assert env[..., :3].max() > 0  # the sunlit sphere seen from outside
    result = renderer.render(settings, renderer.default_camera(), 16, 16)
    assert result.covered.any() and np.isfinite(result.radiance).all()


def test_an_environment_point_inside_geometry_names_the_options():
    target = closed_sphere_under_a_sun()
    settings = target_settings(target, model="envmap")
    with pytest.raises(PatchlightError, match="`envmap_from` 0,0,0 is inside geometry"):
        Renderer(target, envmap_from=(0.0, 0.0, 0.0)).environment(settings)
    inside_camera = closed_sphere_under_a_sun({"eye": [0.0, 0.0, 0.5], "target": [0.0, 0.0, -1.0], "fov": 45.0})
    with pytest.raises(PatchlightError) as err:
        Renderer(inside_camera).environment(settings)
    message = str(err.value)
    assert "inside geometry" in message and "`envmap_from` X,Y,Z" in message and "`sky` R,G,B" in message
    assert "\n" not in message
    from patchlight.cli.parser import build_parser

    for command in ("render", "view"):  # the command line (and the viewer page's note) names the flags
        line = build_parser().commands[command].user_line(err.value)
        assert "--envmap-from X,Y,Z" in line and "--sky R,G,B" in line and "`" not in line


def test_lightmap_model_needs_a_lightmap():
    target = sphere_target(8, 16)
    with pytest.raises(PatchlightError, match="lightmap"):
        Renderer(target).render(target_settings(target, model="lightmap"),
                                Camera(np.array([0.0, 0.0, 4.0]), np.zeros(3)), 8, 8)


def test_default_camera_sees_an_object_from_outside_and_a_room_from_inside():
    obj = showcase_target()
    camera = Renderer(obj).default_camera()
    lo, hi = obj.scene.bounds()
    assert np.any(camera.eye < lo) or np.any(camera.eye > hi)
    covered = Renderer(obj).render(target_settings(obj), camera, 32, 32).covered
    assert 0.1 < covered.mean() < 0.95
    walls = Material(name="walls", base_color=np.ones(4, np.float32))
    room = Target.from_scene(scene_from_parts(_box([0, 0, 0], [6, 3, 4]), [walls], [0] * 6))
    # turn the box inside out: faces and normals towards the interior
    room.scene.indices = room.scene.indices[:, ::-1].copy()
    room.scene.normals = -room.scene.normals
    room = Target.from_scene(room.scene)
    camera = Renderer(room).default_camera()
    assert np.all(camera.eye > 0) and np.all(camera.eye < [6, 3, 4])
    assert Renderer(room).render(target_settings(room), camera, 16, 16).covered.all()


def test_a_lone_plane_is_seen_from_above_and_reflects_from_off_its_surface():
    """The centre of a lone plane lies on it: the default camera looks from outside (not from
    within the plane), and the environment cube is rendered from a point off it (from the
    plane's centre every ray meets the plane at distance 0: no view vector, NaN light)."""
    plane = Target.from_scene(scene_from_parts([_quad([[-2, 0, 2], [2, 0, 2], [2, 0, -2], [-2, 0, -2]], [0, 1, 0])],
                                               [Material(name="floor", base_color=np.ones(4, np.float32))], [0],
                                               [Light(kind="directional", color=np.ones(3, np.float32), intensity=3.0,
                                                      direction=np.float32([0.3, -1.0, 0.2]))]))
    renderer = Renderer(plane)
    assert renderer.on_surface(renderer.center)
    camera = renderer.default_camera()
    assert abs(camera.eye[1]) > 1.0
    point = renderer.environment_point()
    assert not renderer.on_surface(point) and not renderer.is_inside(point)
    settings = target_settings(plane, model="envmap")
    assert np.isfinite(renderer.environment(settings)).all()
    result = renderer.render(settings, camera, 16, 16)
    assert result.covered.mean() > 0.1 and np.isfinite(result.radiance).all()  # edge-on before: none


def test_every_model_and_option_renders_the_showcase():
    target = showcase_target(12, 24)
    renderer = Renderer(target)
    camera = Camera(np.array([3.2, 2.0, 4.2]), np.array([0.2, -0.3, 0.0]), 40.0)
    from patchlight.shading import MODELS
    for model in MODELS:
        for options in ({}, {"per_vertex": True}, {"normal_map": True}, {"falloff": "range"}):
            if model == "lightmap-directional" and options.get("per_vertex"):
                continue  # refused: tests/render/test_cli_render.py
            result = renderer.render(target_settings(target, model=model, **options), camera, 24, 24)
            assert np.isfinite(result.radiance).all() and result.radiance[result.covered].max() > 0


def test_the_sky_shows_behind_the_surfaces():
    from patchlight.scene.sky import Sky

    sky = Sky.gradient([0.1, 0.2, 0.9], [0.5, 0.5, 0.6], [0.05, 0.04, 0.03])
    target = sphere_target(sky=sky)
    camera = Camera(np.array([0.0, 0.0, 5.0]), np.zeros(3), 60.0)
    result = Renderer(target).render(target_settings(target, "lambert"), camera, 32, 32)
    _, directions = camera.rays(32, 32)
    behind = ~result.covered.ravel()
    assert result.covered.any() and behind.any()
    np.testing.assert_allclose(result.radiance.reshape(-1, 3)[behind], sky.radiance(directions[behind]), rtol=1e-6)


def test_the_environment_cube_is_made_once_per_lights_and_surroundings(monkeypatch):
    target = showcase_target(8, 16)
    renderer = Renderer(target, envmap_from=(0.0, 0.5, 2.5))
    made = []
    make = renderer._make_environment
    monkeypatch.setattr(renderer, "_make_environment", lambda *a: made.append(1) or make(*a))
    camera = Camera(np.array([3.2, 2.0, 4.2]), np.array([0.2, -0.3, 0.0]), 40.0)
    for model in ("envmap", "hemisphere-radiosity", "envmap"):
        renderer.render(target_settings(target, model=model), camera, 8, 8)
    assert len(made) == 1 and not renderer.sky_is_environment
    renderer.render(target_settings(target, model="envmap", ambient=(0.5, 0.5, 0.5)), camera, 8, 8)
    assert len(made) == 2  # other surroundings: another cube
    assert Renderer(target).sky_is_environment
