"""Which encoding of the directional lightmap survives three.js's own loaders: the error of the
lightmap-directional model's light, not of the texels.

Bakes the room (`--directional sh` and `dominant`, 128 x 128), encodes the maps with every
candidate, decodes them as a three.js page would (EXRLoader / HDRLoader under node, at the half
floats they hand WebGL, or at float; 8-bit PNGs as the GPU samples them: value / 255) and
evaluates `shading.directional.directional_light` with the decoded maps for normals tilted
from the surface's own by up to 40 degrees (random azimuth), against the same with the bake's
float maps. Prints, over the valid texels brighter than 1 % of the peak, the median, 99th
percentile and largest relative error of the light per channel, and the bytes the maps add.

Candidates: the maps as they are (SH divided by the lightmap's scale) in a ZIP-compressed EXR,
half or float; and, for the two 8-bit-or-RGBE formats, which hold no negative values, the
maps made relative: SH as c1 / c0 per channel mapped 0.5 + r / (2 sqrt 3) (|c1| <= sqrt 3 c0
for any light, and the model's ratio does not depend on c0), the dominant direction as
0.5 + 0.5 d. Needs node and `npm ci`. Run by hand:
`.venv/bin/python bench/bench_directional_encoding.py`.
"""
from __future__ import annotations

import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.imaging.io import encode_exr, encode_png, write_hdr
from patchlight.scene import load_scene
from patchlight.shading.directional import directional_light

REPO = Path(__file__).resolve().parents[1]
DECODE = REPO / "tests" / "gltf" / "decode.mjs"
SQRT3 = np.sqrt(3.0)


def three_decode(kind: str, path: Path, precision: str) -> np.ndarray:
    """(H, W, 3) as three.js's loader hands it to WebGL, turned to row 0 = the file's top row."""
    out = path.with_suffix(f".{precision}.bin")
    subprocess.run(["node", str(DECODE), kind, str(path), precision, str(out)], check=True)
    head, _, body = out.read_bytes().partition(b"\n")
    meta = json.loads(head)
    rgba = np.frombuffer(body, np.float32).reshape(meta["height"], meta["width"], 4)[..., :3]
    return rgba if kind == "hdr" else rgba[::-1]  # EXRLoader hands rows bottom first


def relative(mode: str, maps: np.ndarray) -> np.ndarray:
    """The maps as values in [0, 1] (module docstring); SH: three layers L1 / L0 (L0 becomes 1)."""
    if mode == "dominant":
        return 0.5 + 0.5 * maps
    c0 = np.where(maps[0] > 1e-12, maps[0], 1.0)
    return np.clip(0.5 + maps[1:] / c0 / (2 * SQRT3), 0.0, 1.0)


def absolute(mode: str, stored: np.ndarray, maps: np.ndarray) -> np.ndarray:
    """The maps the model reads back from `relative` values."""
    if mode == "dominant":
        return 2.0 * stored - 1.0
    c0 = (maps[0] > 1e-12).astype(np.float32)  # 1 where there is light, else 0 (the model keeps I)
    return np.concatenate([c0[None], (stored - 0.5) * 2 * SQRT3 * c0])


def tilted(n0: np.ndarray, rng) -> np.ndarray:
    """Unit normals tilted from n0 (N, 3) by up to 40 degrees, random azimuth."""
    helper = np.where(np.abs(n0[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t = np.cross(n0, helper)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n0, t)
    theta = np.radians(rng.uniform(0, 40, (len(n0), 1)))
    phi = rng.uniform(0, 2 * np.pi, (len(n0), 1))
    return np.cos(theta) * n0 + np.sin(theta) * (np.cos(phi) * t + np.sin(phi) * b)


def candidates(mode: str, maps: np.ndarray, tmp: Path) -> dict[str, tuple[np.ndarray, int]]:
    """name -> (decoded maps as the model reads them, bytes)."""
    out = {}
    for precision in ("half", "float"):
        decoded, size = [], 0
        for k, layer in enumerate(maps):
            data = encode_exr(layer, half=precision == "half")
            (tmp / f"{mode}{k}.exr").write_bytes(data)
            decoded.append(three_decode("exr", tmp / f"{mode}{k}.exr", "half" if precision == "half" else "float"))
            size += len(data)
        out[f"EXR {precision}, EXRLoader {precision}"] = (np.stack(decoded), size)
    stored = relative(mode, maps)
    png = np.round(stored * 255) / 255
    out["8-bit PNG, relative"] = (absolute(mode, png, maps),
                                  sum(len(encode_png((s * 255).round().astype(np.uint8))) for s in png))
    decoded, size = [], 0
    for k, layer in enumerate(stored):
        write_hdr(tmp / f"{mode}{k}.hdr", layer)
        decoded.append(three_decode("hdr", tmp / f"{mode}{k}.hdr", "half"))
        size += (tmp / f"{mode}{k}.hdr").stat().st_size
    out["RGBE .hdr, relative, half"] = (absolute(mode, np.stack(decoded), maps), size)
    return out


def main() -> None:
    rng = np.random.default_rng(5)
    scene = load_scene("room")
    print("error of the lightmap-directional light per channel (valid texels above 1 % of the peak, "
          "normals tilted up to 40 degrees): median / p99 / max; bytes of the maps")
    for mode in ("sh", "dominant"):
        result = bake(scene, BakeSettings(resolution=128, directional=mode))
        p = result.patches
        valid = result.valid & (result.lightmap.max(axis=-1) > 0.01 * result.lightmap.max())
        n0 = p.to_image(p.normal)[valid].astype(np.float64)
        n0 /= np.linalg.norm(n0, axis=1, keepdims=True)
        n = tilted(n0, rng)
        baked = result.lightmap[valid].astype(np.float64)
        scale = float(result.lightmap.max()) if mode == "sh" else 1.0
        maps = result.directional.maps / scale
        truth = directional_light(mode, maps[:, valid], baked, n, n0)
        with tempfile.TemporaryDirectory() as tmp:
            for name, (decoded, size) in candidates(mode, maps, Path(tmp)).items():
                light = directional_light(mode, decoded[:, valid], baked, n, n0)
                error = np.abs(light - truth) / np.maximum(truth, 1e-6 * truth.max())
                print(f"{mode:<9}{name:<28}{100 * np.median(error):7.3f} % {100 * np.percentile(error, 99):7.3f} % "
                      f"{100 * error.max():7.3f} %   {size:>8} bytes")


if __name__ == "__main__":
    main()
