"""Finite or refused: light, emission, sky and option values are checked where they enter
(one line, exit 2, nothing written); every file written is strict JSON and finite."""
import base64
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from patchlight.bake import bake
from patchlight.cli.main import main
from patchlight.config import BakeSettings
from patchlight.errors import PatchlightError
from patchlight.imaging.io import json_text, write_exr
from patchlight.scene import Light, SceneBuilder, Sky
from patchlight.volumes.probes import VolumeSettings


def lit_floor_gltf(path, light_text='"intensity": 3.0', emissive="[0, 0, 0]"):
    """A .gltf (JSON written by hand, so it can hold NaN, Infinity and 1e400) of a 2 x 2 m
    floor lit by a sun whose intensity field is `light_text`."""
    positions = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)
    indices = np.array([0, 2, 1, 0, 3, 2], np.uint32)
    blob = positions.tobytes() + indices.tobytes()
    text = f'''{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [{{"type": "directional", {light_text}}}]}}}},
  "nodes": [{{"mesh": 0}}, {{"rotation": [-0.7071068, 0, 0, 0.7071068],
             "extensions": {{"KHR_lights_punctual": {{"light": 0}}}}}}],
  "materials": [{{"emissiveFactor": {emissive}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "buffers": [{{"byteLength": {len(blob)}, "uri": "data:application/octet-stream;base64,{base64.b64encode(blob).decode()}"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 24}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                  "min": [-1, 0, -1], "max": [1, 0, 1]}},
                {{"bufferView": 1, "componentType": 5125, "count": 6, "type": "SCALAR"}}]}}'''
    path.write_text(text)
    return path


def run(capsys, *argv):
    status = main([str(a) for a in argv])
    return status, capsys.readouterr().err


@pytest.mark.parametrize("light_text, emissive", [
    ('"intensity": NaN', "[0, 0, 0]"), ('"intensity": Infinity', "[0, 0, 0]"), ('"intensity": 1e308', "[0, 0, 0]"),
    ('"intensity": 1e400', "[0, 0, 0]"), ('"intensity": 3, "color": [1, NaN, 1]', "[0, 0, 0]"),
    ('"intensity": 3', "[1e300, 0, 0]"), ('"intensity": 3', "[0, Infinity, 0]"), ('"intensity": 3', "[-1, 0, 0]")])
def test_a_light_or_emission_not_finite_or_out_of_range_is_one_line(tmp_path, capsys, light_text, emissive):
    scene = lit_floor_gltf(tmp_path / "floor.gltf", light_text, emissive)
    status, err = run(capsys, "bake", scene, "-o", tmp_path / "out", "--resolution", "16")
    assert status == 2 and len(err.strip().splitlines()) == 1, err
    assert ("light" in err or "emissi" in err) and ("0..1e+12" in err or "finite" in err or "[0, inf]" in err)
    assert not (tmp_path / "out").exists()


def test_the_command_line_says_one_line_without_numpys_warnings(tmp_path):
    """Emission 1e300 overflows float32 as it is read (a NumPy RuntimeWarning): the user still
    sees only patchlight's one line."""
    scene = lit_floor_gltf(tmp_path / "floor.gltf", '"intensity": 3', "[1e300, 0, 0]")
    run = subprocess.run([str(Path(sys.executable).with_name("patchlight")), "bake", str(scene), "-o",
                          str(tmp_path / "out")], capture_output=True, text=True, timeout=300)
    assert run.returncode == 2 and len(run.stderr.strip().splitlines()) == 1, run.stderr


def test_the_same_floor_with_a_sane_sun_bakes(tmp_path, capsys):
    status, err = run(capsys, "bake", lit_floor_gltf(tmp_path / "floor.gltf"), "-o", tmp_path / "out",
                      "--resolution", "16", "--quiet")
    assert status == 0, err


@pytest.mark.parametrize("argv", [
    ["bake", "room", "--max-memory", "nan"], ["bake", "room", "--max-memory", "inf"],
    ["bake", "room", "--max-memory", "1e308"], ["bake", "room", "--texels-per-unit", "1e308"],
    ["bake", "room", "--texels-per-unit", "1e-300"], ["bake", "room", "--tolerance", "nan"],
    ["bake", "room", "--accuracy", "inf"], ["bake", "room", "--sun-angle", "nan"],
    ["bake", "room", "--sky", "1e308,1,1"], ["bake", "room", "--sky", "nan,1,1"],
    ["volume", "room", "--sun-angle", "nan"], ["volume", "room", "--sky", "1e308,1,1"],
    ["volume", "room", "--spacing", "nan"], ["groundmap", "track", "--noise", "nan"],
    ["render", "room", "--size", "16384x16384"], ["render", "room", "--reflectivity", "nan"]])
def test_options_out_of_range_are_one_line(tmp_path, capsys, argv):
    status, err = run(capsys, *argv, "-o", tmp_path / "out")
    assert status == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert not (tmp_path / "out").exists()


def test_api_values_are_checked_where_they_enter():
    b = SceneBuilder()
    b.quad([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], b.material("floor", (0.5, 0.5, 0.5)), (0, 1, 0))
    sun = Light("directional", np.ones(3, np.float32), float("nan"), direction=np.array([0, -1, 0], np.float32))
    with pytest.raises(PatchlightError, match="light"):
        bake(b.scene("floor", lights=[sun]), BakeSettings(resolution=16))
    with pytest.raises(PatchlightError, match="sky radiance"):
        bake(b.scene("floor", sky=Sky.uniform((1e30, 1, 1))), BakeSettings(resolution=16))
    with pytest.raises(PatchlightError, match="^sun_angle: nan must be"):
        VolumeSettings(sun_angle=float("nan"))
    for name, bad in (("uv0", -np.inf), ("normals", np.nan)):
        scene = b.scene("floor", sky=Sky.uniform((1, 1, 1)))
        getattr(scene, name)[0, 0] = bad
        with pytest.raises(PatchlightError, match="1 vertex .* are NaN or infinite"):
            bake(scene, BakeSettings(resolution=16))


def test_arrays_written_are_finite_and_json_is_strict(tmp_path):
    image = np.ones((2, 2, 3), np.float32)
    image[1, 1, 2] = np.nan
    with pytest.raises(PatchlightError, match="1 values to write are NaN"):
        write_exr(tmp_path / "x.exr", image)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(PatchlightError, match="NaN or infinite"):
        json_text({"a": [1.0, float("inf")]}, "x.json")


def test_a_bake_of_few_passes_writes_strict_json(tmp_path, capsys):
    """Two passes leave the change still to come unknown: null, never Infinity."""
    status, err = run(capsys, "bake", "cornell", "-o", tmp_path / "out", "--resolution", "32", "--passes", "2",
                      "--quiet")
    assert status == 0, err

    def refuse(token):
        raise AssertionError(f"{token} in bake.json")

    summary = json.loads((tmp_path / "out" / "bake.json").read_text(), parse_constant=refuse)
    assert summary["change_to_come"] is None and summary["converged"] is False
