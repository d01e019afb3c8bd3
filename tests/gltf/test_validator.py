"""Every glTF the project writes passes the Khronos glTF validator (npm gltf-validator) with
zero errors: bakes of the built-in scenes (flattened writer), of a glTF file (the writer that
keeps the file) and of a baked scene.glb again, directional bakes (PATCHLIGHT_lightmap_directional
and its EXR textures) of either, and vertexbake's output from either. In a
bake, the lightmap texture and every TEXCOORD_1 are used in the validator's eyes (through the
occlusionTexture stand-in at strength 0), and a material's own occlusion map is kept."""
from __future__ import annotations

import json

import numpy as np
import pytest

from patchlight.cli.main import main
from patchlight.imaging.io import encode_png
from patchlight.scene import load_scene
from patchlight.scene.gltf import load_gltf, save_baked_glb
from patchlight.scene.gltf.container import pack_glb, split_glb

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
    occluded = with_own_occlusion(source, root / "occluded_input.glb")
    files = {}
    for name, scene in (("room", "room"), ("cornell", "cornell"), ("track", "track"), ("gltf", source),
                        ("gltf with an occlusion map", occluded)):
        resolution = ["--resolution", RESOLUTION.get(name, "64")]
        assert main(["bake", str(scene), "-o", str(root / name), *resolution, *QUICK]) == 0
        files[f"bake {name}"] = root / name / "scene.glb"
    assert main(["bake", str(files["bake room"]), "-o", str(root / "rebaked"), "--resolution", "64", *QUICK]) == 0
    files["bake of a baked scene.glb"] = root / "rebaked" / "scene.glb"
    for name, scene, mode in (("room directional sh", "room", "sh"), ("gltf directional dominant", source, "dominant"),
                              ("of a directional bake, directional sh", root / "room directional sh" / "scene.glb", "sh")):
        assert main(["bake", str(scene), "-o", str(root / name), "--resolution", "64", "--directional", mode, *QUICK]) == 0
        files[f"bake {name}"] = root / name / "scene.glb"
    directional = root / "room directional sh" / "scene.glb"
    for name, options in (("dominant", ["--directional", "dominant"]), ("none", [])):
        out = root / f"directional sh, again {name}"
        assert main(["bake", str(directional), "-o", str(out), "--resolution", "64", *options, *QUICK]) == 0
        files[f"bake of a directional bake, {name}"] = out / "scene.glb"
    for name, target in (("of a bake", root / "room"), ("of a built-in", "cornell"), ("of a glTF", source),
                         ("of a directional bake", root / "room directional sh")):
        out = root / f"vertex {name}.glb"
        assert main(["vertexbake", str(target), "-o", str(out), "--quiet"]) == 0
        files[f"vertexbake {name}"] = out
    files["input written from a built-in"] = source
    return files


def document(path) -> dict:
    data = path.read_bytes()
    return json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])


OWN_OCCLUSION = {"index": None, "texCoord": 0, "strength": 0.7}  # index: the texture added


def with_own_occlusion(source, out):
    """A copy of the .glb `source` whose first material has an occlusion map of its own (a grey PNG)."""
    text, blob = split_glb(source.read_bytes(), source)
    doc, blob = json.loads(text), bytearray(blob)
    png = encode_png(np.full((4, 4, 3), 200, np.uint8))
    blob += b"\0" * (-len(blob) % 4)
    doc["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(png)})
    blob += png + b"\0" * (-len(png) % 4)
    doc["buffers"][0]["byteLength"] = len(blob)
    doc.setdefault("images", []).append({"bufferView": len(doc["bufferViews"]) - 1, "mimeType": "image/png"})
    doc.setdefault("textures", []).append({"source": len(doc["images"]) - 1, "name": "own occlusion"})
    doc["materials"][0]["occlusionTexture"] = {**OWN_OCCLUSION, "index": len(doc["textures"]) - 1}
    out.write_bytes(pack_glb(json.dumps(doc).encode(), bytes(blob)))
    return out


def test_every_file_the_project_writes_has_zero_validator_errors(written):
    reports = validate(*written.values())
    for (name, path), report in zip(written.items(), reports):
        assert report["errors"] == 0, (name, problems(report))


def test_no_bake_leaves_the_lightmap_or_its_uvs_unused(written):
    """The validator's UNUSED_OBJECT (it does not know MOZ_lightmap) names neither the lightmap
    texture nor any TEXCOORD_1: the occlusionTexture stand-in uses both. The one exception is
    a material with an occlusion map of its own on TEXCOORD_0, which is kept untouched: its
    primitives' TEXCOORD_1 is read by MOZ_lightmap alone."""
    bakes = [name for name in written if name.startswith("bake")]
    for name, report in zip(bakes, validate(*(written[n] for n in bakes))):
        doc = document(written[name])
        texture = doc["extras"]["patchlight"]["lightmap"]["texture"]
        own = {f"/meshes/{m}/primitives/{k}/attributes/TEXCOORD_1" for m, mesh in enumerate(doc["meshes"])
               for k, p in enumerate(mesh["primitives"])
               if doc["materials"][p["material"]]["occlusionTexture"]["index"] != texture}
        unused = [m["pointer"] for m in report["messages"] if m["code"] == "UNUSED_OBJECT"]
        assert f"/textures/{texture}" not in unused, (name, unused)
        assert {p for p in unused if p.endswith("/TEXCOORD_1")} == own, (name, unused)
        assert bool(own) == (name == "bake gltf with an occlusion map"), name


def test_every_lightmapped_material_references_the_lightmap(written):
    for name in (n for n in written if n.startswith("bake")):
        doc = document(written[name])
        info = doc["extras"]["patchlight"]["lightmap"]
        lit = {p["material"] for mesh in doc["meshes"] for p in mesh["primitives"] if "TEXCOORD_1" in p["attributes"]}
        assert lit, name
        for material in lit:
            assert doc["materials"][material]["extensions"]["MOZ_lightmap"] == {
                "index": info["texture"], "texCoord": 1, "intensity": info["intensity"]}, name
            if not (name == "bake gltf with an occlusion map" and material == 0):
                assert doc["materials"][material]["occlusionTexture"] == {
                    "index": info["texture"], "texCoord": 1, "strength": 0.0}, name
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


def test_a_material_keeps_its_own_occlusion_map(written):
    doc = document(written["bake gltf with an occlusion map"])
    own = doc["materials"][0]["occlusionTexture"]
    assert {**own, "index": None} == OWN_OCCLUSION
    assert doc["textures"][own["index"]]["name"] == "own occlusion"
    assert doc["extras"]["patchlight"]["lightmap"]["texture"] != own["index"]


def test_vertexbake_of_a_bake_drops_the_occlusion_stand_in(written):
    doc = document(written["vertexbake of a bake"])
    assert all("occlusionTexture" not in m for m in doc["materials"])


def test_directional_bakes_reference_their_maps_from_every_lit_material(written):
    for name, layers in (("bake room directional sh", ["L0", "L1x", "L1y", "L1z"]),
                         ("bake gltf directional dominant", [""]),
                         ("bake of a directional bake, directional sh", ["L0", "L1x", "L1y", "L1z"]),
                         ("bake of a directional bake, dominant", [""])):
        doc = document(written[name])
        assert {"PATCHLIGHT_lightmap_directional", "PATCHLIGHT_texture_exr"} <= set(doc["extensionsUsed"]), name
        assert "PATCHLIGHT_lightmap_directional" not in doc.get("extensionsRequired", []), name
        lit = {p["material"] for mesh in doc["meshes"] for p in mesh["primitives"] if "TEXCOORD_1" in p["attributes"]}
        for material in lit:
            reference = doc["materials"][material]["extensions"]["PATCHLIGHT_lightmap_directional"]
            assert reference["mode"] == ("sh" if len(layers) == 4 else "dominant"), name
            textures = [doc["textures"][m["index"]] for m in reference["maps"]]
            assert [t["name"] for t in textures] == [f"patchlight_directional_{x}".rstrip("_") for x in layers], name
            images = [doc["images"][t["extensions"]["PATCHLIGHT_texture_exr"]["source"]] for t in textures]
            assert all(i["mimeType"] == "image/x-exr" and "source" not in t for i, t in zip(images, textures)), name
    rebaked = document(written["bake of a directional bake, directional sh"])  # the earlier maps' textures reused
    assert sum(t.get("name", "").startswith("patchlight_directional") for t in rebaked["textures"]) == 4



def test_a_re_bake_leaves_no_earlier_maps_behind(written):
    """Re-baking a directional bake (sh) with dominant, without --directional, or vertexbake:
    the maps nothing uses any more are gone, textures and images (their bytes with them), and
    the extensions and samplers only they used; the validator reports none of the bake's maps
    unused."""
    cases = {"bake of a directional bake, dominant": ({"patchlight_directional"}, {"PATCHLIGHT_texture_exr"}),
             "bake of a directional bake, none": (set(), set()),
             "vertexbake of a directional bake": (set(), set()), "vertexbake of a bake": (set(), set())}
    bake_names = {"patchlight_lightmap", "patchlight_lightmap_hdr"}
    reports = validate(*(written[name] for name in cases))
    for (name, (directional, extensions)), report in zip(cases.items(), reports):
        doc = document(written[name])
        lightmap = set() if name.startswith("vertexbake") else bake_names
        textures = [t.get("name") for t in doc.get("textures", [])]
        assert sorted(textures) == sorted((lightmap - {"patchlight_lightmap_hdr"}) | directional), (name, textures)
        images = [i.get("name") for i in doc.get("images", [])]
        assert sorted(images) == sorted(lightmap | directional), (name, images)
        assert {"PATCHLIGHT_lightmap_directional", "PATCHLIGHT_texture_exr"} & set(doc.get("extensionsUsed", [])) \
            == ({"PATCHLIGHT_lightmap_directional"} | extensions if directional else set()), name
        # unused in the validator's eyes: only what the bake's own extensions name (it knows them not)
        known = {f"/textures/{m['index']}" for material in doc["materials"]
                 for m in material.get("extensions", {}).get("PATCHLIGHT_lightmap_directional", {}).get("maps", [])}
        known |= {f"/images/{e['source']}" for t in doc.get("textures", []) for key, e in t.get("extensions", {}).items()
                  if key in ("PATCHLIGHT_texture_exr", "MOZ_texture_rgbe")}
        unused = {m["pointer"] for m in report["messages"] if m["code"] == "UNUSED_OBJECT"
                  and m["pointer"].startswith(("/textures/", "/images/", "/samplers/"))}
        assert report["errors"] == 0 and unused <= known, (name, unused - known)
