"""The lightmap through three.js's own loaders (run under node, as a three.js page runs them):
scene.glb's HDR image (encode_lightmap's .hdr, HDRLoader at the half floats the plugin asks
for) keeps 1 % precision over at least four decades of I below the peak, and lightmap.exr
reaches a three.js page through EXRLoader with its rows bottom first: upright as a picture,
upside down for glTF UVs unless texture.flipY = true (what README tells three.js users)."""
from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from patchlight.imaging.io import write_exr
from patchlight.imaging.lightmap import encode_lightmap

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
