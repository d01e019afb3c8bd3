"""Texel density per object: extras.patchlight.texelsPerUnit on a node or mesh, --density
NAME=T over it, each object's charts packed at its density (measured from the UVs made), and
bake.json reporting it."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from atlas_meshes import cube_scene, make_scene

from patchlight.atlas import uvs
from patchlight.atlas.uvs import ensure_lightmap_uvs
from patchlight.cli.main import main
from patchlight.errors import PatchlightError
from patchlight.scene.model import Objects, face_normals

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scene"))
from gltf_builder import Builder  # noqa: E402


def three_cubes(asked=(np.nan, 32.0, np.nan)):
    """Three unit cubes side by side, objects "a", "b", "c", b asking 32 texels per metre."""
    cube = cube_scene()
    positions = np.concatenate([cube.positions + [3.0 * k, 0, 0] for k in range(3)])
    indices = np.concatenate([cube.indices + 8 * k for k in range(3)])
    scene = make_scene(positions, indices)
    scene.objects = Objects(["a", "b", "c"], np.repeat(np.arange(3, dtype=np.int32), 12),
                            np.array(asked, np.float64))
    return scene


def measured_density(scene, width, height) -> np.ndarray:
    """(K,) texels per metre of each object: sqrt(its texels in UV / its area in metres)."""
    tri = scene.uv1[scene.indices].astype(np.float64) * [width, height]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    texels = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    area = face_normals(scene.positions, scene.indices)[1].astype(np.float64)
    k = scene.objects.triangle
    return np.sqrt(np.bincount(k, texels) / np.bincount(k, area))


@pytest.mark.parametrize("packer", ["xatlas", "fallback"])
def test_each_object_is_packed_at_its_own_density(packer, monkeypatch):
    if packer == "fallback":
        monkeypatch.setattr(uvs, "_xatlas_installed", lambda: False)
    scene, width, height, info = ensure_lightmap_uvs(three_cubes(), texels_per_unit=8.0, densities={"c": 16.0})
    assert info["uv_source"] == packer
    measured = measured_density(scene, width, height)
    reported = np.array([o["texels_per_unit"] for o in info["objects"]])
    assert [o["name"] for o in info["objects"]] == ["a", "b", "c"]
    np.testing.assert_allclose(measured, reported, rtol=1e-6)
    np.testing.assert_allclose(reported / reported[0], [1, 4, 2], rtol=0.05)  # charts are whole texels
    assert reported[0] == pytest.approx(8.0, rel=0.1)


def test_a_requested_resolution_keeps_the_ratios_between_objects():
    scene, width, height, info = ensure_lightmap_uvs(three_cubes(), resolution=128)
    reported = np.array([o["texels_per_unit"] for o in info["objects"]])
    np.testing.assert_allclose(reported / reported[0], [1, 2, 1], rtol=0.05)  # 32 over the base 16
    np.testing.assert_allclose(measured_density(scene, width, height), reported, rtol=1e-6)


def test_unknown_names_and_bad_densities_are_refused():
    with pytest.raises(PatchlightError, match="'d'.*no object"):
        ensure_lightmap_uvs(three_cubes(), densities={"d": 4.0})
    with pytest.raises(PatchlightError, match="texels per unit"):
        ensure_lightmap_uvs(three_cubes(), densities={"a": -1.0})


def test_a_kept_texcoord1_reports_each_objects_density_and_warns_about_asked_ones():
    again, width, _, _ = ensure_lightmap_uvs(three_cubes(), texels_per_unit=8.0)
    again.objects = Objects(["a", "b", "c"], again.objects.triangle, np.full(3, np.nan))
    _, _, _, kept = ensure_lightmap_uvs(again, resolution=width)
    np.testing.assert_allclose([o["texels_per_unit"] for o in kept["objects"]],
                               measured_density(again, width, width), rtol=1e-6)  # kept: square
    assert not kept["warnings"]
    _, _, _, asked = ensure_lightmap_uvs(again, resolution=width, densities={"a": 64.0})
    assert any("not applied" in w for w in asked["warnings"])


def two_quads_gltf(path, node_extras=None, mesh_extras=None):
    """Two 2 x 2 m floor quads, nodes "near" and "far" with meshes "near mesh" and "far mesh",
    under a uniform sky."""
    b = Builder()
    roots = []
    for k, name in enumerate(("near", "far")):
        positions = np.array([[0, 0, 0], [2, 0, 0], [2, 0, 2], [0, 0, 2]], np.float32) + [3.0 * k, 0, 0]
        primitive = b.primitive(positions, [0, 2, 1, 0, 3, 2], NORMAL=np.tile([0, 1, 0], (4, 1)).astype(np.float32))
        mesh = b.mesh(primitive, name=f"{name} mesh")
        b.doc.meshes[mesh].extras = (mesh_extras or {}).get(name) or {}
        roots.append(b.node(mesh=mesh, name=name, extras=(node_extras or {}).get(name) or {}))
    b.scene(*roots, extras={"patchlight": {"sky": {"uniform": [1.0, 1.0, 1.0]}}})
    return b.glb(path)


def test_cli_density_over_gltf_extras_reaches_bake_json(tmp_path, capsys):
    source = two_quads_gltf(tmp_path / "two.glb",
                            node_extras={"near": {"patchlight": {"texelsPerUnit": 12}}},
                            mesh_extras={"near": {"patchlight": {"texelsPerUnit": 99}},
                                         "far": {"patchlight": {"texelsPerUnit": 6}}})
    out = tmp_path / "out"
    assert main(["bake", str(source), "-o", str(out), "--texels-per-unit", "4", "--rays", "64", "--quiet"]) == 0
    objects = json.loads((out / "bake.json").read_text())["uv"]["objects"]
    density = {o["name"]: o["texels_per_unit"] for o in objects}
    assert density["near"] / density["far"] == pytest.approx(2.0, rel=0.05)  # the node's 12 over the mesh's 99
    assert main(["bake", str(source), "-o", str(out), "--texels-per-unit", "4", "--rays", "64", "--quiet",
                 "--density", "far=24"]) == 0
    objects = json.loads((out / "bake.json").read_text())["uv"]["objects"]
    density = {o["name"]: o["texels_per_unit"] for o in objects}
    assert density["far"] / density["near"] == pytest.approx(2.0, rel=0.05)
    capsys.readouterr()


@pytest.mark.parametrize("flag, message", [("far", "expected NAME=T"), ("far=x", "expected NAME=T"),
                                           ("nobody=8", "no object"), ("far=0", "density far")])
def test_cli_bad_density_flags_fail_in_one_line(tmp_path, capsys, flag, message):
    source = two_quads_gltf(tmp_path / "two.glb")
    out = tmp_path / "out"
    assert main(["bake", str(source), "-o", str(out), "--density", flag, "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not out.exists()


def test_gltf_extras_that_are_not_positive_numbers_are_refused(tmp_path):
    from patchlight.scene import load_scene

    source = two_quads_gltf(tmp_path / "two.glb", node_extras={"far": {"patchlight": {"texelsPerUnit": "big"}}})
    with pytest.raises(PatchlightError, match="node 1: extras.patchlight.texelsPerUnit"):
        load_scene(source)
