"""`patchlight render`: outputs, and one clear line with status 2 for bad input."""
from __future__ import annotations

import numpy as np
import pytest
from render_scenes import closed_sphere_under_a_sun, showcase_scene

from patchlight.cli.main import main
from patchlight.imaging.exposure import exposed_png_pixels
from patchlight.imaging.io import read_exr, read_image, write_exr
from patchlight.render import Camera, Renderer, Target, target_settings
from patchlight.scene import load_scene
from patchlight.scene.gltf import save_baked_glb

CAMERA = ["3.2,2.0,4.2", "0.2,-0.3,0.0", "40"]


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "showcase.glb"
    save_baked_glb(showcase_scene(12, 24), path)
    return path


@pytest.fixture(scope="module")
def bake_dir(tmp_path_factory, scene_file):
    """A bake directory as `patchlight bake` leaves it: scene.glb with TEXCOORD_1 and lightmap.exr."""
    out = tmp_path_factory.mktemp("bake")
    (out / "scene.glb").write_bytes(scene_file.read_bytes())
    lightmap = np.full((8, 8, 3), 0.25, np.float32)
    lightmap[:, 4:] = 1.0
    write_exr(out / "lightmap.exr", lightmap)
    (out / "bake.json").write_text("{}")
    return out


def test_exr_holds_the_renderers_linear_radiance_and_png_its_exposed_picture(scene_file, tmp_path, capsys):
    exr, png = tmp_path / "out.exr", tmp_path / "out.png"
    common = [str(scene_file), "--model", "phong", "--camera", *CAMERA, "--size", "40x30"]
    assert main(["render", *common, "-o", str(exr)]) == 0
    assert main(["render", *common, "--exposure", "0.7", "-o", str(png)]) == 0
    target = Target.from_scene(load_scene(str(scene_file)))
    camera = Camera(np.array([3.2, 2.0, 4.2]), np.array([0.2, -0.3, 0.0]), 40.0)
    expected = Renderer(target).render(target_settings(target, model="phong"), camera, 40, 30).radiance
    np.testing.assert_array_equal(read_exr(exr), expected)
    picture = np.round(read_image(png) * 255).astype(np.uint8)
    np.testing.assert_array_equal(picture, exposed_png_pixels(expected, 0.7))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.exr", "out.png"]
    assert "exposure 0.7" in capsys.readouterr().out


def test_lightmap_model_reads_a_bake_directory(bake_dir, tmp_path):
    out = tmp_path / "lm.exr"
    assert main(["render", str(bake_dir), "--model", "lightmap", "--camera", *CAMERA, "--size", "32x32",
                 "--specular", "-o", str(out)]) == 0
    image = read_exr(out)
    assert image.shape == (32, 32, 3) and image.max() > 0


@pytest.mark.parametrize("target, model", [("bake", "lightmap"), ("file", "lambert")])
def test_view_shows_a_bakes_lightmap_first(bake_dir, scene_file, target, model):
    """The default model comes from the loaded target: lightmap when it has one."""
    from patchlight.cli.options import load_target_and_settings
    from patchlight.cli.parser import build_parser

    args = build_parser().parse_args(["view", str(bake_dir if target == "bake" else scene_file)])
    assert load_target_and_settings(args, args.model)[1].model == model


def test_a_directory_that_is_not_a_complete_bake_is_refused(bake_dir, tmp_path, capsys):
    half = tmp_path / "half"
    half.mkdir()
    for name in ("scene.glb", "lightmap.exr"):  # bake.json, written last, is missing
        (half / name).write_bytes((bake_dir / name).read_bytes())
    assert main(["render", str(half), "--size", "8x8", "-o", str(tmp_path / "x.png")]) == 2
    assert "not a complete bake" in capsys.readouterr().err


def test_envmap_from_a_point_in_the_scene_differs_from_the_sky(scene_file, tmp_path):
    sky, room = tmp_path / "sky.exr", tmp_path / "point.exr"
    base = [str(scene_file), "--model", "envmap", "--camera", *CAMERA, "--size", "24x24"]
    assert main(["render", *base, "-o", str(sky)]) == 0
    assert main(["render", *base, "--envmap-from", "0,0.5,2.5", "-o", str(room)]) == 0
    assert np.abs(read_exr(sky) - read_exr(room)).max() > 0.01
    assert main(["render", *base, "--envmap-from", "0,0,0", "-o", str(room)]) == 2  # inside the sphere


def test_inside_geometry_messages_name_the_option_to_change(scene_file, tmp_path, capsys):
    out = tmp_path / "x.png"
    base = ["render", str(scene_file), "--model", "envmap", "--size", "8x8", "-o", str(out)]
    assert main([*base, "--camera", *CAMERA, "--envmap-from", "0,0,0"]) == 2
    assert "--envmap-from 0,0,0 is inside geometry" in capsys.readouterr().err
    assert main([*base, "--camera", "0,0,0", "0,0,-1", "45"]) == 2
    assert "--camera" in capsys.readouterr().err


@pytest.fixture(scope="module")
def closed_sphere_file(tmp_path_factory):
    """sphere.glb: a closed single-sided sphere under a sun, no sky (its centre is inside it)."""
    path = tmp_path_factory.mktemp("sphere") / "sphere.glb"
    save_baked_glb(closed_sphere_under_a_sun(lat=12, lon=24).scene, path)
    return path


@pytest.mark.parametrize("model", ["lambert", "envmap", "hemisphere-radiosity"])
def test_a_closed_object_without_a_sky_renders_with_every_model_that_reads_the_environment(
        closed_sphere_file, tmp_path, model):
    out = tmp_path / "sphere.exr"
    assert main(["render", str(closed_sphere_file), "--model", model, "--size", "16x16", "-o", str(out)]) == 0
    assert read_exr(out).max() > 0


def test_a_camera_behind_the_cornell_boxs_back_wall_is_outside(tmp_path):
    """The audit's case: outside the box, behind its single-sided back wall, which the viewer culls."""
    out = tmp_path / "cornell.exr"
    assert main(["render", "cornell", "--camera", "0.278,0.27,1.5", "0.278,0.27,0", "40", "--size", "16x16",
                 "-o", str(out)]) == 0
    assert read_exr(out).max() > 0


def test_envmap_from_reaches_hemisphere_radiosity_too(scene_file, tmp_path):
    """Its reflections read the same environment cube as envmap: from the point when given."""
    sky, point = tmp_path / "sky.exr", tmp_path / "point.exr"
    base = [str(scene_file), "--model", "hemisphere-radiosity", "--camera", *CAMERA, "--size", "24x24"]
    assert main(["render", *base, "-o", str(sky)]) == 0
    assert main(["render", *base, "--envmap-from", "0,0.5,2.5", "-o", str(point)]) == 0
    target = Target.from_scene(load_scene(str(scene_file)))
    camera = Camera(np.array([3.2, 2.0, 4.2]), np.array([0.2, -0.3, 0.0]), 40.0)
    settings = target_settings(target, model="hemisphere-radiosity")
    expected = Renderer(target, envmap_from=(0, 0.5, 2.5)).render(settings, camera, 24, 24).radiance
    np.testing.assert_array_equal(read_exr(point), expected)
    assert np.abs(read_exr(sky) - read_exr(point)).max() > 0.01


def test_the_sky_flags_are_the_bakes(scene_file, tmp_path, capsys):
    """--sky-image as bake reads it: a uniform picture is the same sky as --sky of its colour."""
    write_exr(tmp_path / "sky.exr", np.tile(np.float32([0.2, 0.4, 0.8]), (8, 16, 1)))
    base = [str(scene_file), "--model", "hemisphere", "--camera", *CAMERA, "--size", "24x24"]
    assert main(["render", *base, "--sky-image", str(tmp_path / "sky.exr"), "-o", str(tmp_path / "image.exr")]) == 0
    assert main(["render", *base, "--sky", "0.2,0.4,0.8", "-o", str(tmp_path / "uniform.exr")]) == 0
    assert main(["render", *base, "-o", str(tmp_path / "own.exr")]) == 0
    image, uniform = read_exr(tmp_path / "image.exr"), read_exr(tmp_path / "uniform.exr")
    np.testing.assert_allclose(image, uniform, rtol=1e-5, atol=1e-6)
    assert np.abs(image - read_exr(tmp_path / "own.exr")).max() > 0.05
    assert main(["render", *base, "--sky-image", str(tmp_path / "none.exr"), "-o", str(tmp_path / "x.exr")]) == 2
    assert "none.exr" in capsys.readouterr().err


def test_lights_from_the_command_line_replace_the_scenes(scene_file, tmp_path):
    dark, lit = tmp_path / "dark.exr", tmp_path / "lit.exr"
    base = [str(scene_file), "--model", "lambert", "--camera", *CAMERA, "--size", "24x24", "--ambient", "0,0,0"]
    assert main(["render", *base, "--light", "point:0,5,0:1,1,1:0", "-o", str(dark)]) == 0
    assert main(["render", *base, "--light", "point:0,5,0:1,1,1:50:9", "--falloff", "range", "-o", str(lit)]) == 0
    dark_image, lit_image = read_exr(dark), read_exr(lit)
    surfaces = np.any(dark_image != lit_image, axis=2) | (dark_image.max(axis=2) < 0.06)  # not the sky behind
    assert dark_image[surfaces].max() == pytest.approx(0.0, abs=0.06)  # only the box's faint emission
    assert lit_image[surfaces].max() > 0.5


def test_the_documented_minimal_spot_spec_renders(scene_file, tmp_path):
    out = tmp_path / "spot.exr"
    assert main(["render", str(scene_file), "--model", "lambert", "--camera", *CAMERA, "--size", "16x16",
                 "--light", "spot:0,2,0:0,-1,0:1,1,1:10:30", "-o", str(out)]) == 0
    assert read_exr(out).max() > 0


@pytest.mark.parametrize("args, message", [
    (["--model", "toon"], "invalid choice"),
    (["--normal-map", "--per-vertex"], "per-pixel"),
    (["--light", "lamp:0,0,0:1,1,1:1"], "unknown light kind"),
    (["--light", "point:0,1,0:1,1,1:5", "--falloff", "range"], "needs a range"),
    (["--model", "lightmap"], "lightmap"),
    (["--model", "lightmap-directional"], "lightmap-directional"),
    (["--model", "lightmap-directional", "--per-vertex"], "per pixel"),
    (["--camera", "0,0,0", "0,0,-1", "45"], "inside geometry"),
    (["--camera", "0,0,5", "0,0,0"], "expected 3 arguments"),
    (["--size", "0x10"], "1.."),
    (["--exposure", "-1"], "--exposure"),
    (["--reflectivity", "2"], "--reflectivity"),
])
def test_bad_input_is_one_line_and_status_2(scene_file, tmp_path, capsys, args, message):
    out = tmp_path / "x.png"
    status = main(["render", str(scene_file), "--size", "8x8", *args, "-o", str(out)]) if "--size" not in args \
        else main(["render", str(scene_file), *args, "-o", str(out)])
    err = capsys.readouterr().err
    assert status == 2
    assert message in err and err.count("\n") == 1
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_bad_targets_and_outputs(tmp_path, capsys):
    cases = [(["render", str(tmp_path), "-o", str(tmp_path / "a.png")], "not a complete bake"),
             (["render", "room", "-o", str(tmp_path / "a.jpg")], ".png"),
             (["render", "room", "-o", str(tmp_path / "missing" / "a.png")], "does not exist"),
             (["render", "room", "--normal-map", "-o", str(tmp_path / "a.png")], "normal texture")]
    for argv, message in cases:
        assert main(argv) == 2
        assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
