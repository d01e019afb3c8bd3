"""Several lightmap atlases (--max-atlas): charts that do not fit one atlas are moved, whole
and unchanged in shape, onto several; each object and material on one atlas; lightmap_0.exr,
lightmap_1.exr, ... and one texture per atlas in scene.glb; everything that reads a bake reads
the atlases stacked, as the bake made them."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pygltflib as gl
import pytest
from test_density import three_cubes

from patchlight import bakedir
from patchlight.atlas.raster import rasterize
from patchlight.atlas.uvs import ensure_lightmap_uvs
from patchlight.cli.main import main
from patchlight.errors import PatchlightError
from patchlight.scene.model import atlas_uv1, stacked_uv1, triangle_atlas
from patchlight.solved import load_solved

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scene"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "gltf"))
from gltf_builder import Builder  # noqa: E402
from validator import problems, validate, validator_missing  # noqa: E402

QUICK = ["--rays", "64", "--texels-per-unit", "6", "--quiet", "--no-adaptive"]


def test_charts_move_whole_onto_atlases_and_the_uvs_round_trip_bit_for_bit():
    one, width, height, info = ensure_lightmap_uvs(three_cubes(), texels_per_unit=30.0)
    paged, w, h, paged_info = ensure_lightmap_uvs(three_cubes(), texels_per_unit=30.0, max_atlas=128)
    assert info["atlases"] == {"count": 1, "width": width, "height": height} and one.atlases == 1
    assert paged.atlases == 3 and paged_info["atlases"] == {"count": 3, "width": w, "height": h // 3}
    assert max(w, h // 3) <= 128 < max(width, height)
    # the same charts: the same texels, moved by whole texels
    assert len(rasterize(paged, w, h)[0]) == len(rasterize(one, width, height)[0])
    atlas = triangle_atlas(paged)
    for k in range(3):  # each cube (object) lies on one atlas
        assert len(set(atlas[paged.objects.triangle == k])) == 1
    local, vertex_atlas = atlas_uv1(paged.uv1, 3)
    assert local.min() > 0 and local.max() < 1
    assert stacked_uv1(local, vertex_atlas, 3).tobytes() == paged.uv1.tobytes()


def test_an_object_too_big_for_one_atlas_and_bad_limits_are_refused():
    with pytest.raises(PatchlightError, match="'a' \\(material 'default'\\) need more than one 64x64 atlas"):
        ensure_lightmap_uvs(three_cubes(), texels_per_unit=40.0, max_atlas=64)
    with pytest.raises(PatchlightError, match="larger than the atlas limit 128"):
        ensure_lightmap_uvs(three_cubes(), resolution=256, max_atlas=128)


@pytest.mark.parametrize("value", ["32", "9000", "1.5"])
def test_cli_refuses_max_atlas_outside_its_range_in_one_line(tmp_path, capsys, value):
    status = main(["bake", "cornell", "-o", str(tmp_path / "out"), "--max-atlas", value, "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and "max-atlas" in err[0].replace("_", "-"), err
    assert not (tmp_path / "out").exists()


def boxes_level(path: Path) -> Path:
    """An 8 x 8 m floor and 16 boxes of 1.5 m (two meshes, red and white, each drawn by 8
    nodes) under a sun and a sky: at 6 texels per metre its charts need three 96 x 96 atlases."""
    b = Builder()
    b.accessor = bounded(b.accessor)  # POSITION must carry its bounds
    b.doc.materials = [gl_material("floor", [0.7, 0.7, 0.7, 1]), gl_material("red", [0.8, 0.2, 0.2, 1]),
                       gl_material("white", [0.8, 0.8, 0.8, 1])]
    floor = np.array([[0, 0, 0], [8, 0, 0], [8, 0, 8], [0, 0, 8]], np.float32)
    up = np.tile(np.float32([0, 1, 0]), (4, 1))
    roots = [b.node(name="floor", mesh=b.mesh(b.primitive(floor, [0, 2, 1, 0, 3, 2], material=0, NORMAL=up),
                                                name="floor"))]
    positions, normals, indices = box(1.5)
    meshes = [b.mesh(b.primitive(positions, indices, material=m, NORMAL=normals), name=f"{name} box")
              for m, name in ((1, "red"), (2, "white"))]
    for k in range(16):
        x, z = 1.3 + 1.8 * (k % 4), 1.3 + 1.8 * (k // 4)
        roots.append(b.node(name=f"box {k}", mesh=meshes[k % 2], translation=[x, 0.0, z]))
    b.doc.extensionsUsed = ["KHR_lights_punctual", "KHR_materials_specular"]
    b.doc.extensions = {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 683.0 * 3}]}}
    roots.append(b.node(name="sun", rotation=[-0.3535534, 0.3535534, 0.1464466, 0.8535534],
                        extensions={"KHR_lights_punctual": {"light": 0}}))
    b.scene(*roots, extras={"patchlight": {"sky": {"uniform": [0.3, 0.35, 0.4]}}})
    return b.glb(path)


def bounded(accessor):
    """Builder.accessor giving every float VEC3 (POSITION, NORMAL) its min and max."""
    def make(values, *args, **kwargs):
        shape = np.shape(values)
        return accessor(values, *args, bounds=len(shape) == 2 and shape[1] == 3, **kwargs)
    return make


def gl_material(name, colour):
    pbr = gl.PbrMetallicRoughness(baseColorFactor=colour, metallicFactor=0.0)
    return gl.Material(name=name, pbrMetallicRoughness=pbr, extensions={"KHR_materials_specular": {"specularFactor": 0.0}})


def box(size):
    """(24, 3) positions, (24, 3) normals and (36,) indices of a box on the ground, flat faces."""
    positions, normals, indices = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            normal = np.zeros(3)
            normal[axis] = sign
            u, v = np.roll(np.eye(3), 1, axis=0)[axis], np.roll(np.eye(3), 2, axis=0)[axis]
            centre = 0.5 + 0.5 * normal
            corners = [centre + 0.5 * (a * u + b * v) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            base = len(positions)
            positions += corners
            normals += [normal] * 4
            quad = [0, 1, 2, 0, 2, 3] if np.dot(np.cross(u, v), normal) > 0 else [0, 2, 1, 0, 3, 2]
            indices += [base + q for q in quad]
    positions = (np.array(positions) - [0.5, 0.0, 0.5]) * size
    return positions.astype(np.float32), np.array(normals, np.float32), np.array(indices, np.uint32)


@pytest.fixture(scope="module")
def bakes(tmp_path_factory):
    """The boxes level baked in three 96 x 96 atlases and in one, at the same density."""
    root = tmp_path_factory.mktemp("atlases")
    level = boxes_level(root / "boxes.glb")
    assert main(["bake", str(level), "-o", str(root / "three"), "--max-atlas", "96", *QUICK]) == 0
    assert main(["bake", str(level), "-o", str(root / "one"), *QUICK]) == 0
    return root


def test_a_level_in_three_atlases_writes_three_lightmaps_and_reports_them(bakes):
    three = bakes / "three"
    summary = json.loads((three / "bake.json").read_text())
    atlases = summary["atlases"]
    assert atlases["count"] == 3 and atlases["files"] == ["lightmap_0.exr", "lightmap_1.exr", "lightmap_2.exr"]
    assert max(atlases["width"], atlases["height"]) <= 96 and min(atlases["texels_used"]) > 0
    assert summary["resolution"] == [atlases["width"], 3 * atlases["height"]]
    assert all((three / name).is_file() for name in atlases["files"]) and not (three / "lightmap.exr").exists()
    assert set(atlases["files"]) <= set(summary["files"])
    one = json.loads((bakes / "one" / "bake.json").read_text())
    assert one["atlases"]["count"] == 1 and (bakes / "one" / "lightmap.exr").is_file()
    assert sum(atlases["texels_used"]) == one["atlases"]["texels_used"][0] == one["patches"] == summary["patches"]


def test_each_material_references_the_texture_of_its_own_atlas(bakes):
    from patchlight.scene.gltf.container import split_glb

    path = bakes / "three" / "scene.glb"
    doc = json.loads(split_glb(path.read_bytes(), path)[0])
    textures = doc["extras"]["patchlight"]["lightmap"]["textures"]
    assert len(set(textures)) == 3
    used = {m["extensions"]["MOZ_lightmap"]["index"] for m in doc["materials"]}
    assert used == set(textures)  # every atlas is referenced
    names = [m["name"] for m in doc["materials"]]
    assert any("(atlas" in name for name in names)  # a material on two atlases got a copy
    scene = bakedir.read_scene(bakes / "three")  # TEXCOORD_1 per atlas, stacked again
    lightmap = bakedir.read_lightmap(bakes / "three")
    texels = bakedir.read_texels(bakes / "three")
    assert scene.atlases == 3 and lightmap.shape[:2] == texels.status.shape
    patches, _ = rasterize(scene, lightmap.shape[1], lightmap.shape[0])
    covered = np.zeros(texels.status.shape, bool)
    covered[patches.texel_y, patches.texel_x] = True
    np.testing.assert_array_equal(covered, texels.status > 0)  # the same texels as the bake's


def object_means(bake: Path) -> np.ndarray:
    """(objects, 3) mean incident light of each object over 64 random points per triangle."""
    solved = load_solved(bake)
    scene = solved.scene
    rng = np.random.default_rng(3)
    tri = np.repeat(np.arange(scene.n_triangles), 64)
    u, v = rng.random(len(tri)), rng.random(len(tri))
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    light = solved.incident(tri, u.astype(np.float32), v.astype(np.float32))
    node = scene.provenance.triangle_node[tri]
    return np.stack([light[node == n].mean(axis=0) for n in np.unique(node)])


def test_three_atlases_give_the_light_of_one(bakes):
    """The same charts, moved: the same texels (as many gathered, as many inside), the direct
    light alike, and the lightmaps agree up to the gather's noise (its ray pattern is seeded by
    patch number, and the numbers differ): each object's mean within 1 % (measured: 0.3 %)."""
    three, one = object_means(bakes / "three"), object_means(bakes / "one")
    texels = [bakedir.read_texels(bakes / name) for name in ("three", "one")]
    np.testing.assert_array_equal(*[np.bincount(t.status.ravel(), minlength=4)[1:] for t in texels])
    np.testing.assert_allclose(*[t.passes[0][t.status > 0].astype(np.float64).mean(axis=0) for t in texels],
                               rtol=1e-4)  # pass 1: direct light and sky
    np.testing.assert_allclose(three, one, rtol=0.01)
    assert np.ptp(one[:, 1]) > 0.05 * one[:, 1].max()  # objects differ: a wrong atlas would show


def test_render_volume_groundmap_vertexbake_and_viewer_read_three_atlases(bakes, tmp_path):
    from PIL import Image

    pictures = {}
    for name in ("three", "one"):
        out = tmp_path / f"{name}.png"
        assert main(["render", str(bakes / name), "--model", "lightmap", "--size", "48x32", "--exposure", "10",
                     "-o", str(out)]) == 0
        pictures[name] = np.asarray(Image.open(out), np.float64)
    difference = pictures["three"] - pictures["one"]  # 8-bit levels: the gather's noise, no bias
    assert np.abs(difference).mean() < 3 and abs(difference.mean()) < 1.5  # measured 1.9 and 0.8
    assert main(["volume", str(bakes / "three"), "-o", str(tmp_path / "volume"), "--spacing", "2.5",
                 "--rays", "32", "--quiet"]) == 0
    assert main(["groundmap", str(bakes / "three"), "-o", str(tmp_path / "ground"), "--size", "16", "--quiet"]) == 0
    assert main(["vertexbake", str(bakes / "three"), "-o", str(tmp_path / "vertex.glb"), "--quiet"]) == 0
    from patchlight.inputs import open_input

    target, _ = open_input(str(bakes / "three")).target()  # what the viewer shows: the atlases stacked
    assert target.lightmap.shape[:2] == target.texels.status.shape and target.scene.atlases == 3
    from patchlight.viewer.bundle import _Packer, texels_bundle

    texels = texels_bundle(_Packer(), target.texels, target.bake_dir)  # the page's checker legend
    assert len(texels["objects"]) == 17  # the floor and 16 boxes


def test_three_js_shows_each_material_with_its_own_atlas(browser, bakes, tmp_path):
    """scene.glb through GLTFLoader and the plugin (each material's MOZ_lightmap texture, its
    per-atlas TEXCOORD_1) looks like the CPU renderer on the stacked atlases."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "viewer"))
    from browser_support import three_missing
    from test_gltf_plugin import cpu_and_three, smooth_difference

    if three_missing():
        pytest.skip(three_missing())
    cpu, gpu, materials = cpu_and_three(browser, bakes / "three", tmp_path)
    assert materials and all(m["lightMap"] for m in materials.values()), materials
    assert smooth_difference(cpu, gpu, "three atlases: plugin vs CPU") <= 2


def test_the_viewer_page_lays_atlases_out_as_a_grid_that_fits_its_texture_limit(browser, bakes, tmp_path):
    """The page's own view under a texture limit (?max-texture=N) below the stacked atlases'
    height (3 h) but of two atlases each way: the atlases as a 2 x 2 grid, the lightmap model
    as the CPU renderer draws it (mean < 1/255, p99 < 4/255, as every model of the page), and
    the surfaces' texel overlays, checker and pass 1 as the page draws them stacked; under one
    atlas's size no grid fits, and the page says so in one line."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "viewer"))
    from browser_support import difference, three_missing

    from patchlight.inputs import open_input
    from patchlight.render import Renderer, target_settings
    from patchlight.render.output import display_pixels
    from patchlight.viewer.app import make_server

    if three_missing():
        pytest.skip(three_missing())
    target, _ = open_input(str(bakes / "three")).target()
    height, width = target.lightmap.shape[0] // 3, target.lightmap.shape[1]
    limit = 2 * max(width, height)
    assert limit < 3 * height  # the stacked atlases do not fit, a 2 x 2 grid does
    renderer = Renderer(target)
    camera = renderer.default_camera()
    shown = {"model": "lightmap", "camera": camera.to_json(), "width": 96, "height": 96, "exposure": 10.0}
    specs = [{"name": "lightmap", **shown}, {"name": "charts", "overlay": "charts", **shown},
             {"name": "status", "overlay": "adaptive", **shown}, {"name": "pass1", "overlay": "light", "pass": 1, **shown},
             {"name": "checker", "overlay": "charts", "checker": True, **shown}]
    for name in ("grid", "stacked", "refused"):
        (tmp_path / name).mkdir()
    (tmp_path / "refused" / "cases.json").write_text("[]")
    with make_server(target, target_settings(target, model="lightmap"), exposure=10.0) as server:
        grid, grid_log = browser.cases(f"{server.url}?max-texture={limit}", specs, tmp_path / "grid")
        stacked, stacked_log = browser.cases(server.url, specs, tmp_path / "stacked")
        refused = browser.run("cases", f"{server.url}?max-texture={max(width, height) - 1}", tmp_path / "refused",
                              tmp_path / "refused" / "cases.json", ready="error")
    assert grid_log["atlas_grid"] == {"atlases": 3, "cols": 2, "rows": 2, "max_size": limit}
    assert stacked_log["atlas_grid"]["cols"] == 1 and stacked_log["atlas_grid"]["rows"] == 3
    cpu = renderer.render(target_settings(target, model="lightmap"), camera, 96, 96)
    mean, p99 = difference(grid["lightmap"], display_pixels(cpu.radiance, 10.0), cpu.covered)
    print(f"grid page vs CPU: mean {mean:.3f}/255, p99 {p99:.1f}/255")
    assert mean < 1 and p99 < 4
    for name in ("charts", "status", "pass1", "checker"):
        differ = np.any(grid[name] != stacked[name], axis=-1)
        print(f"{name}: grid vs stacked page, {differ.mean():.2%} of the pixels differ")
        # a pixel centre on a texel border (the checker's texels, thinner than a pixel on the
        # receding walls) may take either texel: it shows what a pixel near it shows stacked
        # (over the charts' flat colours)
        assert differ.mean() < 0.05 and all(shows_a_neighbour(grid[name], stacked[name], y, x)
                                            for y, x in zip(*np.nonzero(differ))), name
    assert np.ptp(grid["charts"][..., :3].reshape(-1, 3), axis=0).max() > 100  # many charts' colours
    assert "3 lightmap atlases of" in refused["stats"] and "largest texture" in refused["stats"], refused
    assert "\n" not in refused["stats"].strip()


def shows_a_neighbour(picture: np.ndarray, other: np.ndarray, y: int, x: int) -> bool:
    """Whether pixel (y, x) of picture (H, W, 4) uint8 is within 4/255 of a pixel at most 2
    away in other."""
    near = other[max(0, y - 2):y + 3, max(0, x - 2):x + 3].reshape(-1, 4).astype(int)
    return bool(np.any(np.all(np.abs(near - picture[y, x]) <= 4, axis=-1)))


def test_a_scene_glb_of_three_atlases_bakes_again_on_its_own_uvs_and_validates(bakes):
    """Re-baking scene.glb keeps its TEXCOORD_1, stacked again: the same three atlases and
    texels; the earlier bake's lightmap textures get the new images. The Khronos validator
    finds no error in either file."""
    from patchlight.scene.gltf.container import split_glb

    again = bakes / "again"
    assert main(["bake", str(bakes / "three" / "scene.glb"), "-o", str(again), "--max-atlas", "96", *QUICK]) == 0
    first, second = (json.loads((bakes / name / "bake.json").read_text()) for name in ("three", "again"))
    assert second["uv"]["uv_source"] == "TEXCOORD_1" and second["atlases"] == first["atlases"]
    doc = json.loads(split_glb((again / "scene.glb").read_bytes(), again / "scene.glb")[0])
    assert [t["name"] for t in doc["textures"]].count("patchlight_lightmap") == 3
    reason = validator_missing()
    if reason:
        pytest.skip(reason)
    for report in validate(bakes / "three" / "scene.glb", again / "scene.glb"):
        assert problems(report) == [], report["file"]


def test_directional_maps_of_three_atlases_are_three_files_read_back_stacked(tmp_path):
    from patchlight.shading.directional import DirectionalLightmap

    maps = np.random.default_rng(5).normal(size=(4, 3 * 6, 7, 3)).astype(np.float32)
    bakedir.write_directional(tmp_path, DirectionalLightmap("sh", maps), atlases=3)
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"lightmap_sh_{k}.exr" for k in range(3)]
    (tmp_path / bakedir.MARKER).write_text(json.dumps({"atlases": {"count": 3}}))
    assert np.array_equal(bakedir.read_directional(tmp_path).maps, maps)
    (tmp_path / bakedir.MARKER).write_text(json.dumps({"atlases": {"count": 0}}))
    with pytest.raises(PatchlightError, match="atlases count 0"):
        bakedir.read_directional(tmp_path)


def test_a_directional_bake_of_three_atlases_gives_each_material_its_atlas_maps(bakes, tmp_path):
    """--directional sh over three atlases: lightmap_sh_0..2.exr, and in scene.glb each
    material's PATCHLIGHT_lightmap_directional names its own atlas's EXRs (L0 = that file's
    L0 / scale, to half-float precision); the validator finds no error."""
    from patchlight.imaging.io import read_exr, read_exr_layers
    from patchlight.scene.gltf.container import split_glb

    out = bakes / "directional"
    assert main(["bake", str(bakes / "boxes.glb"), "-o", str(out), "--max-atlas", "96", "--directional", "sh",
                 *QUICK]) == 0
    assert all((out / f"lightmap_sh_{k}.exr").is_file() for k in range(3))
    text, blob = split_glb((out / "scene.glb").read_bytes(), out / "scene.glb")
    doc = json.loads(text)
    atlas_of = {t: k for k, t in enumerate(doc["extras"]["patchlight"]["lightmap"]["textures"])}
    scale = doc["extras"]["patchlight"]["lightmap"]["scale"]
    for material in doc["materials"]:
        atlas = atlas_of[material["extensions"]["MOZ_lightmap"]["index"]]
        first = doc["textures"][material["extensions"]["PATCHLIGHT_lightmap_directional"]["maps"][0]["index"]]
        assert first["name"].endswith(f"_atlas{atlas}")
        image = doc["images"][first["extensions"]["PATCHLIGHT_texture_exr"]["source"]]
        view = doc["bufferViews"][image["bufferView"]]
        (tmp_path / "l0.exr").write_bytes(blob[view.get("byteOffset", 0):view.get("byteOffset", 0) + view["byteLength"]])
        l0 = read_exr_layers(out / f"lightmap_sh_{atlas}.exr", ("L0",))[0]
        np.testing.assert_allclose(read_exr(tmp_path / "l0.exr"), l0 / scale, rtol=2e-3, atol=1e-6)
    reason = validator_missing()
    if reason:
        pytest.skip(reason)
    report, = validate(out / "scene.glb")
    assert problems(report) == []
