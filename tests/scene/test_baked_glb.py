"""scene.glb of a glTF input is that input plus TEXCOORD_1 and the lightmap: hierarchy, names,
transforms, materials, samplers, textures, image bytes, cameras, lights, skins, animations and
extras kept; vertices split in local space; one mesh copy per further instance; the sky and the
three.js-facing lightmap description in the extras."""
import json
import math
import struct
import warnings

import numpy as np
import pygltflib as gl
import pytest

from patchlight.atlas import _kernels as atlas_kernels
from patchlight.bake import bake
from patchlight.bakedir import write_bake
from patchlight.cli.main import main
from patchlight.config import BakeSettings
from patchlight.imaging.io import decode_image, encode_png, read_exr, read_hdr, write_hdr
from patchlight.scene import load_scene
from patchlight.scene.gltf import load_gltf, save_baked_glb

from gltf_builder import FLOAT, UBYTE, UINT, USHORT, Builder

RESOLUTION = 64
SKY = [0.4, 0.5, 0.7]
CORNERS = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)], np.float32)
CUBE = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],   # -x, +x, -y
                 [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]],  # +y, -z, +z
                np.uint32)
MORPH = np.float32(0.25)  # the morph target moves each corner by MORPH x its position


def png(rgba) -> bytes:
    return encode_png(np.array(rgba, np.uint8).reshape(2, 2, 4))


BASE_PNG = png([[200, 40, 40, 255], [40, 200, 40, 128], [40, 40, 200, 255], [250, 250, 250, 64]])
METAL_ROUGH_PNG = png([[0, 51, 255, 255]] * 4)


class Doc(Builder):
    """The input document: a parent node turned and moved, its child drawing the box, a second
    root drawing the same box (with a skin), a floor, a sun, a camera, an animation."""

    def __init__(self):
        super().__init__()
        self.doc.asset.generator = "hand"

    def build(self):
        d = self.doc
        d.samplers = [gl.Sampler(magFilter=9728, minFilter=9986, wrapS=33648, wrapT=10497, extras={"label": "nearest mirror"})]
        d.images = [gl.Image(bufferView=self.view(BASE_PNG), mimeType="image/png", name="base"),
                    gl.Image(bufferView=self.view(METAL_ROUGH_PNG), mimeType="image/png", name="metal-rough")]
        d.textures = [gl.Texture(sampler=0, source=0, name="base"), gl.Texture(sampler=0, source=1, name="mr")]
        metal = gl.Material(
            name="Metal", alphaMode="BLEND", doubleSided=True, extras={"note": "keep me"},
            pbrMetallicRoughness=gl.PbrMetallicRoughness(
                baseColorFactor=[0.9, 0.8, 0.7, 0.5], metallicFactor=1.0, roughnessFactor=0.2,
                baseColorTexture=gl.TextureInfo(index=0), metallicRoughnessTexture=gl.TextureInfo(index=1)),
            occlusionTexture=gl.OcclusionTextureInfo(index=1, strength=0.5),
            extensions={"KHR_materials_ior": {"ior": 1.7}})
        ground = gl.Material(name="Ground", pbrMetallicRoughness=gl.PbrMetallicRoughness(
            baseColorFactor=[0.6, 0.6, 0.6, 1.0], metallicFactor=0.0, roughnessFactor=0.9))
        d.materials = [metal, ground]
        d.extensionsUsed = ["KHR_materials_ior", "KHR_lights_punctual"]

        p = CORNERS
        box = gl.Primitive(
            attributes=gl.Attributes(
                POSITION=self.accessor(p, bounds=True),
                NORMAL=self.accessor(p / np.linalg.norm(p, axis=1, keepdims=True)),
                TEXCOORD_0=self.accessor(p[:, [0, 2]] + np.float32(0.5)),
                TANGENT=self.accessor(np.concatenate([np.tile([1, 0, 0], (8, 1)), np.sign(p[:, :1])], axis=1)),
                COLOR_0=self.accessor(np.round((p + np.float32(0.5)) * 65535), component=USHORT, normalized=True, stride=8),
                JOINTS_0=self.accessor(np.zeros((8, 4)), component=UBYTE),
                WEIGHTS_0=self.accessor(np.tile([1, 0, 0, 0], (8, 1)))),
            indices=self.accessor(CUBE.ravel(), component=UINT), material=0,
            targets=[{"POSITION": self.accessor(p * MORPH, bounds=True)}])
        floor = np.array([[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]], np.float32)
        floor_primitive = gl.Primitive(
            attributes=gl.Attributes(POSITION=self.accessor(floor, bounds=True), NORMAL=self.accessor(np.tile([0, 1, 0], (4, 1)))),
            indices=self.accessor([0, 2, 1, 0, 3, 2], component=UINT), material=1)
        d.meshes = [gl.Mesh(name="Box", primitives=[box], weights=[0.0], extras={"mesh": "extra"}),
                    gl.Mesh(name="Floor", primitives=[floor_primitive])]
        turn = [0.0, math.sin(math.radians(15)), 0.0, math.cos(math.radians(15))]
        d.nodes = [
            gl.Node(name="Parent", translation=[-1.2, 0.8, 0.3], rotation=turn, children=[1, 2], extras={"tag": "parent"}),
            gl.Node(name="Child box", mesh=0, translation=[0.2, 0.1, 0.0], scale=[0.8, 0.8, 0.8], extras={"tag": "child"}),
            gl.Node(name="Bone", translation=[0.0, 0.5, 0.0]),
            gl.Node(name="Second box", mesh=0, skin=0, translation=[1.4, 0.6, -0.2], extras={"tag": "second"}),
            gl.Node(name="Floor", mesh=1),
            gl.Node(name="Sun", rotation=[-0.5, 0.1, 0.05, 0.86], extensions={"KHR_lights_punctual": {"light": 0}}),
            gl.Node(name="Camera", camera=0, translation=[0, 2, 6]),
        ]
        d.skins = [gl.Skin(name="rig", joints=[2], inverseBindMatrices=self.accessor(
            np.eye(4, dtype=np.float32).ravel()[None].repeat(1, axis=0), kind="MAT4"))]
        d.cameras = [gl.Camera(name="view", type="perspective", perspective=gl.Perspective(yfov=0.9, znear=0.1))]
        d.extensions = {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 683 * 3.0,
                                                            "name": "sun", "color": [1, 0.95, 0.9]}]}}
        times = self.accessor(np.array([0.0, 1.0]), bounds=True)
        moves = self.accessor(np.array([[-1.2, 0.8, 0.3], [-1.2, 1.3, 0.3]]))
        d.animations = [gl.Animation(name="bob", samplers=[gl.AnimationSampler(input=times, output=moves)],
                                     channels=[gl.AnimationChannel(sampler=0, target=gl.AnimationChannelTarget(
                                         node=0, path="translation"))])]
        d.scenes = [gl.Scene(name="Level", nodes=[0, 3, 4, 5, 6], extras={"patchlight": {"sky": {"uniform": SKY}},
                                                                           "level": 7})]
        d.scene = 0
        d.extras = {"author": "someone"}
        return self


    def gltf(self, path):
        """A .gltf: buffer in in.bin beside it; the base-colour image moved to base.png beside it."""
        d = self.doc
        (path.parent / "base.png").write_bytes(BASE_PNG)
        d.images[0] = gl.Image(uri="base.png", name="base")
        (path.parent / "in.bin").write_bytes(bytes(self.blob))
        d.buffers = [gl.Buffer(uri="in.bin", byteLength=len(self.blob))]
        path.write_text(d.gltf_to_json())
        return path


# ----------------------------------------------------------------------------- reading files back

def read_glb(path) -> tuple[dict, bytes]:
    data = path.read_bytes()
    assert data[:4] == b"glTF" and struct.unpack_from("<I", data, 8)[0] == len(data)
    length = struct.unpack_from("<I", data, 12)[0]
    assert length % 4 == 0
    doc = json.loads(data[20:20 + length])
    rest = data[20 + length:]
    blob = rest[8:8 + struct.unpack_from("<I", rest, 0)[0]] if rest else b""
    return doc, blob


def read_gltf(path) -> tuple[dict, dict]:
    """A .glb or .gltf: its JSON and {buffer index: bytes}."""
    if path.suffix == ".glb":
        doc, blob = read_glb(path)
        return doc, {0: blob}
    doc = json.loads(path.read_text())
    return doc, {i: (path.parent / b["uri"]).read_bytes() for i, b in enumerate(doc["buffers"])}


def view_bytes(doc, buffers, index) -> bytes:
    view = doc["bufferViews"][index]
    start = view.get("byteOffset", 0)
    return buffers[view["buffer"]][start:start + view["byteLength"]]


def accessor_values(doc, buffers, index) -> np.ndarray:
    accessor = doc["accessors"][index]
    assert "sparse" not in accessor
    dtype = np.dtype({FLOAT: "<f4", UBYTE: "<u1", USHORT: "<u2", UINT: "<u4"}[accessor["componentType"]])
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[accessor["type"]]
    data = view_bytes(doc, buffers, accessor["bufferView"])
    stride = doc["bufferViews"][accessor["bufferView"]].get("byteStride") or width * dtype.itemsize
    if accessor["type"] != "SCALAR" and accessor["type"] != "MAT4":
        assert stride % 4 == 0  # vertex attributes aligned to 4 bytes
    return np.ndarray((accessor["count"], width), dtype, data, accessor.get("byteOffset", 0),
                      (stride, dtype.itemsize)).copy()


def image_bytes(doc, buffers, folder, index) -> bytes:
    image = doc["images"][index]
    if "uri" in image:
        return (folder / image["uri"]).read_bytes()
    return view_bytes(doc, buffers, image["bufferView"])


def world_triangles(scene) -> np.ndarray:
    return scene.positions[scene.indices].astype(np.float64)


def settings() -> BakeSettings:
    return BakeSettings(resolution=RESOLUTION, rays=32, passes=2, sun_samples=1)


# ----------------------------------------------------------------------------- the checks

def check_intact(source, out, source_folder):
    """Everything of the input document is in the output, bytes of images included."""
    before, before_buffers = read_gltf(source)
    after, blob = read_glb(out)
    buffers = {0: blob}
    assert after["asset"] == before["asset"]
    assert after["extensionsUsed"] == before["extensionsUsed"] + ["MOZ_lightmap", "MOZ_texture_rgbe"]
    assert without_marks(after)["materials"] == before["materials"]
    assert after["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] == 1.0
    assert after["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] == 0.2
    assert after["materials"][0]["alphaMode"] == "BLEND"
    assert after["samplers"][:len(before["samplers"])] == before["samplers"]
    assert after["textures"][:len(before["textures"])] == before["textures"]
    for number, image in enumerate(before["images"]):
        assert after["images"][number]["name"] == image["name"]
        assert after["images"][number]["mimeType"] == "image/png"
        assert image_bytes(after, buffers, None, number) == image_bytes(before, before_buffers, source_folder, number)
    for key in ("cameras", "extensions", "scene"):
        assert without_marks(after)[key] == before[key], key
    assert all(light["extras"]["baked"] for light in after["extensions"]["KHR_lights_punctual"]["lights"])
    assert after["extras"]["author"] == "someone"
    # the hierarchy, names, transforms and extras of every node; the box nodes on their own mesh
    assert len(after["nodes"]) == len(before["nodes"])
    for a, b in zip(after["nodes"], before["nodes"]):
        assert {k: v for k, v in a.items() if k != "mesh"} == {k: v for k, v in b.items() if k != "mesh"}
    child, second = after["nodes"][1]["mesh"], after["nodes"][3]["mesh"]
    assert child == 0 and second == len(before["meshes"]) and after["nodes"][4]["mesh"] == 1
    assert [m["name"] for m in after["meshes"]] == ["Box", "Floor", "Box (lightmap 2)"]
    assert after["meshes"][2]["weights"] == [0.0] and after["meshes"][2]["extras"] == {"mesh": "extra"}
    # the scene keeps its name and extras (the sky is the bake's)
    assert after["scenes"][0]["name"] == "Level" and after["scenes"][0]["extras"]["level"] == 7
    assert after["scenes"][0]["nodes"] == before["scenes"][0]["nodes"]
    # skin and animation: their accessors renumbered, their values unchanged
    assert after["skins"][0]["joints"] == [2] and after["skins"][0]["name"] == "rig"
    np.testing.assert_array_equal(accessor_values(after, buffers, after["skins"][0]["inverseBindMatrices"]),
                                  accessor_values(before, before_buffers, before["skins"][0]["inverseBindMatrices"]))
    assert after["animations"][0]["channels"] == before["animations"][0]["channels"]
    for key in ("input", "output"):
        np.testing.assert_array_equal(accessor_values(after, buffers, after["animations"][0]["samplers"][0][key]),
                                      accessor_values(before, before_buffers, before["animations"][0]["samplers"][0][key]))
    return after, buffers


def without_marks(doc: dict) -> dict:
    """A copy of doc without what the bake adds to materials (MOZ_lightmap, and the lightmap as
    occlusionTexture at strength 0 where a material has no occlusion map of its own) and lights
    (extras.baked)."""
    doc = json.loads(json.dumps(doc))
    for material in doc.get("materials", []):
        lightmap = material.get("extensions", {}).pop("MOZ_lightmap", None)
        if lightmap and material.get("occlusionTexture") == {"index": lightmap["index"], "texCoord": 1, "strength": 0.0}:
            del material["occlusionTexture"]
        if material.get("extensions") == {}:
            del material["extensions"]
    for light in doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", []):
        light.get("extras", {}).pop("baked", None)
        if light.get("extras") == {}:
            del light["extras"]
    return doc


def check_box_primitives(after, buffers):
    """Each box copy: every attribute in its stored type, copied through one vertex mapping (the
    values are functions of the local position, so a mismatch shows), plus TEXCOORD_1."""
    for mesh in (0, 2):
        primitive, = after["meshes"][mesh]["primitives"]
        assert primitive["material"] == 0 and primitive.get("mode", 4) == 4
        attributes = primitive["attributes"]
        assert set(attributes) == {"POSITION", "NORMAL", "TEXCOORD_0", "TANGENT", "COLOR_0", "JOINTS_0",
                                   "WEIGHTS_0", "TEXCOORD_1"}
        get = {name: accessor_values(after, buffers, index) for name, index in attributes.items()}
        p = get["POSITION"]
        assert len(p) > 8  # split along the chart seams
        assert {tuple(v) for v in p} == {tuple(v) for v in CORNERS}  # local space, not world space
        position = after["accessors"][attributes["POSITION"]]
        np.testing.assert_array_equal(position["min"], [-0.5] * 3)
        np.testing.assert_array_equal(position["max"], [0.5] * 3)
        np.testing.assert_array_equal(get["TEXCOORD_0"], p[:, [0, 2]] + np.float32(0.5))
        np.testing.assert_array_equal(get["TANGENT"][:, 3], np.sign(p[:, 0]))
        assert after["accessors"][attributes["COLOR_0"]]["componentType"] == USHORT
        assert after["accessors"][attributes["COLOR_0"]]["normalized"] is True
        np.testing.assert_array_equal(get["COLOR_0"], np.round((p + np.float32(0.5)) * 65535))
        assert get["JOINTS_0"].dtype == np.uint8 and not get["JOINTS_0"].any()
        np.testing.assert_array_equal(get["WEIGHTS_0"], np.tile([1, 0, 0, 0], (len(p), 1)))
        target, = primitive["targets"]
        np.testing.assert_array_equal(accessor_values(after, buffers, target["POSITION"]), p * MORPH)
        uv1 = get["TEXCOORD_1"]
        assert uv1.dtype == np.float32 and uv1.min() >= 0 and uv1.max() <= 1
        corners = accessor_values(after, buffers, primitive["indices"]).reshape(-1, 3)
        assert len(corners) == 12
        # the file's winding: every face's normal points away from the centre
        tri = p[corners].astype(np.float64)
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        assert np.all((normal * tri.mean(axis=1)).sum(axis=1) > 0)


def covered_texels(scene, triangles) -> np.ndarray:
    """(H, W) bool: texels any of the triangles touches (conservative, as the baker rasterises)."""
    tex = scene.uv1[scene.indices[triangles]].astype(np.float64) * RESOLUTION
    owner = atlas_kernels.rasterize_owners(np.ascontiguousarray(tex), np.ones(len(tex), bool), RESOLUTION, RESOLUTION)
    return owner >= 0


def check_reloaded(source, out, baked_scene):
    """The output loads to the input's world-space triangles, with the bake's lightmap UVs, and
    the two box instances own disjoint lightmap texels."""
    before, after = load_gltf(source), load_gltf(out)
    np.testing.assert_allclose(world_triangles(after), world_triangles(before), rtol=0, atol=1e-6)
    np.testing.assert_array_equal(after.material_ids, before.material_ids)
    assert after.uv1 is not None
    np.testing.assert_array_equal(after.uv1[after.indices], baked_scene.uv1[baked_scene.indices])
    node = after.provenance.triangle_node
    assert set(node.tolist()) == {1, 3, 4}
    child, second, floor = (covered_texels(after, node == n) for n in (1, 3, 4))
    assert child.any() and second.any() and floor.any()
    assert not (child & second).any() and not (child & floor).any() and not (second & floor).any()
    return after


def check_lightmap(after_doc, buffers, out_dir):
    """What three.js and other engines read: MOZ_lightmap on the lightmapped materials, naming a
    texture on TEXCOORD_1 whose PNG source and MOZ_texture_rgbe .hdr hold I / scale."""
    info = after_doc["extras"]["patchlight"]["lightmap"]
    assert info["texCoord"] == 1 and info["intensity"] == pytest.approx(math.pi * info["scale"])
    texture = after_doc["textures"][info["texture"]]
    assert texture["name"] == "patchlight_lightmap"
    sampler = after_doc["samplers"][texture["sampler"]]
    assert sampler == {"magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071}
    image = after_doc["images"][texture["source"]]
    assert image["mimeType"] == "image/png" and image["name"] == "patchlight_lightmap"
    hdr_image = after_doc["images"][texture["extensions"]["MOZ_texture_rgbe"]["source"]]
    assert hdr_image["mimeType"] == "image/vnd.radiance"
    lightmap = read_exr(out_dir / "lightmap.exr")
    assert info["scale"] == pytest.approx(float(lightmap.max()))
    png = decode_image(view_bytes(after_doc, buffers, image["bufferView"]), "lightmap")[..., :3] * info["scale"]
    np.testing.assert_allclose(png, lightmap, atol=info["scale"] / 510 * 1.01)
    hdr_path = out_dir / "check.hdr"
    hdr_path.write_bytes(view_bytes(after_doc, buffers, hdr_image["bufferView"]))
    hdr = read_hdr(hdr_path) * info["scale"]
    hdr_path.unlink()
    peak = lightmap.max(axis=-1, keepdims=True)  # RGBE: 8-bit mantissas under the texel's peak's exponent
    assert np.all(np.abs(hdr - lightmap) <= peak / 256 + 1e-6 * info["scale"])
    for primitive in (p for mesh in after_doc["meshes"] for p in mesh["primitives"] if "TEXCOORD_1" in p["attributes"]):
        reference = after_doc["materials"][primitive["material"]]["extensions"]["MOZ_lightmap"]
        assert reference == {"index": info["texture"], "texCoord": 1, "intensity": info["intensity"]}
    assert sum(t.get("name") == "patchlight_lightmap" for t in after_doc["textures"]) == 1


# ----------------------------------------------------------------------------- the tests

def test_python_api_bake_keeps_the_input_and_adds_lightmap_uvs(tmp_path):
    source = Doc().build().glb(tmp_path / "level.glb")
    scene = load_scene(source)
    result = bake(scene, settings(), quiet=True)
    write_bake(result, tmp_path / "out", settings())
    out = tmp_path / "out" / "scene.glb"
    after, buffers = check_intact(source, out, tmp_path)
    check_box_primitives(after, buffers)
    floor, = after["meshes"][1]["primitives"]
    assert {"TEXCOORD_0", "TEXCOORD_1"} <= set(floor["attributes"])  # TEXCOORD_n numbered from 0, as glTF wants
    assert not accessor_values(after, buffers, floor["attributes"]["TEXCOORD_0"]).any()
    check_reloaded(source, out, result.scene)
    check_lightmap(after, buffers, tmp_path / "out")
    assert after["scenes"][0]["extras"]["patchlight"] == {"sky": {"uniform": SKY}}
    back = load_gltf(out)
    assert back.sky.kind == "uniform"
    np.testing.assert_array_equal(back.sky.colors, scene.sky.colors)


def test_cli_bake_of_a_gltf_with_external_files_and_a_sky_flag(tmp_path, capsys):
    (tmp_path / "src").mkdir()
    source = Doc().build().gltf(tmp_path / "src" / "level.gltf")
    out_dir = tmp_path / "out"
    gradient = ["1.2,1.9,3.6", "2.6,2.9,3.2", "0.5,0.45,0.4"]
    status = main(["bake", str(source), "-o", str(out_dir), "--resolution", str(RESOLUTION), "--rays", "32",
                   "--passes", "2", "--quiet", "--sky-gradient", *gradient])
    assert status == 0, capsys.readouterr().err
    out = out_dir / "scene.glb"
    after, buffers = check_intact(source, out, source.parent)
    assert "uri" not in after["images"][0] and after["buffers"] == [{"byteLength": len(buffers[0])}]
    check_box_primitives(after, buffers)
    baked = load_gltf(out)
    np.testing.assert_allclose(world_triangles(baked), world_triangles(load_gltf(source)), rtol=0, atol=1e-6)
    node = baked.provenance.triangle_node
    assert not (covered_texels(baked, node == 1) & covered_texels(baked, node == 3)).any()
    check_lightmap(after, buffers, out_dir)
    # the bake's sky, not the file's, in the form the loader reads: re-loading gives it back
    expected = [[float(v) for v in triple.split(",")] for triple in gradient]
    assert after["scenes"][0]["extras"]["patchlight"]["sky"] == {
        "gradient": dict(zip(("zenith", "horizon", "ground"), expected))}
    assert baked.sky.kind == "gradient"
    np.testing.assert_array_equal(baked.sky.colors, np.array(expected, np.float32))


def test_rebaking_scene_glb_keeps_its_lightmap_uvs_and_replaces_its_lightmap(tmp_path):
    source = Doc().build().glb(tmp_path / "level.glb")
    write_bake(bake(load_scene(source), settings(), quiet=True), tmp_path / "first", settings())
    first = tmp_path / "first" / "scene.glb"
    write_bake(bake(load_scene(first), settings(), quiet=True), tmp_path / "second", settings())
    second = tmp_path / "second" / "scene.glb"
    (a, a_blob), (b, b_blob) = read_glb(first), read_glb(second)
    assert b["meshes"] == a["meshes"] and b["nodes"] == a["nodes"]  # TEXCOORD_1 kept: nothing re-split
    for mesh in b["meshes"]:
        for primitive in mesh["primitives"]:
            for name, index in [*primitive["attributes"].items(), ("indices", primitive["indices"])]:
                assert (accessor_values(b, {0: b_blob}, index).tobytes()
                        == accessor_values(a, {0: a_blob}, index).tobytes()), name
    assert len(b["textures"]) == len(a["textures"]) and len(b["images"]) == len(a["images"])
    check_lightmap(b, {0: b_blob}, tmp_path / "second")
    np.testing.assert_array_equal(load_gltf(second).uv1.view(np.uint32), load_gltf(first).uv1.view(np.uint32))


def test_vertex_colours_written_per_instance_in_the_files_structure(tmp_path):
    """vertexbake's case: a scene whose COLOR_0 changed gets new float colours; instances differ."""
    source = Doc().build().glb(tmp_path / "level.glb")
    write_bake(bake(load_scene(source), settings(), quiet=True), tmp_path / "out", settings())
    scene = load_gltf(tmp_path / "out" / "scene.glb")
    light = np.where(scene.provenance.vertex_node == 3, 2.0, 0.5).astype(np.float32)
    scene.colors = scene.colors * light[:, None]
    save_baked_glb(scene, tmp_path / "lit.glb")
    back = load_gltf(tmp_path / "lit.glb")
    np.testing.assert_array_equal(back.colors[back.indices], scene.colors[scene.indices])
    doc, _ = read_glb(tmp_path / "lit.glb")
    child, second = (doc["meshes"][doc["nodes"][n]["mesh"]]["primitives"][0] for n in (1, 3))
    assert child["attributes"]["COLOR_0"] != second["attributes"]["COLOR_0"]
    assert doc["accessors"][child["attributes"]["COLOR_0"]]["componentType"] == FLOAT
    assert child["attributes"]["TEXCOORD_1"] != second["attributes"]["TEXCOORD_1"]


def test_image_sky_is_recorded_relative_to_scene_glb(tmp_path):
    (tmp_path / "src" / "sky").mkdir(parents=True)
    image = np.zeros((4, 8, 3), np.float32)
    image[:2] = [0.3, 0.6, 0.9]
    image[2:] = [0.2, 0.1, 0.05]
    write_hdr(tmp_path / "src" / "sky" / "day.hdr", image)
    doc = Doc().build()
    doc.doc.scenes[0].extras = {"patchlight": {"sky": {"image": "sky/day.hdr"}}}
    source = doc.glb(tmp_path / "src" / "level.glb")
    scene = load_scene(source)
    (tmp_path / "deep" / "out").mkdir(parents=True)
    save_baked_glb(scene, tmp_path / "deep" / "out" / "scene.glb")
    after, _ = read_glb(tmp_path / "deep" / "out" / "scene.glb")
    assert after["scenes"][0]["extras"]["patchlight"]["sky"] == {"image": "../../src/sky/day.hdr"}
    back = load_gltf(tmp_path / "deep" / "out" / "scene.glb")
    assert back.sky.kind == "image"
    np.testing.assert_array_equal(back.sky.image, scene.sky.image)


def test_a_changed_source_file_gives_the_flattened_copy_with_a_warning(tmp_path):
    source = Doc().build().glb(tmp_path / "level.glb")
    scene = load_gltf(source)
    source.write_bytes(source.read_bytes() + b"    ")
    with pytest.warns(UserWarning, match="has changed"):
        save_baked_glb(scene, tmp_path / "flat.glb")
    np.testing.assert_array_equal(world_triangles(load_gltf(tmp_path / "flat.glb")), world_triangles(scene))


def test_a_broken_reference_the_reader_never_follows_gives_the_flattened_copy_and_one_warning(tmp_path, capsys):
    """A skin naming accessor 999 (the reader reads no skins): the source-preserving writer
    cannot renumber it, so scene.glb is the flattened copy and the command line says why in
    one line (before: an IndexError traceback after the whole bake)."""
    source = Doc().build().glb(tmp_path / "level.glb")
    data = source.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + length])
    doc["skins"][0]["inverseBindMatrices"] = 999
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    rest = data[20 + length:]
    source.write_bytes(struct.pack("<4sII", b"glTF", 2, 20 + len(text) + len(rest))
                       + struct.pack("<I4s", len(text), b"JSON") + text + rest)
    assert main(["bake", str(source), "-o", str(tmp_path / "out"), "--resolution", "32", "--rays", "16",
                 "--passes", "1", "--quiet"]) == 0
    err = capsys.readouterr().err.strip().splitlines()  # the file's other oddities are warned too
    assert all(line.startswith("patchlight: warning: ") for line in err), err
    flattened = [line for line in err if "accessors 999" in line]
    assert len(flattened) == 1 and "flattened copy" in flattened[0], err
    assert "skins" not in read_glb(tmp_path / "out" / "scene.glb")[0]


def test_built_in_scenes_are_written_as_before(tmp_path):
    room = load_scene("room")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        save_baked_glb(room, tmp_path / "room.glb")
    doc, _ = read_glb(tmp_path / "room.glb")
    assert {n.get("name") for n in doc["nodes"] if "mesh" in n} == {m.name for m in room.materials}
    np.testing.assert_array_equal(load_gltf(tmp_path / "room.glb").positions, room.positions)


def test_provenance_follows_the_vertex_split(tmp_path):
    source = Doc().build().glb(tmp_path / "level.glb")
    scene = load_gltf(source)
    p = scene.provenance
    assert p.path == str(source) and p.stamp[0] == source.stat().st_size
    assert p.triangle_node.shape == p.triangle_mesh.shape == p.triangle_primitive.shape == (scene.n_triangles,)
    assert p.vertex_node.shape == p.vertex_source.shape == (len(scene.positions),)
    assert sorted(set(p.triangle_node.tolist())) == [1, 3, 4]
    np.testing.assert_array_equal(p.triangle_mesh, np.where(p.triangle_node == 4, 1, 0))
    from patchlight.atlas.uvs import ensure_lightmap_uvs

    split, *_ = ensure_lightmap_uvs(scene, resolution=RESOLUTION)
    q = split.provenance
    assert len(split.positions) > len(scene.positions) and q.fits(len(split.positions), split.n_triangles)
    # every split vertex copies the vertex of the same node and accessor element
    unsplit = {(n, v): i for i, (n, v) in enumerate(zip(p.vertex_node.tolist(), p.vertex_source.tolist()))}
    origin = [unsplit[n, v] for n, v in zip(q.vertex_node.tolist(), q.vertex_source.tolist())]
    np.testing.assert_array_equal(split.positions, scene.positions[origin])
    np.testing.assert_array_equal(q.vertex_primitive, p.vertex_primitive[origin])


def test_mirrored_node_strips_and_points_keep_their_meaning(tmp_path):
    """Under a mirroring node the file's winding comes back; a strip becomes the same triangles
    as a list; a points primitive stays as it was."""
    from patchlight.atlas.uvs import ensure_lightmap_uvs

    d = Doc()
    cube = gl.Primitive(attributes=gl.Attributes(POSITION=d.accessor(CORNERS, bounds=True)),
                        indices=d.accessor(CUBE.ravel(), component=UINT))
    strip = np.array([[-2, 0, -2], [-2, 0, 2], [2, 0, -2], [2, 0, 2], [9, 9, 9]], np.float32)  # the last unused
    ground = gl.Primitive(attributes=gl.Attributes(POSITION=d.accessor(strip, bounds=True)),
                          indices=d.accessor([0, 1, 2, 3], component=UINT), mode=5)
    points = gl.Primitive(attributes=gl.Attributes(POSITION=d.accessor(CORNERS, bounds=True)), mode=0)
    d.doc.meshes = [gl.Mesh(name="cube", primitives=[cube, points]), gl.Mesh(name="ground", primitives=[ground])]
    d.doc.nodes = [gl.Node(name="mirror", mesh=0, scale=[-1, 1, 1], translation=[0, 1, 0]), gl.Node(mesh=1)]
    d.doc.scenes = [gl.Scene(nodes=[0, 1])]
    source = d.glb(tmp_path / "mirror.glb")
    scene, *_ = ensure_lightmap_uvs(load_gltf(source), resolution=RESOLUTION)
    save_baked_glb(scene, tmp_path / "out.glb")
    after, blob = read_glb(tmp_path / "out.glb")
    buffers = {0: blob}
    assert not {"images", "textures", "samplers"} & set(after)  # no empty top-level arrays
    cube_out, points_out = after["meshes"][0]["primitives"]
    p = accessor_values(after, buffers, cube_out["attributes"]["POSITION"])
    tri = p[accessor_values(after, buffers, cube_out["indices"]).reshape(-1, 3)].astype(np.float64)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.all((normal * tri.mean(axis=1)).sum(axis=1) > 0)  # outward in local space, as in the file
    assert points_out["mode"] == 0 and set(points_out) == {"attributes", "mode"}  # accessors renumbered only
    assert set(points_out["attributes"]) == {"POSITION"}
    np.testing.assert_array_equal(accessor_values(after, buffers, points_out["attributes"]["POSITION"]), CORNERS)
    ground_out, = after["meshes"][1]["primitives"]
    assert "TEXCOORD_1" in ground_out["attributes"]
    assert after["accessors"][ground_out["attributes"]["POSITION"]]["count"] == 4  # re-indexed without it:
    assert ground_out.get("mode", 4) == 4 and after["accessors"][ground_out["indices"]]["count"] == 6  # a list
    np.testing.assert_allclose(world_triangles(load_gltf(tmp_path / "out.glb")), world_triangles(load_gltf(source)),
                               rtol=0, atol=1e-6)
