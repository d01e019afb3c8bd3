"""`patchlight bake` end to end: outputs, round trips, orientation, and every bad input
giving one line, exit status 2 and an untouched output directory."""
import json
import struct

import numpy as np
import pytest

from patchlight.cli.main import main
from patchlight.imaging.io import read_exr
from patchlight.scene import Light, SceneBuilder
from patchlight.scene.gltf import load_gltf, save_baked_glb


def lit_quad(uv1=None, light=None):
    """A 2 x 2 m floor at y = 0 with lightmap UVs uv1 (4 corners, optional) and a light."""
    b = SceneBuilder()
    m = b.material("floor", (0.5, 0.5, 0.5))
    b.quad([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], m, (0, 1, 0))
    light = light or Light("point", np.ones(3, np.float32), 4.0, position=np.array([0.8, 0.3, 0.8], np.float32))
    scene = b.scene("quad", lights=[light])
    if uv1 is not None:
        # positions are two triangles (0,1,2) (0,2,3) of the oriented quad: map UVs by position
        corner_uv = {(-1, -1): uv1[0], (1, -1): uv1[1], (1, 1): uv1[2], (-1, 1): uv1[3]}
        scene.uv1 = np.array([corner_uv[(int(round(p[0])), int(round(p[2])))] for p in scene.positions], np.float32)
    return scene


def run(capsys, *argv):
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def test_bake_writes_every_output_and_a_json_summary(tmp_path, capsys):
    out = tmp_path / "out"
    status, stdout, _ = run(capsys, "bake", "cornell", "-o", str(out), "--resolution", "32", "--json")
    assert status == 0
    summary = json.loads(stdout)
    for name in ("lightmap.exr", "lightmap.png", "scene.glb", "bake.json", "adaptive.png"):
        assert (out / name).stat().st_size > 0
    assert summary["computed_patches"] + summary["interpolated_patches"] + summary["inside_geometry_patches"] == summary["patches"]
    for key in ("rays_traced", "rays_per_second", "form_factor_matrix", "pass_changes", "seconds_per_stage"):
        assert key in summary
    assert not list(out.glob("*.tmp*")) and not list(out.glob(".*"))
    lightmap = read_exr(out / "lightmap.exr")
    assert lightmap.shape == (32, 32, 3) and lightmap.max() > 0


def test_texcoord1_survives_the_bake_bit_exact(tmp_path, capsys):
    uv1 = np.array([[0.1, 0.2], [0.9, 0.2], [0.9, 0.8], [0.1, 0.8]], np.float32) + np.float32(1e-7)
    save_baked_glb(lit_quad(uv1), tmp_path / "in.glb")
    before = load_gltf(tmp_path / "in.glb").uv1
    status, _, _ = run(capsys, "bake", str(tmp_path / "in.glb"), "-o", str(tmp_path / "out"), "--resolution", "32", "--quiet")
    assert status == 0
    after = load_gltf(tmp_path / "out" / "scene.glb").uv1
    assert after.tobytes() == before.tobytes()


def test_lightmap_orientation_puts_the_lit_texel_where_the_uvs_say(tmp_path, capsys):
    # uv1 = ((x + 1) / 2, (z + 1) / 2): the lamp over (x, z) = (0.8, -0.4) is near uv (0.9, 0.3),
    # which is row 0.3 H = 12 (v = 0 is the top row), column 0.9 W = 36: a transposed or
    # flipped lightmap puts it elsewhere.
    uv1 = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    lamp = Light("point", np.ones(3, np.float32), 4.0, position=np.array([0.8, 0.3, -0.4], np.float32))
    save_baked_glb(lit_quad(uv1, lamp), tmp_path / "in.glb")
    status, _, _ = run(capsys, "bake", str(tmp_path / "in.glb"), "-o", str(tmp_path / "out"), "--resolution", "40", "--quiet")
    assert status == 0
    lightmap = read_exr(tmp_path / "out" / "lightmap.exr")[..., 0]
    row, col = np.unravel_index(np.argmax(lightmap), lightmap.shape)
    assert abs(row - 12) <= 1 and abs(col - 36) <= 1


def _write(path, data: bytes):
    path.write_bytes(data)
    return path


def _bad_inputs(tmp_path):
    save_baked_glb(lit_quad(), tmp_path / "good.glb")
    good = (tmp_path / "good.glb").read_bytes()
    json_len = struct.unpack_from("<I", good, 12)[0]
    doc = json.loads(good[20:20 + json_len])
    broken = dict(doc, accessors=[dict(a, bufferView=99) for a in doc["accessors"]])
    uncounted = dict(doc, accessors=[dict(a, count=-3) for a in doc["accessors"]])
    dark = lit_quad()
    dark.lights = []
    points = dict(doc, meshes=[{"primitives": [dict(p, mode=0) for p in m["primitives"]]} for m in doc["meshes"]])
    lines = dict(doc, meshes=[{"primitives": [dict(p, mode=1) for p in m["primitives"]]} for m in doc["meshes"]])
    lost_buffer = dict(doc, buffers=[{"byteLength": doc["buffers"][0]["byteLength"], "uri": "gone.bin"}])
    light_defs = doc["extensions"]["KHR_lights_punctual"]["lights"]
    negative = _with_lights(doc, [dict(light, color=[1.0, -0.5, 1.0]) for light in light_defs])
    zero = _with_lights(doc, [dict(light, intensity=0.0) for light in light_defs])
    glowing = dict(doc, materials=[dict(m, pbrMetallicRoughness={"baseColorFactor": [5.0, 1.0, 1.0, 1.0]})
                                   for m in doc["materials"]])
    (tmp_path / "folder.glb").mkdir()
    return {
        "missing": (tmp_path / "nope.glb", "not found"),
        "a folder": (tmp_path / "folder.glb", "folder.glb"),
        "lost buffer": (_write(tmp_path / "lost.gltf", json.dumps(lost_buffer).encode()), "gone.bin"),
        "only lines": (_write(tmp_path / "lines.gltf", _embed(lines, good, json_len)), "no triangle"),
        "infinite": (_write(tmp_path / "inf.glb", _with_position(good, doc, json_len, float("inf"))), "infinite"),
        "all degenerate": (_write(tmp_path / "flat.glb", _with_position(good, doc, json_len, None)), "degenerate"),
        "negative light": (_write(tmp_path / "neg.gltf", _embed(negative, good, json_len)), "color"),
        "dark light": (_write(tmp_path / "zero.gltf", _embed(zero, good, json_len)), "nothing lights"),
        "base colour above 1": (_write(tmp_path / "glow.gltf", _embed(glowing, good, json_len)), "baseColorFactor"),
        "not gltf": (_write(tmp_path / "noise.glb", bytes(range(256)) * 4), "glTF"),
        "truncated": (_write(tmp_path / "cut.glb", good[: len(good) // 2]), "truncated"),
        "broken accessor": (_write(tmp_path / "broken.gltf", json.dumps(broken).encode()), "bufferView"),
        "negative count": (_write(tmp_path / "negative.gltf", _embed(uncounted, good, json_len)), "count -3"),
        "nan": (_write(tmp_path / "nan.glb", _with_position(good, doc, json_len, float("nan"))), "NaN"),
        "no light": (_save(dark, tmp_path / "dark.glb"), "nothing lights"),
        "only points": (_write(tmp_path / "points.gltf", _embed(points, good, json_len)), "no triangle"),
    }


def _with_position(glb, doc, json_len, x):
    """The .glb with its first vertex's x set to x in the BIN chunk; x None: every vertex of
    the first mesh moved onto the first (all its triangles degenerate)."""
    accessor = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    view = doc["bufferViews"][accessor["bufferView"]]
    at = 20 + json_len + 8 + view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    data = bytearray(glb)
    if x is None:
        stride = view.get("byteStride", 12)
        for k in range(1, accessor["count"]):
            data[at + k * stride:at + k * stride + 12] = data[at:at + 12]
    else:
        data[at:at + 4] = struct.pack("<f", x)
    return bytes(data)


def _with_lights(doc, lights):
    return dict(doc, extensions=dict(doc["extensions"], KHR_lights_punctual={"lights": lights}))


def _save(scene, path):
    save_baked_glb(scene, path)
    return path


def _embed(doc, glb, json_len):
    """A .gltf whose single buffer is the .glb's BIN chunk as a data URI."""
    import base64

    bin_start = 20 + json_len + 8
    blob = glb[bin_start:]
    doc = dict(doc, buffers=[{"byteLength": len(blob), "uri": "data:application/octet-stream;base64,"
                              + base64.b64encode(blob).decode()}])
    return json.dumps(doc).encode()


@pytest.mark.parametrize("case", ["missing", "a folder", "not gltf", "truncated", "broken accessor",
                                  "negative count", "lost buffer",
                                  "nan", "infinite", "all degenerate", "no light", "dark light", "negative light",
                                  "base colour above 1", "only points", "only lines"])
def test_bad_input_gives_one_line_status_2_and_no_output(tmp_path, capsys, case):
    path, words = _bad_inputs(tmp_path)[case]
    out = tmp_path / "out"
    status, stdout, err = run(capsys, "bake", str(path), "-o", str(out), "--resolution", "16", "--quiet")
    assert status == 2
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert words.lower() in err.lower()
    assert not out.exists() or not any(out.iterdir())


def test_absurd_resolution_is_refused(tmp_path, capsys):
    status, _, err = run(capsys, "bake", "cornell", "-o", str(tmp_path / "out"), "--resolution", "100000", "--quiet")
    assert status == 2 and "8192" in err
    assert not (tmp_path / "out").exists()


def test_lightmap_too_large_for_memory_is_refused_with_the_estimate(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("patchlight.bake.available_memory", lambda: 256 << 20)
    status, _, err = run(capsys, "bake", "cornell", "-o", str(tmp_path / "out"), "--resolution", "2048", "--quiet")
    assert status == 2 and "GiB" in err and "--resolution" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv", [["--sky", "1,2"], ["--passes", "0"], ["--accuracy", "1.5"], ["--exposure", "bright"]])
def test_bad_options_are_one_line_errors(tmp_path, capsys, argv):
    status, _, err = run(capsys, "bake", "cornell", "-o", str(tmp_path / "out"), *argv)
    assert status == 2 and len(err.strip().splitlines()) == 1


def test_ctrl_c_leaves_no_partial_output(tmp_path, capsys, monkeypatch):
    import patchlight.bake as bake_module

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(bake_module, "solve", interrupted)
    status, _, err = run(capsys, "bake", "cornell", "-o", str(tmp_path / "out"), "--resolution", "32", "--quiet")
    assert status == 130 and "interrupted" in err
    assert not (tmp_path / "out").exists()


def test_points_beside_triangles_are_skipped_with_a_warning(tmp_path, capsys):
    save_baked_glb(lit_quad(), tmp_path / "good.glb")
    good = (tmp_path / "good.glb").read_bytes()
    json_len = struct.unpack_from("<I", good, 12)[0]
    doc = json.loads(good[20:20 + json_len])
    mesh = doc["meshes"][0]
    mesh["primitives"].append(dict(mesh["primitives"][0], mode=0))
    (tmp_path / "mixed.gltf").write_bytes(_embed(doc, good, json_len))
    status, _, err = run(capsys, "bake", str(tmp_path / "mixed.gltf"), "-o", str(tmp_path / "out"),
                         "--resolution", "16", "--quiet")
    assert status == 0
    assert "1 point/line primitives skipped" in err


def test_sky_image_lights_an_open_plane_with_its_radiance(tmp_path, capsys):
    from patchlight.imaging.io import write_exr

    write_exr(tmp_path / "sky.exr", np.full((16, 32, 3), [0.5, 1.0, 2.0], np.float32))
    dark = lit_quad()
    dark.lights = []
    save_baked_glb(dark, tmp_path / "in.glb")
    status, _, _ = run(capsys, "bake", str(tmp_path / "in.glb"), "-o", str(tmp_path / "out"),
                       "--resolution", "16", "--sky-image", str(tmp_path / "sky.exr"), "--quiet")
    assert status == 0
    lightmap = read_exr(tmp_path / "out" / "lightmap.exr")
    lit = lightmap[lightmap.sum(axis=2) > 0]
    np.testing.assert_allclose(lit, np.broadcast_to([0.5, 1.0, 2.0], lit.shape), rtol=1e-5)


def test_ctrl_c_while_writing_leaves_the_older_bake_whole(tmp_path, capsys, monkeypatch):
    import patchlight.imaging.io as io

    out = tmp_path / "out"
    assert run(capsys, "bake", "cornell", "-o", str(out), "--resolution", "32", "--quiet")[0] == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    real = io.write_png

    def interrupted(path, pixels):
        real(path, pixels)
        raise KeyboardInterrupt

    monkeypatch.setattr(io, "write_png", interrupted)
    status, _, err = run(capsys, "bake", "cornell", "-o", str(out), "--resolution", "48", "--quiet")
    assert status == 130 and "interrupted" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert [p.name for p in tmp_path.iterdir()] == ["out"]  # no staging directory left behind


def test_a_rebake_replaces_the_whole_set_of_files(tmp_path, capsys):
    out = tmp_path / "out"
    assert run(capsys, "bake", "cornell", "-o", str(out), "--resolution", "32", "--save-passes", "--passes", "3",
               "--quiet")[0] == 0
    assert (out / "pass_03.png").exists()
    assert run(capsys, "bake", "cornell", "-o", str(out), "--resolution", "32", "--save-passes", "--passes", "2",
               "--quiet")[0] == 0
    assert sorted(p.name for p in out.glob("pass_*.png")) == ["pass_01.png", "pass_02.png"]
    assert json.loads((out / "bake.json").read_text())["passes"] == 2


@pytest.mark.parametrize("where", ["file", "file/below"])
def test_an_output_directory_that_cannot_be_made_is_refused_before_baking(tmp_path, capsys, where):
    (tmp_path / "file").write_text("in the way")
    status, _, err = run(capsys, "bake", "cornell", "-o", str(tmp_path / where), "--resolution", "32", "--quiet")
    assert status == 2 and "not a directory" in err and "Traceback" not in err


@pytest.mark.parametrize("argv, words", [(["--exposure", "nan"], "exposure"), (["--exposure", "0"], "exposure"),
                                         (["--seed", "-1"], "seed"), (["--sun-angle", "-5"], "sun angle")])
def test_out_of_range_settings_are_refused_in_one_line(tmp_path, capsys, argv, words):
    status, _, err = run(capsys, "bake", "cornell", "-o", str(tmp_path / "out"), *argv)
    assert status == 2 and words in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_an_image_sky_is_found_again_from_a_scene_glb_written_into_new_folders(tmp_path, capsys):
    from patchlight.imaging.io import write_exr

    (tmp_path / "sky").mkdir()
    write_exr(tmp_path / "sky" / "day.exr", np.full((8, 16, 3), [0.5, 1.0, 2.0], np.float32))
    dark = lit_quad()
    dark.lights = []
    save_baked_glb(dark, tmp_path / "in.glb")
    out = tmp_path / "new" / "deep" / "out"   # staged beside the nearest folder that exists
    status, _, _ = run(capsys, "bake", str(tmp_path / "in.glb"), "-o", str(out), "--resolution", "16",
                       "--sky-image", str(tmp_path / "sky" / "day.exr"), "--quiet")
    assert status == 0
    sky = load_gltf(out / "scene.glb").sky
    assert sky.kind == "image" and sky.image.shape == (8, 16, 3)
