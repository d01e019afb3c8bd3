"""`patchlight groundmap` end to end: a scene baked on the spot, a bake directory, bad input."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from patchlight.cli.main import main
from patchlight.cli.options import load_target_and_settings
from patchlight.cli.parser import build_parser
from patchlight.errors import PatchlightError
from patchlight.ground.files import load_ground_map
from patchlight.ground.groundmap import GroundMapSettings, make_groundmap, write_groundmap
from patchlight.ground.viewer import ground_map_target
from patchlight.imaging.io import read_exr
from patchlight.solved import load_solved


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    """`patchlight groundmap cornell` baked on the spot into one directory (a sky, no sun: one warning)."""
    out = tmp_path_factory.mktemp("cornell")
    status = main(["groundmap", "cornell", "-o", str(out), "--size", "32", "--quiet", "--texels-per-unit", "8",
                   "--shadows", "alpha", "--sky", "0.5,0.6,0.9"])
    return status, out


def test_a_scene_is_baked_into_the_output_which_is_then_a_bake_too(baked, capsys):
    status, out = baked
    assert status == 0
    names = {p.name for p in out.iterdir()}
    assert {"groundmap.png", "groundmap.dds", "groundmap.json", "scene.glb", "lightmap.exr"} <= names
    assert not [n for n in names if n.startswith(".")]               # no temporary files left
    manifest = json.loads((out / "groundmap.json").read_text())
    assert manifest["bake"] == "." and manifest["encoding"] == "alpha" and manifest["size"] == 32
    assert manifest["sun"] is None and len(manifest["warnings"]) == 1 and "no sun" in manifest["warnings"][0]


def test_a_bake_directory_is_read_and_named_relative_to_the_output(baked, tmp_path, capsys):
    _, bake_dir = baked
    out = tmp_path / "map"
    assert main(["groundmap", str(bake_dir), "-o", str(out), "--size", "16", "--shadows", "hsv"]) == 0
    captured = capsys.readouterr()
    assert "ground map 16 x 16 (hsv)" in captured.out
    assert captured.err.count("warning") == 1 and "no sun" in captured.err
    manifest = json.loads((out / "groundmap.json").read_text())
    assert (out / manifest["bake"]).resolve() == bake_dir.resolve()


def test_view_opens_the_map_written_with_its_own_sky(baked, tmp_path, capsys):
    """A --sky given to groundmap (not the bake's sky) stays in the map the viewer opens."""
    _, bake_dir = baked
    out = tmp_path / "map"
    assert main(["groundmap", str(bake_dir), "-o", str(out), "--size", "16", "--quiet", "--sky", "3,3,3"]) == 0
    manifest = json.loads((out / "groundmap.json").read_text())
    shown, inputs = ground_map_target(str(out))
    assert Path(shown) == bake_dir.resolve()
    assert np.array_equal(inputs.sky_scale, np.float32(manifest["sky_scale"]))
    assert np.array_equal(inputs.texture, load_ground_map(out).texture)
    remade = make_groundmap(load_solved(bake_dir), GroundMapSettings(size=16, shadows=manifest["encoding"]))
    assert not np.allclose(remade.encoded.sky_scale, manifest["sky_scale"])  # the bake's own sky differs


def test_the_map_takes_the_bakes_sun_angle_unless_told_otherwise(tmp_path, capsys):
    bake_dir = tmp_path / "bake"
    assert main(["bake", "cornell", "-o", str(bake_dir), "--resolution", "32", "--rays", "16", "--quiet",
                 "--sun-angle", "5"]) == 0
    for extra, angle in (([], 5.0), (["--sun-angle", "0"], 0.0)):
        out = tmp_path / f"map{len(extra)}"
        assert main(["groundmap", str(bake_dir), "-o", str(out), "--size", "16", "--quiet", *extra]) == 0
        assert json.loads((out / "groundmap.json").read_text())["sun_angle"] == angle


@pytest.mark.parametrize("args, message", [
    (["--size", "20000"], "--size 20000"),
    (["--area", "1,2,3"], "--area 1,2,3"),
    (["--area", "5,5,1,1"], "X1 > X0"),
    (["--area", "100,100,110,110"], "no ground under the area"),
    (["--noise", "2"], "--noise 2"),
    (["--seed", "-1"], "--seed -1: seed must be a whole number >= 0"),
    (["--offset-distance", "-1"], "--offset-distance -1"),
])
def test_bad_input_is_one_line_and_exit_2(baked, tmp_path, capsys, args, message):
    _, bake_dir = baked
    assert main(["groundmap", str(bake_dir), "-o", str(tmp_path / "out"), "--size", "16", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert not (tmp_path / "out" / "groundmap.json").exists()


def test_a_directory_that_is_not_a_bake(tmp_path, capsys):
    assert main(["groundmap", str(tmp_path), "-o", str(tmp_path / "out")]) == 2
    assert "not a bake" in capsys.readouterr().err


def test_an_output_that_cannot_be_made_is_refused_before_any_work(baked, tmp_path, capsys, monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("groundmap started working before checking its output")

    monkeypatch.setattr("patchlight.solved.load_solved", refuse)
    monkeypatch.setattr("patchlight.bake.bake", refuse)
    (tmp_path / "blocker").write_text("a file, not a directory")
    for scene in (str(baked[1]), "cornell"):
        assert main(["groundmap", scene, "-o", str(tmp_path / "blocker" / "map"), "--size", "16"]) == 2
        err = capsys.readouterr().err
        assert "is a file, not a directory" in err and err.count("\n") == 1


@pytest.mark.parametrize("change, message", [
    (lambda m: m.pop("mapping"), "mapping needs U and V"),
    (lambda m: m.update(area=[-1, -1, 1]), "area needs four numbers"),
    (lambda m: m.update(area=[1, -1, -1, 1]), "x1 > x0"),
    (lambda m: m.pop("sky_scale"), "sky_scale needs three numbers"),
    (lambda m: m.update(map_scale="big"), "map_scale must be a positive number"),
    (lambda m: m.pop("variants"), "variants must hold"),
    (lambda m: m.update(variants=["alpha", "hsv"]), "variants must be an object"),
    (lambda m: m["files"]["color"].pop("dds"), "files must name the color map's png and dds"),
    (lambda m: m["files"]["color"].update(png="../../etc/passwd"), "files must name"),
    (lambda m: m.update(encoding="rgbm"), "encoding must be one of"),
    (lambda m: m.update(path=[[0, 0]]), "path must be null"),
    (lambda m: m.update(version=1), "ground map version 1"),
    (lambda m: m.update(offset_mode="sideways"), "offset_mode must be one of none, normal, side"),
])
def test_a_damaged_manifest_is_one_line_and_exit_2(baked, tmp_path, capsys, change, message):
    _, bake_dir = baked
    out = tmp_path / "map"
    assert main(["groundmap", str(bake_dir), "-o", str(out), "--size", "16", "--quiet"]) == 0
    capsys.readouterr()
    manifest = json.loads((out / "groundmap.json").read_text())
    change(manifest)
    (out / "groundmap.json").write_text(json.dumps(manifest))
    assert main(["render", str(out), "--model", "hemisphere-radiosity", "--size", "8x8", "-o", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert message in err and "groundmap.json" in err and err.count("\n") == 1


# ------------------------------------------------------------------ a scene baked here: one set, checked first

def refuse_to_bake(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("groundmap baked a scene whose map it could have refused before the bake")

    monkeypatch.setattr("patchlight.bake.bake", refuse)


@pytest.mark.parametrize("args, message", [
    (["--area", "100,100,110,110"], "no ground under the area"),
    (["--seed", "-1"], "--seed -1"),
    (["--size", "0"], "--size 0"),
])
def test_a_map_that_cannot_be_made_is_refused_before_the_scene_is_baked(tmp_path, capsys, monkeypatch, args, message):
    refuse_to_bake(monkeypatch)
    out = tmp_path / "bad"
    assert main(["groundmap", "cornell", "-o", str(out), "--texels-per-unit", "8", *args]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == []          # no output, no staging left


def test_the_level_extent_is_named_when_no_ground_lies_under_the_area(tmp_path, capsys, monkeypatch):
    refuse_to_bake(monkeypatch)
    assert main(["groundmap", "cornell", "-o", str(tmp_path / "bad"), "--area", "100,100,110,110"]) == 2
    assert "the level spans x " in capsys.readouterr().err


@pytest.mark.parametrize("broken", ["patchlight.ground.groundmap.make_groundmap",
                                    "patchlight.ground.groundmap._write_variant"])
def test_a_failure_after_the_bake_writes_nothing(tmp_path, capsys, monkeypatch, broken):
    """The bake is part of the one staged set: a map that fails to be made (or written) after
    the bake leaves no bake behind either."""
    def fail(*args, **kwargs):
        raise OSError(28, "No space left on device") if broken.endswith("_write_variant") else PatchlightError("boom")

    monkeypatch.setattr(broken, fail)
    assert main(["groundmap", "cornell", "-o", str(tmp_path / "out"), "--size", "8", "--quiet",
                 "--texels-per-unit", "4"]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_a_failure_while_writing_the_bake_keeps_the_older_set_whole(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    assert main(["groundmap", "cornell", "-o", str(out), "--size", "8", "--quiet", "--texels-per-unit", "4"]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("patchlight.scene.gltf.save_baked_glb", full)
    assert main(["groundmap", "cornell", "-o", str(out), "--size", "16", "--quiet", "--texels-per-unit", "4"]) == 2
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before   # groundmap.json included
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_a_new_map_over_an_older_set_replaces_bake_and_map_together(baked, tmp_path, capsys):
    _, first = baked
    out = tmp_path / "out"
    assert main(["groundmap", "cornell", "-o", str(out), "--size", "16", "--quiet", "--texels-per-unit", "8"]) == 0
    before = json.loads((out / "bake.json").read_text())
    assert main(["groundmap", "cornell", "-o", str(out), "--size", "8", "--quiet", "--texels-per-unit", "4"]) == 0
    after = json.loads((out / "bake.json").read_text())
    assert after["settings"]["texels_per_unit"] == 4 and before["settings"]["texels_per_unit"] == 8
    assert json.loads((out / "groundmap.json").read_text())["size"] == 8
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]


# ------------------------------------------------------------------ offset mode and distance

def render_exr(target, tmp_path, name, *extra) -> np.ndarray:
    out = tmp_path / f"{name}.exr"
    assert main(["render", str(target), "--model", "hemisphere-radiosity", "--size", "24x24", "-o", str(out),
                 *extra]) == 0
    return read_exr(out)


def test_the_offset_mode_is_recorded_by_groundmap_and_chosen_by_render_and_view(baked, tmp_path, capsys):
    _, bake_dir = baked
    out = tmp_path / "map"
    assert main(["groundmap", str(bake_dir), "-o", str(out), "--size", "16", "--quiet",
                 "--offset-mode", "none", "--offset-distance", "2.5"]) == 0
    manifest = json.loads((out / "groundmap.json").read_text())
    assert manifest["offset_mode"] == "none" and manifest["offset"] == 2.5
    stored = load_ground_map(out)
    assert stored.offset_mode == "none" and stored.offset == 2.5
    # render: the map's mode unless --offset-mode names another
    default = render_exr(out, tmp_path, "default")
    assert np.array_equal(default, render_exr(out, tmp_path, "none", "--offset-mode", "none"))
    assert not np.array_equal(default, render_exr(out, tmp_path, "normal", "--offset-mode", "normal"))
    # view builds its settings the same way
    for extra, mode in (([], "none"), (["--offset-mode", "side"], "side")):
        args = build_parser().parse_args(["view", str(out), *extra])
        _, settings = load_target_and_settings(args, args.model)
        assert settings.ground_map.offset_mode == mode and settings.ground_map.offset == 2.5


def test_the_offset_flags_are_unambiguous(baked, tmp_path, capsys):
    _, bake_dir = baked
    assert main(["groundmap", str(bake_dir), "-o", str(tmp_path / "m"), "--offset", "2"]) == 2
    assert "ambiguous option: --offset" in capsys.readouterr().err
    assert main(["groundmap", str(bake_dir), "-o", str(tmp_path / "m"), "--offset-mode", "sideways"]) == 2
    assert "invalid choice: 'sideways'" in capsys.readouterr().err
    assert not (tmp_path / "m").exists()


@pytest.mark.parametrize("command", ["render", "view"])
def test_offset_mode_needs_a_ground_map_directory(baked, tmp_path, capsys, command):
    _, bake_dir = baked
    (bake_dir / "groundmap.json").rename(tmp_path / "kept.json")        # the bake alone
    try:
        extra = ["-o", str(tmp_path / "x.png")] if command == "render" else []
        assert main([command, str(bake_dir), "--model", "hemisphere-radiosity", "--offset-mode", "side", *extra]) == 2
    finally:
        (tmp_path / "kept.json").rename(bake_dir / "groundmap.json")
    err = capsys.readouterr().err
    assert "--offset-mode side" in err and "not a ground map directory" in err and err.count("\n") == 1


# ------------------------------------------------------------------ maps written from Python

def test_a_map_written_from_python_names_the_bake_its_scene_was_read_from(baked, tmp_path, capsys):
    _, bake_dir = baked
    out = tmp_path / "api_g"
    manifest = write_groundmap(make_groundmap(load_solved(bake_dir), GroundMapSettings(size=16)), out, "api")
    assert (out / manifest["bake"]).resolve() == bake_dir.resolve()
    assert main(["render", str(out), "--model", "hemisphere-radiosity", "--size", "8x8",
                 "-o", str(tmp_path / "x.png")]) == 0


def test_a_map_written_from_python_with_its_bake_made_in_memory_is_one_set(tmp_path, capsys):
    from patchlight.bake import bake
    from patchlight.config import BakeSettings
    from patchlight.scene import load_scene
    from patchlight.solved import SolvedScene

    settings = BakeSettings(texels_per_unit=4.0)
    result = bake(load_scene("cornell"), settings)
    out = tmp_path / "api_g"
    ground_map = make_groundmap(SolvedScene(result.scene, result.lightmap, "cornell"), GroundMapSettings(size=8))
    assert write_groundmap(ground_map, out, "cornell", bake=(result, settings))["bake"] == "."
    assert {"bake.json", "scene.glb", "lightmap.exr", "groundmap.json"} <= {p.name for p in out.iterdir()}
    assert main(["render", str(out), "--model", "hemisphere-radiosity", "--size", "8x8",
                 "-o", str(tmp_path / "x.png")]) == 0


def test_a_map_written_from_python_without_a_bake_says_what_to_do(tmp_path, capsys):
    from ground_scenes import ground, solved
    from patchlight.scene.builtin import SceneBuilder

    b = SceneBuilder()
    ground(b)
    out = tmp_path / "api_g"
    manifest = write_groundmap(make_groundmap(solved(b), GroundMapSettings(size=8)), out, "test")
    assert manifest["bake"] is None and any("no bake recorded" in w for w in manifest["warnings"])
    assert load_ground_map(out).texture.shape == (8, 8, 4)         # the map itself is whole
    for command in (["render", str(out), "--model", "hemisphere-radiosity", "-o", str(tmp_path / "x.png")],
                    ["view", str(out)]):
        assert main(command) == 2
        err = capsys.readouterr().err
        assert "names no bake" in err and "bake_dir=" in err and "patchlight groundmap" in err
        assert err.count("\n") == 1
