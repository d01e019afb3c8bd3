"""Every glTF the project writes passes the Khronos glTF validator (npm gltf-validator) with
zero errors: bakes of the built-in scenes (flattened writer), of a glTF file (the writer that
keeps the file) and of a baked scene.glb again, and vertexbake's output from either."""
from __future__ import annotations

import json

import numpy as np
import pytest

from patchlight.cli.main import main
from patchlight.scene import load_scene
from patchlight.scene.gltf import load_gltf, save_baked_glb

from validator import problems, validate, validator_missing

QUICK = ["--rays", "32", "--passes", "2", "--quiet"]
RESOLUTION = {"track": "256"}  # thousands of small charts; the others fit 64 x 64


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> dict:
    """name -> a .glb the project wrote."""
    reason = validator_missing()
    if reason:
        pytest.skip(reason)
    root = tmp_path_factory.mktemp("written")
    source = save_baked_glb(load_scene("cornell"), root / "cornell_input.glb")  # a glTF file, not built in
    files = {}
    for name, scene in (("room", "room"), ("cornell", "cornell"), ("track", "track"), ("gltf", source)):
        resolution = ["--resolution", RESOLUTION.get(name, "64")]
        assert main(["bake", str(scene), "-o", str(root / name), *resolution, *QUICK]) == 0
        files[f"bake {name}"] = root / name / "scene.glb"
    assert main(["bake", str(files["bake room"]), "-o", str(root / "rebaked"), "--resolution", "64", *QUICK]) == 0
    files["bake of a baked scene.glb"] = root / "rebaked" / "scene.glb"
    for name, target in (("of a bake", root / "room"), ("of a built-in", "cornell"), ("of a glTF", source)):
        out = root / f"vertex {name}.glb"
        assert main(["vertexbake", str(target), "-o", str(out), "--quiet"]) == 0
        files[f"vertexbake {name}"] = out
    files["input written from a built-in"] = source
    return files


def document(path) -> dict:
    data = path.read_bytes()
    return json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])


def test_every_file_the_project_writes_has_zero_validator_errors(written):
    reports = validate(*written.values())
    for (name, path), report in zip(written.items(), reports):
        assert report["errors"] == 0, (name, problems(report))


def test_every_lightmapped_material_references_the_lightmap(written):
    for name in (n for n in written if n.startswith("bake")):
        doc = document(written[name])
        info = doc["extras"]["patchlight"]["lightmap"]
        lit = {p["material"] for mesh in doc["meshes"] for p in mesh["primitives"] if "TEXCOORD_1" in p["attributes"]}
        assert lit, name
        for material in lit:
            assert doc["materials"][material]["extensions"]["MOZ_lightmap"] == {
                "index": info["texture"], "texCoord": 1, "intensity": info["intensity"]}, name
        assert {"MOZ_lightmap", "MOZ_texture_rgbe"} <= set(doc["extensionsUsed"]), name
        assert sum(t.get("name") == "patchlight_lightmap" for t in doc["textures"]) == 1, name


def test_vertexbake_colours_lie_in_0_1_with_their_scale_recorded(written):
    for name in (n for n in written if n.startswith("vertexbake")):
        doc = document(written[name])
        scale = doc["extras"]["patchlight"]["vertexLight"]["colorScale"]
        colors = load_gltf(written[name]).colors
        assert scale >= 1.0 and colors.min() >= 0.0 and colors.max() <= 1.0, name
        assert "lightmap" not in doc["extras"]["patchlight"], name  # the light is in COLOR_0 only
        assert all("MOZ_lightmap" not in m.get("extensions", {}) for m in doc["materials"]), name
    assert np.isclose(load_gltf(written["vertexbake of a bake"]).colors[:, :3].max(), 1.0)  # the brightest is 1
