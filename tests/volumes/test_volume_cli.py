"""`patchlight volume` and `patchlight vertexbake` end to end, and their bad-input messages."""
from __future__ import annotations

import json

import numpy as np
import pytest
from volume_scenes import floor

from patchlight.cli.main import main
from patchlight.scene import Sky
from patchlight.scene.gltf import load_gltf, save_baked_glb
from patchlight.solved import load_solved
from patchlight.volumes import read_volume
from patchlight.volumes.vertex import vertex_incident


def run(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.fixture(scope="module")
def cornell_bake(tmp_path_factory):
    out = tmp_path_factory.mktemp("bake") / "cornell"
    assert main(["bake", "cornell", "-o", str(out), "--resolution", "32", "--rays", "16", "--quiet"]) == 0
    return out


def test_volume_writes_header_data_and_stats(cornell_bake, tmp_path, capsys):
    status, stdout, _ = run(capsys, "volume", cornell_bake, "-o", tmp_path / "v", "--dims", "3,2,4", "--rays", "16", "--json")
    assert status == 0
    stats = json.loads(stdout)
    assert stats["probes"] == 24 and stats["dims"] == [3, 2, 4] and stats["rays_per_axis"] == 16
    for key in ("inside_geometry_probes", "rays_traced", "seconds", "probes_per_second", "rays_per_second"):
        assert key in stats
    assert json.loads((tmp_path / "v" / "volume.json").read_text())["probes"] == 24
    volume = read_volume(tmp_path / "v")
    assert volume.cube.shape == (6, 4, 2, 3, 3) and volume.cube.min() >= 0 and volume.cube.max() > 0
    assert sorted(p.name for p in (tmp_path / "v").iterdir()) == ["light_volume.bin", "light_volume.json", "volume.json"]


def test_volume_compact_and_spacing(cornell_bake, tmp_path, capsys):
    status, _, _ = run(capsys, "volume", cornell_bake, "-o", tmp_path / "v", "--spacing", "0.25", "--rays", "16",
                       "--compact", "--quiet", "--bounds", "0,0,0,0.5,0.5,0.5")
    assert status == 0
    header = json.loads((tmp_path / "v" / "light_volume.json").read_text())
    # probes at the centres of the 2 x 2 x 2 cells of 0.25 m that tile the box
    assert header["layout"] == "compact" and header["dims"] == [2, 2, 2] and header["spacing"] == [0.25] * 3
    np.testing.assert_allclose(header["origin"], [0.125] * 3)
    assert [s["name"] for s in header["sections"]] == ["color", "intensity", "inside", "validity"]
    assert read_volume(tmp_path / "v").cube.shape == (6, 2, 2, 2, 3)


@pytest.mark.parametrize("args, message", [
    (["--spacing", "0.0001"], r"5\d\d\d x 5\d\d\d x 5\d\d\d = [\d,]+ probes is more than the limit of 10,000,000"),
    (["--dims", "3000,3000,3000"], r"27,000,000,000 probes is more than the limit"),
    (["--bounds", "5,5,5,6,6,6"], r"--bounds 5,5,5,6,6,6: bounds lie outside the scene, whose bounds are"),
    (["--bounds", "1,2,3"], r"expected X0,Y0,Z0,X1,Y1,Z1"),
    (["--bounds", "1,1,1,0,2,2"], r"must be at least X0"),
    (["--dims", "3,x,3"], r"--dims 3,x,3: expected NX,NY,NZ"),
    (["--dims", "3,0,3"], r"--dims 3,0,3: dims must be 3 numbers, each a whole number >= 1"),
    (["--spacing", "-1"], r"--spacing -1.0: spacing must be a number > 0 \(m\)"),
    (["--rays", "0"], r"--rays 0: rays must be a whole number in 1\.\.16384"),
    (["--bounds", "0,0.2,0,0.5,0.2,0.5", "--dims", "3,3,3"], r"3 probes along Y, where the box has no extent"),
    (["--seed", "-1"], r"--seed -1: seed must be a whole number in 0\.\.4294967295"),
    (["--seed", "4294967296"], r"--seed 4294967296: seed must be a whole number in 0\.\.4294967295"),
    (["--spacing", "1e-320"], r"--spacing 1e-320: spacing is too small: more than 1e308 probes along X alone \(0.556 m\), more than the limit"),
    (["--spacing", "1e-8"], r"--spacing 1e-08: spacing is too small: 5.59e\+07 probes along Z alone \(0.5592 m\), more than the limit"),
    (["--bounds", "-1e300,0,0,1e300,1,1", "--dims", "2,2,2"], r"too large for float32 positions"),
])
def test_volume_bad_input_is_one_line_and_writes_nothing(cornell_bake, tmp_path, capsys, args, message):
    status, _, err = run(capsys, "volume", cornell_bake, "-o", tmp_path / "v", *args)
    assert status == 2
    assert err.count("\n") == 1 and err.startswith("patchlight: error: ")
    assert __import__("re").search(message, err), err
    assert not (tmp_path / "v").exists()


def test_volume_refuses_a_directory_that_is_not_a_bake(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    status, _, err = run(capsys, "volume", tmp_path / "empty", "-o", tmp_path / "v")
    assert status == 2 and "not a complete bake" in err and err.count("\n") == 1


@pytest.fixture
def no_baking(monkeypatch):
    """Any attempt to load or bake a scene fails the test: errors must come before the work."""
    def refuse(*args, **kwargs):
        raise AssertionError("the command started working before checking its output")

    monkeypatch.setattr("patchlight.solved.load_solved", refuse)


@pytest.mark.parametrize("command, output", [("volume", "blocker/v"), ("vertexbake", "blocker/out.glb")])
def test_an_output_that_cannot_be_made_is_refused_before_any_work(cornell_bake, tmp_path, capsys, no_baking,
                                                                  command, output):
    (tmp_path / "blocker").write_text("a file, not a directory")
    status, _, err = run(capsys, command, cornell_bake, "-o", tmp_path / output)
    assert status == 2 and "is a file, not a directory" in err and err.count("\n") == 1


def test_a_volume_written_over_another_replaces_it_as_a_set(cornell_bake, tmp_path, capsys):
    out = tmp_path / "v"
    assert run(capsys, "volume", cornell_bake, "-o", out, "--dims", "2,2,2", "--rays", "4", "--quiet")[0] == 0
    assert run(capsys, "volume", cornell_bake, "-o", out, "--dims", "3,2,2", "--rays", "4", "--quiet",
               "--compact")[0] == 0
    assert read_volume(out).grid.dims == (3, 2, 2)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v"]  # no staging directory left
    assert json.loads((out / "volume.json").read_text())["layout"] == "compact"


def test_vertex_colours_survive_the_gltf_round_trip(cornell_bake, tmp_path, capsys):
    out = tmp_path / "vc.glb"
    status, _, _ = run(capsys, "vertexbake", cornell_bake, "-o", out, "--quiet")
    assert status == 0
    colors = load_gltf(out).colors
    expected = vertex_incident(load_solved(cornell_bake))
    scale = glb_json(out)["extras"]["patchlight"]["vertexLight"]["colorScale"]
    assert scale == pytest.approx(float(expected.max())) and scale > 1.0  # glTF's COLOR_0 stays within 0..1
    assert colors.min() >= 0.0 and colors.max() <= 1.0
    np.testing.assert_allclose(colors[:, :3] * scale, expected, rtol=1e-6, atol=1e-7 * scale)  # the HDR light restored
    np.testing.assert_array_equal(colors[:, 3], 1.0)
    assert_every_material_unlit(out)


def glb_json(path) -> dict:
    data = path.read_bytes()
    return json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])


def assert_every_material_unlit(path):
    """The .glb at `path` marks each material KHR_materials_unlit, so a glTF viewer draws base
    colour x COLOR_0 without lighting it again; optional, so others still load it."""
    import pygltflib

    doc = pygltflib.GLTF2.load_from_bytes(path.read_bytes())
    assert doc.materials and all((m.extensions or {}).get("KHR_materials_unlit") == {} for m in doc.materials)
    assert "KHR_materials_unlit" in doc.extensionsUsed
    assert "KHR_materials_unlit" not in (doc.extensionsRequired or [])
    assert all(p.attributes.COLOR_0 is not None for mesh in doc.meshes for p in mesh.primitives)


def test_vertex_colours_of_an_open_floor_under_a_uniform_sky_are_the_sky(tmp_path, capsys):
    """An unoccluded floor under a sky of radiance L receives I = L at every vertex; the file's own
    vertex colours multiply it."""
    scene = floor(1.0, sky=Sky.uniform((0.2, 0.4, 0.8)))
    scene.colors = np.tile(np.array([[0.5, 1.0, 1.0, 1.0]], np.float32), (len(scene.positions), 1))
    save_baked_glb(scene, tmp_path / "floor.glb")
    status, stdout, _ = run(capsys, "vertexbake", tmp_path / "floor.glb", "-o", tmp_path / "out.glb", "--json")
    assert status == 0 and json.loads(stdout)["vertices"] > 0
    colors = load_gltf(tmp_path / "out.glb").colors
    np.testing.assert_allclose(colors, np.tile([0.1, 0.4, 0.8, 1.0], (len(colors), 1)), rtol=1e-3)
    assert glb_json(tmp_path / "out.glb")["extras"]["patchlight"]["vertexLight"]["colorScale"] == 1.0  # light below 1
    assert_every_material_unlit(tmp_path / "out.glb")
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary file left


def test_vertexbake_help_says_the_materials_are_unlit(capsys):
    status, out, _ = run(capsys, "vertexbake", "--help")
    assert status == 0
    assert "KHR_materials_unlit" in out and "base colour x COLOR_0" in out


@pytest.mark.parametrize("output, message", [("out.png", "must be a .glb file"), ("missing/out.glb", "does not exist")])
def test_vertexbake_bad_output(cornell_bake, tmp_path, capsys, output, message):
    status, _, err = run(capsys, "vertexbake", cornell_bake, "-o", tmp_path / output)
    assert status == 2 and message in err and err.count("\n") == 1


def test_render_finds_the_volume_in_the_bake_directory(cornell_bake, tmp_path, capsys):
    """`patchlight volume BAKE -o BAKE` puts the volume beside the lightmap, where render and view look."""
    import shutil

    from patchlight.imaging.io import read_exr

    bake = tmp_path / "bake"
    shutil.copytree(cornell_bake, bake)
    status, _, _ = run(capsys, "render", bake, "--model", "ambient-cube", "--size", "32x32", "-o", tmp_path / "sky.exr")
    assert status == 0  # no volume yet: the sky (here the default ambient) as one probe
    assert run(capsys, "volume", bake, "-o", bake, "--dims", "3,3,3", "--rays", "16", "--quiet")[0] == 0
    for name, extra in (("squared.exr", []), ("naive.exr", ["--naive-weights"])):
        status, _, _ = run(capsys, "render", bake, "--model", "ambient-cube", "--size", "32x32", "-o", tmp_path / name, *extra)
        assert status == 0
    squared, naive = read_exr(tmp_path / "squared.exr"), read_exr(tmp_path / "naive.exr")
    assert squared.max() > 0 and naive.sum() > squared.sum()
    assert not np.allclose(squared, read_exr(tmp_path / "sky.exr"), rtol=0.05)


def test_render_with_a_missing_volume_says_so(cornell_bake, tmp_path, capsys):
    status, _, err = run(capsys, "render", cornell_bake, "--model", "ambient-cube", "--volume", tmp_path,
                         "-o", tmp_path / "x.png")
    assert status == 2 and "no light_volume.json" in err and err.count("\n") == 1


def test_vertices_under_a_wall_take_the_light_of_the_visible_floor():
    """A floor running under a solid wall: the bake leaves the texels deep under the wall black,
    yet the floor's vertices there get the light the visible floor shows, extrapolated."""
    from patchlight.bake import bake
    from patchlight.config import BakeSettings
    from patchlight.scene import SceneBuilder
    from patchlight.shading.textures import sample_bilinear
    from patchlight.solved import SolvedScene

    b = SceneBuilder()
    m = b.material("grey", (0.5, 0.5, 0.5))
    b.quad([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]], m, (0, 1, 0))
    b.box((-3, 0, -3), (-0.5, 2, 3), m)
    result = bake(b.scene("under", sky=Sky.uniform((1, 1, 1))), BakeSettings(resolution=64, rays=64))
    solved = SolvedScene.from_bake(result, "under")
    scene = solved.scene
    floor = np.unique(scene.indices[np.abs(scene.positions[scene.indices][:, :, 1]).max(axis=1) < 1e-6])
    floor = floor[np.abs(scene.positions[floor, 0]) == 2]  # the floor quad's corners at x = -2 and x = 2
    under = floor[scene.positions[floor, 0] < 0]
    assert sample_bilinear(solved.lightmap, scene.uv1[under], wrap="clamp").max() < 0.05  # black there
    light = vertex_incident(solved)
    assert light[under].min() > 0.3
    assert light[floor].max() < 1.1  # a linear fit of a concave falloff overshoots a little, no more


def test_the_bake_directory_keeps_the_inside_mask_vertexbake_uses(tmp_path):
    """lightmap.exr's alpha is the bake's validity: read back, it equals the texels the bake
    found with light of their own, and the vertex colours from the directory are the ones
    from the bake in memory (no ray traced again)."""
    from patchlight.bake import bake
    from patchlight.bakedir import write_bake
    from patchlight.config import BakeSettings
    from patchlight.scene import SceneBuilder
    from patchlight.solved import SolvedScene

    b = SceneBuilder()
    m = b.material("grey", (0.5, 0.5, 0.5))
    b.quad([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]], m, (0, 1, 0))
    b.box((-3, 0, -3), (-0.5, 2, 3), m)
    settings = BakeSettings(resolution=32, rays=16)
    result = bake(b.scene("under", sky=Sky.uniform((1, 1, 1))), settings)
    assert 0 < result.valid.sum() < (result.patches.index >= 0).sum()  # some texels lie inside the box
    write_bake(result, tmp_path / "under", settings)
    solved = load_solved(tmp_path / "under")
    np.testing.assert_array_equal(solved.valid, result.valid)
    np.testing.assert_allclose(vertex_incident(solved), vertex_incident(SolvedScene.from_bake(result, "under")),
                               rtol=1e-6, atol=1e-7)


def test_volume_settings_refuse_a_seed_numpy_would_choke_on():
    from patchlight.errors import PatchlightError
    from patchlight.volumes import VolumeSettings

    for seed in (-1, 2**32, 1.5):
        with pytest.raises(PatchlightError, match=r"^seed: .* must be a whole number in 0\.\.4294967295$"):
            VolumeSettings(seed=seed)
    assert VolumeSettings(seed=2**32 - 1).seed == 2**32 - 1
    for rays in (0, 16385, 2.5):
        with pytest.raises(PatchlightError, match=r"^rays: .* must be a whole number in 1\.\.16384 \(rays / axis\)$"):
            VolumeSettings(rays=rays)
