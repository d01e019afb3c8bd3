"""glTF import (transforms, primitive modes, attributes, materials, lights, sky, errors) and the
baked .glb export, on small files written here with pygltflib."""
import base64
import json
import math
import struct

import numpy as np
import pygltflib as gl
import pytest

from patchlight.errors import PatchlightError
from patchlight.imaging.color import srgb_to_linear
from patchlight.imaging.io import encode_png, write_hdr
from patchlight.imaging.lightmap import encode_lightmap
from patchlight.scene.gltf import load_gltf, save_baked_glb
from patchlight.scene.model import face_normals, vertex_normals

from gltf_builder import UBYTE, UINT, USHORT, Builder

S = math.sqrt(0.5)


TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 0, -1]], np.float32)  # faces +Y
UP = np.tile([0, 1, 0], (3, 1)).astype(np.float32)


def one_triangle(builder, **node_fields) -> int:
    mesh = builder.mesh(builder.primitive(TRIANGLE, NORMAL=UP), name="tri")
    return builder.node(mesh=mesh, **node_fields)


# ----------------------------------------------------------------------------- transforms

def test_node_hierarchy_composes_translation_rotation_scale(tmp_path):
    b = Builder()
    child = one_triangle(b, translation=[0, 1, 0])
    parent = b.node(children=[child], translation=[1, 2, 3], rotation=[0, S, 0, S], scale=[2, 2, 2])
    b.scene(parent)
    scene = load_gltf(b.glb(tmp_path / "tree.glb"))
    # p -> parent T + R_y(90) (2 (p + (0,1,0))), R_y(90): (x, y, z) -> (z, y, -x)
    expected = np.array([[1, 4, 3], [1, 4, 1], [-1, 4, 3]], np.float32)
    np.testing.assert_allclose(scene.positions, expected, atol=1e-6)
    np.testing.assert_allclose(scene.normals, UP, atol=1e-6)
    np.testing.assert_array_equal(scene.indices, [[0, 1, 2]])
    assert scene.name == "tree" and scene.source == str(tmp_path / "tree.glb")


def test_matrix_node_equals_its_trs(tmp_path):
    b = Builder()
    angle = 0.3
    rotation = [0, 0, math.sin(angle / 2), math.cos(angle / 2)]
    trs = one_triangle(b, translation=[1, -2, 0.5], rotation=rotation, scale=[1, 3, 2])
    c, s = math.cos(angle), math.sin(angle)
    m = np.array([[c, -s, 0, 1], [s, c, 0, -2], [0, 0, 1, 0.5], [0, 0, 0, 1]]) @ np.diag([1, 3, 2, 1])
    mat = one_triangle(b, matrix=m.T.ravel().tolist())  # glTF stores columns
    b.scene(trs, mat)
    scene = load_gltf(b.glb(tmp_path / "m.glb"))
    np.testing.assert_allclose(scene.positions[:3], scene.positions[3:], atol=1e-6)
    np.testing.assert_allclose(scene.positions[:3], (TRIANGLE @ m[:3, :3].T + m[:3, 3]), atol=1e-6)


def test_non_uniform_scale_transforms_normals_by_inverse_transpose(tmp_path):
    b = Builder()
    tilted = np.array([[0, 0, 0], [1, 0, -1], [0, 1, 0]], np.float32)  # face normal (1, 0, 1)/sqrt2
    mesh = b.mesh(b.primitive(tilted, NORMAL=np.tile([S, 0, S], (3, 1))))
    b.scene(b.node(mesh=mesh, scale=[2, 1, 1]))
    scene = load_gltf(b.glb(tmp_path / "s.glb"))
    want = np.array([0.5, 0, 1]) / math.hypot(0.5, 1)
    np.testing.assert_allclose(scene.normals, np.tile(want, (3, 1)), atol=1e-6)
    np.testing.assert_allclose(face_normals(scene.positions, scene.indices)[0][0], want, atol=1e-6)


def test_negative_scale_flips_winding_and_keeps_normals_outward(tmp_path):
    b = Builder()
    tilted = np.array([[0, 0, 0], [1, 0, -1], [0, 1, 0]], np.float32)
    mesh = b.mesh(b.primitive(tilted, NORMAL=np.tile([S, 0, S], (3, 1)),
                              TANGENT=np.tile([S, 0, -S, 1], (3, 1))))
    child = b.node(mesh=mesh)
    b.scene(b.node(children=[child], scale=[-1, 1, 1]))
    scene = load_gltf(b.glb(tmp_path / "mirror.glb"))
    np.testing.assert_allclose(scene.positions, [[0, 0, 0], [-1, 0, -1], [0, 1, 0]], atol=0)
    np.testing.assert_array_equal(scene.indices, [[0, 2, 1]])
    mirrored_normal = np.array([-S, 0, S])
    np.testing.assert_allclose(scene.normals, np.tile(mirrored_normal, (3, 1)), atol=1e-6)
    np.testing.assert_allclose(face_normals(scene.positions, scene.indices)[0][0], mirrored_normal, atol=1e-6)
    np.testing.assert_allclose(scene.tangents, np.tile([-S, 0, -S, -1], (3, 1)), atol=1e-6)


def test_without_scenes_every_root_node_is_used(tmp_path):
    b = Builder()
    child = one_triangle(b, translation=[0, 5, 0])
    b.node(children=[child])
    one_triangle(b, translation=[0, -5, 0])
    scene = load_gltf(b.glb(tmp_path / "roots.glb"))
    assert scene.n_triangles == 2
    assert sorted(scene.positions[:, 1].tolist()) == [-5] * 3 + [5] * 3


# ----------------------------------------------------------------------------- primitives

def test_primitive_modes_indexed_non_indexed_strip_fan_and_skipped_lines(tmp_path):
    b = Builder()
    quad = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    strip = np.array([[0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1], [0, 2, 1]], np.float32)
    fan = np.array([[0, 0, 2], [1, 0, 2], [1, 1, 2], [0, 1, 2], [-1, 1, 2]], np.float32)
    primitives = [b.primitive(quad),                                   # non-indexed list
                  b.primitive(quad[[0, 1, 2, 5]] + [0, 0, 3], indices=[0, 1, 2, 0, 2, 3]),
                  b.primitive(strip, mode=5), b.primitive(fan, mode=6),
                  b.primitive(quad, mode=0), b.primitive(quad, mode=1), b.primitive(quad, mode=3)]
    b.scene(b.node(mesh=b.mesh(*primitives)))
    scene = load_gltf(b.glb(tmp_path / "modes.glb"))
    assert scene.n_triangles == 2 + 2 + 3 + 3
    assert scene.extras["skipped_primitives"] == 3
    assert scene.extras["degenerate_triangles"] == 0 and scene.extras["warnings"] == []
    strip_tris = scene.indices[4:7] - 10  # vertices 0..5 quad, 6..9 indexed quad, 10.. strip
    np.testing.assert_array_equal(strip_tris, [[0, 1, 2], [1, 3, 2], [2, 3, 4]])
    np.testing.assert_array_equal(scene.indices[7:] - 15, [[1, 2, 0], [2, 3, 0], [3, 4, 0]])
    normals, areas = face_normals(scene.positions, scene.indices)
    np.testing.assert_allclose(normals, np.tile([0, 0, 1], (10, 1)), atol=1e-7)  # every winding faces +Z
    np.testing.assert_allclose(scene.normals, np.tile([0, 0, 1], (len(scene.positions), 1)), atol=1e-6)
    assert np.all(areas > 0)


def test_primitives_sharing_accessors_share_vertices(tmp_path):
    b = Builder()
    positions = b.accessor(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32))
    first = gl.Primitive(attributes=gl.Attributes(POSITION=positions), indices=b.accessor([0, 1, 2], component=UINT))
    second = gl.Primitive(attributes=gl.Attributes(POSITION=positions), indices=b.accessor([0, 2, 3], component=UINT))
    b.scene(b.node(mesh=b.mesh(first, second)))
    scene = load_gltf(b.glb(tmp_path / "shared.glb"))
    assert len(scene.positions) == 4
    np.testing.assert_array_equal(scene.indices, [[0, 1, 2], [0, 2, 3]])


def test_missing_normals_are_computed(tmp_path):
    b = Builder()
    tetra = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    b.scene(b.node(mesh=b.mesh(b.primitive(tetra, indices=faces))))
    scene = load_gltf(b.glb(tmp_path / "tetra.glb"))
    np.testing.assert_allclose(scene.normals, vertex_normals(tetra, np.array(faces)), atol=1e-7)
    np.testing.assert_allclose(scene.normals[0], -np.ones(3) / math.sqrt(3), atol=1e-6)  # outward corner


def test_degenerate_triangles_are_dropped_and_counted(tmp_path):
    b = Builder()
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [0, 0, 0]], np.float32)
    faces = [[0, 1, 2], [0, 0, 1], [0, 1, 3], [4, 1, 2], [1, 4, 0]]  # good, repeated, collinear, good, same point
    b.scene(b.node(mesh=b.mesh(b.primitive(points, indices=faces))))
    scene = load_gltf(b.glb(tmp_path / "degenerate.glb"))
    np.testing.assert_array_equal(scene.indices, [[0, 1, 2], [4, 1, 2]])
    assert scene.extras["degenerate_triangles"] == 3


def test_texcoord1_is_bit_exact_from_an_interleaved_strided_buffer(tmp_path):
    rng = np.random.default_rng(7)
    uv1 = rng.random((4, 2)).astype(np.float32)
    uv1[0] = [np.float32(1 / 3), np.nextafter(np.float32(0.5), np.float32(1))]
    uv1[1] = [np.float32(1e-42), np.float32(0.99999994)]  # subnormal, largest float32 below 1
    positions = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    interleaved = np.concatenate([positions, uv1], axis=1).astype(np.float32)  # 20-byte stride
    b = Builder()
    view = b.view(interleaved.tobytes(), stride=20)
    position = b.accessor(positions, view=view)
    texcoord1 = b.accessor(uv1, view=view, offset=12)
    uv0 = b.accessor(np.array([[0, 0], [65535, 0], [65535, 65535], [0, 32768]], np.uint16), component=USHORT,
                     normalized=True)
    primitive = gl.Primitive(attributes=gl.Attributes(POSITION=position, TEXCOORD_0=uv0, TEXCOORD_1=texcoord1),
                             indices=b.accessor([0, 1, 2, 0, 2, 3], component=UINT))
    b.scene(b.node(mesh=b.mesh(primitive)))
    scene = load_gltf(b.glb(tmp_path / "uv.glb"))
    assert scene.uv1.dtype == np.float32
    np.testing.assert_array_equal(scene.uv1.view(np.uint32), uv1.view(np.uint32))
    np.testing.assert_array_equal(scene.positions, positions)
    np.testing.assert_allclose(scene.uv0, [[0, 0], [1, 0], [1, 1], [0, 32768 / 65535]], atol=0)


def test_texcoord1_on_only_some_primitives_is_dropped_with_a_warning(tmp_path):
    b = Builder()
    with_uv1 = b.primitive(TRIANGLE, TEXCOORD_1=np.zeros((3, 2), np.float32))
    without = b.primitive(TRIANGLE + [0, 1, 0])
    b.scene(b.node(mesh=b.mesh(with_uv1, without)))
    scene = load_gltf(b.glb(tmp_path / "mixed.glb"))
    assert scene.uv1 is None
    assert any("TEXCOORD_1" in w for w in scene.extras["warnings"])
    np.testing.assert_array_equal(scene.uv0, np.zeros((6, 2)))


def test_vertex_colours_normalized_rgb_become_rgba(tmp_path):
    b = Builder()
    colors = b.accessor(np.array([[255, 0, 0], [0, 255, 0], [0, 0, 51]], np.uint8), component=UBYTE, normalized=True)
    coloured = b.primitive(TRIANGLE, COLOR_0=colors)
    plain = b.primitive(TRIANGLE + [0, 1, 0])
    b.scene(b.node(mesh=b.mesh(coloured, plain)))
    scene = load_gltf(b.glb(tmp_path / "colours.glb"))
    np.testing.assert_allclose(scene.colors[:3], [[1, 0, 0, 1], [0, 1, 0, 1], [0, 0, 0.2, 1]], atol=1e-7)
    np.testing.assert_array_equal(scene.colors[3:], np.ones((3, 4)))


def test_quantized_integer_positions(tmp_path):
    b = Builder()
    quantized = b.accessor(np.array([[0, 0, 0], [1000, 0, 0], [0, 0, 65535]], np.uint16), component=USHORT)
    b.scene(b.node(mesh=b.mesh(gl.Primitive(attributes=gl.Attributes(POSITION=quantized))), scale=[0.001] * 3))
    b.doc.extensionsUsed = b.doc.extensionsRequired = ["KHR_mesh_quantization"]
    scene = load_gltf(b.glb(tmp_path / "quantized.glb"))
    np.testing.assert_allclose(scene.positions, [[0, 0, 0], [1, 0, 0], [0, 0, 65.535]], rtol=1e-6)


def test_sparse_accessor_substitutes_values(tmp_path):
    b = Builder()
    base = b.accessor(np.zeros((3, 3), np.float32))
    acc = b.doc.accessors[base]
    which = gl.AccessorSparseIndices(bufferView=b.view(np.array([1, 2], "<u2").tobytes()), componentType=USHORT)
    acc.sparse = gl.Sparse(count=2, indices=which, values=gl.AccessorSparseValues(bufferView=b.view(TRIANGLE[1:].tobytes())))
    primitive = gl.Primitive(attributes=gl.Attributes(POSITION=base))
    b.scene(b.node(mesh=b.mesh(primitive)))
    np.testing.assert_array_equal(load_gltf(b.glb(tmp_path / "sparse.glb")).positions, TRIANGLE)


# ----------------------------------------------------------------------------- materials

def checker_png() -> tuple[bytes, np.ndarray]:
    pixels = np.array([[[0, 64, 128, 255], [255, 255, 255, 128]],
                       [[10, 20, 30, 0], [200, 100, 50, 255]]], np.uint8)
    return encode_png(pixels), pixels


def material_scene(b: Builder):
    png, _ = checker_png()
    texture = b.image(png)
    b.doc.materials = [
        gl.Material(name="painted", pbrMetallicRoughness=gl.PbrMetallicRoughness(
            baseColorFactor=[0.5, 0.25, 1.0, 1.0], baseColorTexture=gl.TextureInfo(index=texture)),
            doubleSided=True, extras={"shininess": 32, "reflectivity": 0.25}),
        gl.Material(name="lamp", emissiveFactor=[1.0, 0.5, 0.25], emissiveTexture=gl.TextureInfo(index=texture),
                    normalTexture=gl.NormalMaterialTexture(index=texture),
                    extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}),
    ]
    b.doc.extensionsUsed = ["KHR_materials_emissive_strength"]
    mesh = b.mesh(b.primitive(TRIANGLE, material=0), b.primitive(TRIANGLE + [0, 1, 0], material=1),
                  b.primitive(TRIANGLE + [0, 2, 0]))
    b.scene(b.node(mesh=mesh))


def test_materials_textures_emissive_strength_and_default(tmp_path):
    b = Builder()
    material_scene(b)
    scene = load_gltf(b.glb(tmp_path / "materials.glb"))
    painted, lamp, default = scene.materials
    np.testing.assert_array_equal(scene.material_ids, [0, 1, 2])
    _, pixels = checker_png()
    expected = pixels / 255.0
    np.testing.assert_allclose(painted.base_color_texture[..., :3], srgb_to_linear(expected[..., :3]), atol=1e-6)
    np.testing.assert_allclose(painted.base_color_texture[..., 3], expected[..., 3], atol=1e-6)  # alpha stays linear
    assert painted.base_color_texture.shape == (2, 2, 4) and painted.base_color_texture.dtype == np.float32
    assert painted.base_color_texture[0, 0, 1] == pytest.approx(0.05126946, rel=1e-5)  # sRGB 64/255
    np.testing.assert_array_equal(painted.base_color, np.float32([0.5, 0.25, 1.0, 1.0]))
    assert painted.double_sided and painted.shininess == 32.0 and painted.reflectivity == 0.25
    np.testing.assert_allclose(lamp.emissive, [4, 2, 1])
    np.testing.assert_allclose(lamp.emissive_texture, srgb_to_linear(expected[..., :3]), atol=1e-6)
    np.testing.assert_allclose(lamp.normal_texture, expected[..., :3], atol=1e-6)
    assert lamp.base_color_texture is None and not lamp.double_sided
    assert default.name == "default" and not default.is_emissive


# ----------------------------------------------------------------------------- lights

def light_scene(b: Builder):
    b.doc.extensions = {"KHR_lights_punctual": {"lights": [
        {"type": "directional", "intensity": 683 * 3, "color": [1, 0.9, 0.8], "name": "sun",
         "extras": {"angle": 0.0093}},
        {"type": "point", "intensity": 683, "range": 10, "extras": {"falloff": "range"}},
        {"type": "spot", "intensity": 6830, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
        {"type": "spot", "intensity": 68.3},
    ]}}
    b.doc.extensionsUsed = ["KHR_lights_punctual"]
    light = lambda i: {"KHR_lights_punctual": {"light": i}}  # noqa: E731
    sun = b.node(extensions=light(0), rotation=[-S, 0, 0, S])  # -Z turned to -Y: straight down
    point = b.node(extensions=light(1), translation=[0, 1, 0])
    spot = b.node(extensions=light(2), translation=[1, 0, 0], rotation=[0, S, 0, S])  # -Z turned to -X
    plain_spot = b.node(extensions=light(3))
    group = b.node(children=[point, spot, plain_spot], translation=[0, 2, 0])
    b.scene(one_triangle(b), sun, group)


def test_punctual_lights_units_positions_directions_and_cones(tmp_path):
    b = Builder()
    light_scene(b)
    sun, point, spot, plain = load_gltf(b.glb(tmp_path / "lights.glb")).lights
    assert (sun.kind, point.kind, spot.kind) == ("directional", "point", "spot")
    assert sun.intensity == pytest.approx(3.0) and point.intensity == pytest.approx(1.0)
    assert spot.intensity == pytest.approx(10.0) and plain.intensity == pytest.approx(0.1)
    np.testing.assert_allclose(sun.direction, [0, -1, 0], atol=1e-7)
    np.testing.assert_allclose(sun.color, [1, 0.9, 0.8])
    assert sun.angle == pytest.approx(0.0093) and sun.name == "sun" and sun.range is None
    np.testing.assert_allclose(point.position, [0, 3, 0])
    assert point.range == 10.0 and point.falloff == "range"
    np.testing.assert_allclose(spot.position, [1, 2, 0])
    np.testing.assert_allclose(spot.direction, [-1, 0, 0], atol=1e-7)
    assert (spot.inner_cone, spot.outer_cone) == (0.2, 0.5)
    assert (plain.inner_cone, plain.outer_cone) == (0.0, pytest.approx(math.pi / 4))
    np.testing.assert_allclose(plain.direction, [0, 0, -1])
    assert plain.falloff is None and plain.range is None


# ----------------------------------------------------------------------------- sky

def test_sky_from_scene_or_asset_extras(tmp_path):
    b = Builder()
    b.scene(one_triangle(b), extras={"patchlight": {"sky": {"uniform": [0.1, 0.2, 0.3]}}})
    sky = load_gltf(b.glb(tmp_path / "uniform.glb")).sky
    assert sky.kind == "uniform"
    np.testing.assert_allclose(sky.radiance(np.array([[0, 1, 0]]))[0], [0.1, 0.2, 0.3])

    b = Builder()
    b.scene(one_triangle(b))
    b.doc.asset.extras = {"patchlight": {"sky": {"gradient": {"zenith": [0, 0, 1], "horizon": [1, 1, 1],
                                                              "ground": [0.2, 0.1, 0]}}}}
    sky = load_gltf(b.glb(tmp_path / "gradient.glb")).sky
    np.testing.assert_allclose(sky.radiance(np.array([[0, 1, 0], [0, -1, 0]])), [[0, 0, 1], [0.2, 0.1, 0]])


def test_sky_image_is_read_relative_to_the_gltf(tmp_path):
    (tmp_path / "env").mkdir()
    env = np.zeros((4, 8, 3), np.float32)
    env[:2] = 2.0  # bright upper half
    write_hdr(tmp_path / "env" / "sky.hdr", env)
    b = Builder()
    b.scene(one_triangle(b), extras={"patchlight": {"sky": {"image": "env/sky.hdr"}}})
    sky = load_gltf(b.glb(tmp_path / "image.glb")).sky
    assert sky.kind == "image" and sky.image.shape == (4, 8, 3)
    assert sky.radiance(np.array([[0, 1, 0]]))[0, 0] == pytest.approx(2.0, rel=1 / 128)
    assert sky.radiance(np.array([[0, -1, 0]]))[0, 0] < 0.01


@pytest.mark.parametrize("spec", [{"uniform": [1, 2]}, {"cloudy": 1}, {"uniform": [1, 1, 1], "image": "x.exr"},
                                  {"gradient": {"zenith": [1, 1, 1]}}, {"uniform": [-1, 0, 0]},
                                  {"image": "missing.exr"}])
def test_bad_sky_is_refused(tmp_path, spec):
    b = Builder()
    b.scene(one_triangle(b), extras={"patchlight": {"sky": spec}})
    path = b.glb(tmp_path / "sky.glb")
    with pytest.raises(PatchlightError) as info:
        load_gltf(path)
    assert str(tmp_path) in str(info.value)


# ----------------------------------------------------------------------------- .gltf variants

def textured_quad(b: Builder, image: gl.Image):
    b.doc.images = [image]
    b.doc.textures = [gl.Texture(source=0)]
    b.doc.materials = [gl.Material(pbrMetallicRoughness=gl.PbrMetallicRoughness(
        baseColorTexture=gl.TextureInfo(index=0)))]
    uv1 = np.array([[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]], np.float32)
    b.scene(b.node(mesh=b.mesh(b.primitive(TRIANGLE, material=0, TEXCOORD_1=uv1))))
    return uv1


def test_gltf_with_external_bin_and_image(tmp_path):
    png, pixels = checker_png()
    (tmp_path / "tex dir").mkdir()
    (tmp_path / "tex dir" / "check.png").write_bytes(png)
    b = Builder()
    uv1 = textured_quad(b, gl.Image(uri="tex%20dir/check.png"))
    scene = load_gltf(b.gltf(tmp_path / "external.gltf", buffer_uri="external.bin"))
    np.testing.assert_array_equal(scene.uv1, uv1)
    np.testing.assert_allclose(scene.materials[0].base_color_texture[..., 3], pixels[..., 3] / 255, atol=1e-7)


def test_gltf_with_data_uris(tmp_path):
    png, pixels = checker_png()
    b = Builder()
    uv1 = textured_quad(b, gl.Image(uri="data:image/png;base64," + base64.b64encode(png).decode()))
    scene = load_gltf(b.gltf(tmp_path / "inline.gltf"))
    np.testing.assert_array_equal(scene.uv1, uv1)
    np.testing.assert_allclose(scene.positions, TRIANGLE)
    assert scene.materials[0].base_color_texture.shape == (2, 2, 4)


# ----------------------------------------------------------------------------- bad input

def expect_error(path, match=None):
    with pytest.raises(PatchlightError, match=match) as info:
        load_gltf(path)
    message = str(info.value)
    assert message.startswith(str(path)) and "\n" not in message, message
    return message


def valid_builder() -> Builder:
    b = Builder()
    b.scene(one_triangle(b))
    return b


def test_missing_directory_random_and_non_gltf_files(tmp_path):
    expect_error(tmp_path / "nope.glb", "file not found")
    expect_error(tmp_path, "is a directory")
    (tmp_path / "noise.glb").write_bytes(np.random.default_rng(3).bytes(500))
    expect_error(tmp_path / "noise.glb", "not a glTF file")
    (tmp_path / "other.gltf").write_text('{"type": "FeatureCollection"}')
    expect_error(tmp_path / "other.gltf", "not a glTF file")
    (tmp_path / "list.gltf").write_text("[1, 2, 3]")
    expect_error(tmp_path / "list.gltf", "not a glTF file")
    (tmp_path / "old.gltf").write_text('{"asset": {"version": "1.0"}}')
    expect_error(tmp_path / "old.gltf", "version")
    (tmp_path / "broken.gltf").write_text('{"asset": {"version": "2.0"}, "meshes": [')
    expect_error(tmp_path / "broken.gltf", "invalid JSON")


def test_truncated_glb(tmp_path):
    data = valid_builder().glb(tmp_path / "ok.glb").read_bytes()
    for cut in (8, 40, len(data) - 7):
        (tmp_path / "cut.glb").write_bytes(data[:cut])
        expect_error(tmp_path / "cut.glb", "truncated")


def test_accessor_past_its_buffer_missing_bin_and_bad_indices(tmp_path):
    b = valid_builder()
    b.doc.accessors[0].count = 1000
    expect_error(b.glb(tmp_path / "long.glb"), "accessor 0 reads bytes up to")

    b = valid_builder()
    b.doc.bufferViews[0].byteLength = 10_000
    expect_error(b.glb(tmp_path / "view.glb"), "bufferView 0")

    b = valid_builder()
    b.doc.meshes[0].primitives[0].attributes.POSITION = 99
    expect_error(b.glb(tmp_path / "acc.glb"), "accessor 99 does not exist")

    b = valid_builder()
    b.doc.accessors[0].bufferView = 42
    expect_error(b.glb(tmp_path / "bv.glb"), "bufferView 42 does not exist")

    b = valid_builder()
    path = b.gltf(tmp_path / "ext.gltf", buffer_uri="ext.bin")
    (tmp_path / "ext.bin").unlink()
    expect_error(path, "'ext.bin' not found")

    b = valid_builder()
    b.doc.meshes[0].primitives[0].indices = b.accessor([0, 1, 7], component=UINT)
    expect_error(b.glb(tmp_path / "index.glb"), "index 7 is past its 3 vertices")

    b = valid_builder()
    b.doc.images = [gl.Image(uri="missing.png")]
    b.doc.textures = [gl.Texture(source=0)]
    b.doc.materials = [gl.Material(emissiveTexture=gl.TextureInfo(index=0))]
    expect_error(b.gltf(tmp_path / "img.gltf"), "'missing.png' not found")

    b = valid_builder()
    b.doc.images = [gl.Image(bufferView=b.view(b"not a png at all"), mimeType="image/png")]
    b.doc.textures = [gl.Texture(source=0)]
    b.doc.materials = [gl.Material(emissiveTexture=gl.TextureInfo(index=0))]
    expect_error(b.glb(tmp_path / "badimg.glb"), "image 0 .*not a readable PNG/JPEG")


def test_required_extension_nan_positions_and_no_triangles(tmp_path):
    b = valid_builder()
    b.doc.extensionsUsed = b.doc.extensionsRequired = ["KHR_draco_mesh_compression"]
    expect_error(b.glb(tmp_path / "draco.glb"), "KHR_draco_mesh_compression")

    b = Builder()
    bad = TRIANGLE.copy()
    bad[1, 2] = np.nan
    b.scene(b.node(mesh=b.mesh(b.primitive(bad), name="broken_rock")))
    expect_error(b.glb(tmp_path / "nan.glb"), "mesh 'broken_rock': 1 vertex positions are NaN")

    b = Builder()
    b.scene(b.node(mesh=b.mesh(b.primitive(TRIANGLE, mode=0), b.primitive(TRIANGLE, mode=1))))
    assert "2 point/line primitives skipped" in expect_error(b.glb(tmp_path / "points.glb"), "no triangles")

    b = Builder()
    b.scene(b.node(mesh=b.mesh(b.primitive(TRIANGLE, indices=[0, 0, 1]))))
    expect_error(b.glb(tmp_path / "flat.glb"), "no triangles left")


def test_malformed_values_and_bad_lights(tmp_path):
    b = valid_builder()
    b.doc.nodes[0].matrix = [1, 0, 0]
    expect_error(b.glb(tmp_path / "matrix.glb"), "matrix has 3 numbers")

    b = valid_builder()
    b.doc.extensions = {"KHR_lights_punctual": {"lights": [{"type": "area"}]}}
    b.doc.nodes[0].extensions = {"KHR_lights_punctual": {"light": 0}}
    expect_error(b.glb(tmp_path / "area.glb"), "unknown light type 'area'")

    b = valid_builder()
    b.doc.nodes[0].extensions = {"KHR_lights_punctual": {"light": 3}}
    expect_error(b.glb(tmp_path / "nolight.glb"), "light 3 does not exist")

    path = valid_builder().gltf(tmp_path / "types.gltf")
    doc = json.loads(path.read_text())
    doc["nodes"][0]["translation"] = "up"
    path.write_text(json.dumps(doc))
    expect_error(path, "malformed glTF")


# ----------------------------------------------------------------------------- export round trip

def rich_scene(tmp_path):
    b = Builder()
    material_scene(b)
    light_scene(b)
    light_roots = b.doc.scenes[0].nodes[1:]
    mesh = b.doc.nodes[0].mesh
    prims = b.doc.meshes[mesh].primitives
    rng = np.random.default_rng(11)
    for number, primitive in enumerate(prims):
        primitive.attributes.TEXCOORD_1 = b.accessor(rng.random((3, 2)).astype(np.float32))
        primitive.attributes.COLOR_0 = b.accessor(rng.random((3, 4)).astype(np.float32))
    b.scene(b.node(mesh=mesh, translation=[0.5, 0, 0]), *light_roots,
            extras={"patchlight": {"sky": {"gradient": {"zenith": [0, 0, 1], "horizon": [1, 1, 1],
                                                        "ground": [0.2, 0.1, 0]}}}})
    return load_gltf(b.glb(tmp_path / "rich.glb"))


def test_baked_glb_round_trip(tmp_path):
    scene = rich_scene(tmp_path)
    lightmap = encode_lightmap(np.full((4, 4, 3), 2.5, np.float32))
    meta = {"width": 4, "height": 4, "exposure": np.float64(1.5)}
    path = save_baked_glb(scene, tmp_path / "baked.glb", lightmap, meta)
    back = load_gltf(path)
    np.testing.assert_array_equal(back.uv1.view(np.uint32), scene.uv1.view(np.uint32))
    for name in ("positions", "normals", "uv0", "colors", "indices", "material_ids"):
        np.testing.assert_array_equal(getattr(back, name), getattr(scene, name), err_msg=name)
    assert [m.name for m in back.materials] == [m.name for m in scene.materials]
    for a, c in zip(scene.materials, back.materials):
        np.testing.assert_array_equal(a.base_color, c.base_color)
        np.testing.assert_allclose(c.emissive, a.emissive, rtol=1e-6)
        assert (a.double_sided, a.shininess, a.reflectivity) == (c.double_sided, c.shininess, c.reflectivity)
        for texture in ("base_color_texture", "emissive_texture", "normal_texture"):
            if getattr(a, texture) is None:
                assert getattr(c, texture) is None
            else:  # 8-bit sRGB re-encoding of 8-bit sRGB data: exact to rounding
                np.testing.assert_allclose(getattr(c, texture), getattr(a, texture), atol=1e-6)
    assert len(back.lights) == len(scene.lights) == 4
    for a, c in zip(scene.lights, back.lights):
        assert (a.kind, a.name, a.range, a.falloff) == (c.kind, c.name, c.range, c.falloff)
        assert c.intensity == pytest.approx(a.intensity, rel=1e-12)
        assert (c.inner_cone, c.outer_cone, c.angle) == pytest.approx((a.inner_cone, a.outer_cone, a.angle))
        np.testing.assert_allclose(c.position, a.position, atol=1e-6)
        np.testing.assert_allclose(c.direction, a.direction, atol=1e-6)
        np.testing.assert_array_equal(c.color, a.color)
    np.testing.assert_array_equal(back.sky.colors, scene.sky.colors)


def glb_json(path) -> dict:
    data = path.read_bytes()
    assert data[:4] == b"glTF" and struct.unpack_from("<I", data, 8)[0] == len(data)
    length = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + length])


def test_baked_glb_layout_for_three_js(tmp_path):
    scene = rich_scene(tmp_path)
    scene.provenance = None  # the flattened writer of built-in scenes (tests/scene/test_baked_glb.py: files)
    lightmap = encode_lightmap(np.full((2, 2, 3), 6.0, np.float32))
    path = save_baked_glb(scene, tmp_path / "baked.glb", lightmap, {"exposure": 0.5})
    doc = glb_json(path)
    info = doc["extras"]["patchlight"]["lightmap"]
    assert info == {"texture": info["texture"], "texCoord": 1, "scale": 6.0, "intensity": pytest.approx(6 * math.pi),
                    "exposure": 0.5}
    texture = doc["textures"][info["texture"]]
    assert texture["name"] == "patchlight_lightmap"
    data = path.read_bytes()
    bin_start = 20 + struct.unpack_from("<I", data, 12)[0] + 8
    hdr_source = texture["extensions"]["MOZ_texture_rgbe"]["source"]
    for source, mime, payload in ((texture["source"], "image/png", lightmap.png),
                                  (hdr_source, "image/vnd.radiance", lightmap.hdr)):
        image = doc["images"][source]
        assert image["mimeType"] == mime and image["name"].startswith("patchlight_lightmap")
        view = doc["bufferViews"][image["bufferView"]]
        assert data[bin_start + view.get("byteOffset", 0):][:view["byteLength"]] == payload
    for material in doc["materials"]:
        assert material["extensions"]["MOZ_lightmap"] == {"index": info["texture"], "texCoord": 1,
                                                          "intensity": info["intensity"]}
        assert material["extensions"]["KHR_materials_specular"] == {"specularFactor": 0.0}
    assert all(light["extras"]["baked"] is True for light in doc["extensions"]["KHR_lights_punctual"]["lights"])
    assert doc["samplers"][texture["sampler"]]["wrapS"] == 33071
    assert len(doc["meshes"]) == 3  # one per material
    assert all(p["attributes"]["TEXCOORD_1"] == doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"]
               for m in doc["meshes"] for p in m["primitives"])
    assert set(doc["extensionsUsed"]) == {"KHR_lights_punctual", "KHR_materials_emissive_strength",
                                          "KHR_materials_specular", "MOZ_lightmap", "MOZ_texture_rgbe"}
    assert doc["materials"][1]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] == 4.0
    assert max(doc["materials"][1]["emissiveFactor"]) <= 1.0
    assert doc["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] == 0.0
    lights = doc["extensions"]["KHR_lights_punctual"]["lights"]
    assert lights[0]["intensity"] == pytest.approx(683 * 3) and lights[3]["intensity"] == pytest.approx(68.3)
    position = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    np.testing.assert_allclose(position["min"], scene.positions.min(axis=0))
    assert [f for f in (tmp_path).iterdir() if f.name.startswith(".")] == []


def test_baked_glb_groups_interleaved_materials_and_needs_uv1_for_a_lightmap(tmp_path):
    scene = rich_scene(tmp_path)
    scene.provenance = None  # reordered triangles: the flattened writer
    order = np.array([2, 0, 1])
    scene.indices, scene.material_ids = scene.indices[order], scene.material_ids[order]
    back = load_gltf(save_baked_glb(scene, tmp_path / "plain.glb"))
    assert "extras" not in glb_json(tmp_path / "plain.glb")
    grouped = np.argsort(scene.material_ids, kind="stable")
    np.testing.assert_array_equal(back.indices, scene.indices[grouped])
    np.testing.assert_array_equal(back.material_ids, scene.material_ids[grouped])
    scene.uv1 = None
    with pytest.raises(ValueError, match="uv1"):
        save_baked_glb(scene, tmp_path / "no_uv1.glb", encode_lightmap(np.zeros((1, 1, 3), np.float32)))
    assert not (tmp_path / "no_uv1.glb").exists()


def test_camera_round_trips_as_a_perspective_camera_node(tmp_path):
    from patchlight.scene import load_scene

    room = load_scene("room")
    save_baked_glb(room, tmp_path / "room.glb")
    camera = load_gltf(tmp_path / "room.glb").extras["camera"]
    eye, target = np.array(room.extras["camera"]["eye"]), np.array(room.extras["camera"]["target"])
    np.testing.assert_allclose(camera["eye"], eye, atol=1e-6)
    forward = np.array(camera["target"]) - np.array(camera["eye"])
    np.testing.assert_allclose(forward, (target - eye) / np.linalg.norm(target - eye), atol=1e-6)
    assert camera["fov"] == pytest.approx(75.0)
