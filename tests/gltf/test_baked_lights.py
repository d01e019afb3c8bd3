"""Lights whose light is in the lightmap are marked in scene.glb (extras.baked) and kept dynamic
on request: --keep-lights, or "baked": false in the input's light extras, leaves them out of
the bake."""
from __future__ import annotations

import json
from dataclasses import replace

from patchlight.cli.main import main
from patchlight.scene import load_scene
from patchlight.scene.gltf import load_gltf, save_baked_glb


def lights_json(path) -> list[dict]:
    data = path.read_bytes()
    doc = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])
    return doc["extensions"]["KHR_lights_punctual"]["lights"]


def test_the_mark_round_trips_through_scene_glb(tmp_path):
    scene = load_scene("room")
    scene.lights = [replace(scene.lights[0], baked=False)]
    path = save_baked_glb(scene, tmp_path / "room.glb")
    assert lights_json(path)[0]["extras"]["baked"] is False
    back = load_gltf(path)
    assert [light.baked for light in back.lights] == [False] and back.lights[0].source == 0
    again = save_baked_glb(back, tmp_path / "again.glb")  # the writer that keeps the file marks it too
    assert lights_json(again)[0]["extras"]["baked"] is False


def test_kept_lights_are_left_out_of_the_bake(tmp_path, capsys):
    quick = ["--resolution", "64", "--rays", "16", "--passes", "1", "--quiet"]
    assert main(["bake", "room", "-o", str(tmp_path / "all"), *quick]) == 0
    assert main(["bake", "room", "-o", str(tmp_path / "kept"), "--keep-lights", "sun", *quick]) == 0
    assert lights_json(tmp_path / "all" / "scene.glb")[0]["extras"]["baked"] is True
    assert lights_json(tmp_path / "kept" / "scene.glb")[0]["extras"]["baked"] is False
    baked = json.loads((tmp_path / "all" / "bake.json").read_text())
    kept = json.loads((tmp_path / "kept" / "bake.json").read_text())
    assert baked["rays_direct"] > 0 and kept["rays_direct"] == 0  # no shadow ray for a light not baked
    status = main(["bake", "room", "-o", str(tmp_path / "x"), "--keep-lights", "moon", *quick])
    assert status == 2 and "no light named moon (lights: sun)" in capsys.readouterr().err
    status = main(["bake", "room", "-o", str(tmp_path / "dark"), "--keep-lights", "--sky", "0,0,0", *quick])
    assert status == 2 and "lights kept dynamic are not baked" in capsys.readouterr().err
    assert not (tmp_path / "x").exists() and not (tmp_path / "dark").exists()


def test_a_bad_mark_in_the_input_is_one_clear_error(tmp_path, capsys):
    path = save_baked_glb(load_scene("room"), tmp_path / "room.glb")
    data = bytearray(path.read_bytes())
    length = int.from_bytes(data[12:16], "little")
    text = data[20:20 + length].decode().replace('"baked":true', '"baked":"ye"')
    assert len(text) == length
    data[20:20 + length] = text.encode()
    path.write_bytes(bytes(data))
    status = main(["bake", str(path), "-o", str(tmp_path / "out"), "--quiet"])
    assert status == 2 and "extras 'baked' must be true or false, got 'ye'" in capsys.readouterr().err
