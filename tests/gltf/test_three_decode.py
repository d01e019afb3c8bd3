"""The lightmap through three.js's own loaders (run under node, as a three.js page runs them):
scene.glb's HDR image (encode_lightmap's .hdr, HDRLoader at the half floats the plugin asks
for) keeps 1 % precision over at least four decades of I below the peak, and lightmap.exr
reaches a three.js page through EXRLoader with its rows bottom first: upright as a picture,
upside down for glTF UVs unless texture.flipY = true (what README tells three.js users);
scene.glb's directional maps (half-float EXRs) reach it as the bake wrote them, to half
precision."""
from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from patchlight.bakedir import read_directional
from patchlight.cli.main import main
from patchlight.imaging.io import write_exr
from patchlight.imaging.lightmap import encode_lightmap
from patchlight.scene.gltf.container import split_glb

from validator import REPO

DECODE = Path(__file__).with_name("decode.mjs")

pytestmark = pytest.mark.skipif(shutil.which("node") is None or not (REPO / "node_modules/three").is_dir(),
                                reason="node or node_modules/three is missing (tools/setup_browser.sh)")


def three_decode(kind: str, path: Path, precision: str = "half") -> np.ndarray:
    """(H, W, 3) texels in the order the loader hands them to WebGL (row 0: t = 0)."""
    out = path.with_suffix(".bin")
    subprocess.run(["node", str(DECODE), kind, str(path), precision, str(out)], check=True, timeout=120)
    head, _, body = out.read_bytes().partition(b"\n")
    meta = json.loads(head)
    assert meta["flipY"] is (kind == "hdr")  # HDRLoader: flip on upload; GLTFLoader turns it off
    return np.frombuffer(body, np.float32).reshape(meta["height"], meta["width"], 4)[..., :3]


def test_scene_glb_hdr_keeps_one_percent_over_four_decades(tmp_path):
    rng = np.random.default_rng(3)
    peak = 50.0
    level = peak * 10.0 ** -rng.uniform(0, 4, (128, 128, 1))  # four decades below the peak
    colour = rng.uniform(0.3, 1.0, (128, 128, 3))
    colour /= colour.max(axis=-1, keepdims=True)
    lightmap = (level * colour).astype(np.float32)
    lightmap[0, 0] = peak
    encoded = encode_lightmap(lightmap)
    (tmp_path / "lightmap.hdr").write_bytes(encoded.hdr)
    decoded = three_decode("hdr", tmp_path / "lightmap.hdr") * encoded.scale
    error = np.abs(decoded - lightmap) / lightmap
    for decade in range(4):
        rows = (lightmap.max(axis=-1) <= peak * 10.0 ** -decade) & (lightmap.max(axis=-1) > peak * 10.0 ** -(decade + 1))
        assert np.percentile(error[rows], 99) < 0.0105, decade
        assert np.median(error[rows]) < 0.003, decade


def test_lightmap_exr_reaches_three_js_bottom_row_first(tmp_path):
    lightmap = np.zeros((4, 6, 3), np.float32)
    lightmap[0] = 1.0  # the top row (v = 0)
    write_exr(tmp_path / "lightmap.exr", lightmap)
    texels = three_decode("exr", tmp_path / "lightmap.exr")
    np.testing.assert_array_equal(texels, lightmap[::-1])


@pytest.mark.parametrize("mode", ["sh", "dominant"])
def test_scene_glb_directional_maps_reach_three_js_at_half_precision(tmp_path, mode):
    """scene.glb's directional textures, decoded by three.js's EXRLoader at half floats, are the
    bake's lightmap_sh.exr / lightmap_dir.exr (SH divided by the lightmap's scale) to half
    precision, top row first once flipped as the plugin flips them."""
    out = tmp_path / "bake"
    assert main(["bake", "room", "-o", str(out), "--resolution", "64", "--rays", "32", "--passes", "2",
                 "--directional", mode, "--quiet"]) == 0
    data = (out / "scene.glb").read_bytes()
    text, blob = split_glb(data, out / "scene.glb")
    doc = json.loads(text)
    reference = doc["materials"][0]["extensions"]["PATCHLIGHT_lightmap_directional"]
    assert reference["scale"] == (doc["extras"]["patchlight"]["lightmap"]["scale"] if mode == "sh" else 1.0)
    expected = read_directional(out).maps / reference["scale"]
    for k, texture_info in enumerate(reference["maps"]):
        image = doc["images"][doc["textures"][texture_info["index"]]["extensions"]["PATCHLIGHT_texture_exr"]["source"]]
        view = doc["bufferViews"][image["bufferView"]]
        (tmp_path / f"map{k}.exr").write_bytes(blob[view.get("byteOffset", 0):view.get("byteOffset", 0) + view["byteLength"]])
        texels = three_decode("exr", tmp_path / f"map{k}.exr")[::-1]  # flipY, as the plugin sets it
        np.testing.assert_allclose(texels, expected[k], rtol=2.0 ** -11, atol=2.0 ** -24)
