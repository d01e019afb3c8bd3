"""Which lightmap encoding survives three.js's own loaders: relative error per decade of I.

Encodes one synthetic lightmap (I from 1e-4 to 1e3, coloured texels) with every candidate,
decodes it the way a three.js page would (HDRLoader / EXRLoader under node, at the half
float precision they hand WebGL, or at float; 8-bit PNGs as the GPU samples them) and
prints, per decade of I, the median and 99th-percentile relative error of each channel.
Needs node and `npm ci`. Run by hand: `.venv/bin/python bench/bench_lightmap_encoding.py`.
"""
from __future__ import annotations

import subprocess
import tempfile
from pathlib import Path

import numpy as np

from patchlight.imaging.color import linear_to_srgb, srgb_to_linear
from patchlight.imaging.io import write_exr, write_hdr

REPO = Path(__file__).resolve().parents[1]
DECODE = REPO / "tests" / "gltf" / "decode.mjs"
DECADES = range(-4, 3)  # [1e-4, 1e-3) ... [1e2, 1e3)


def synthetic(size: int = 256, seed: int = 1) -> np.ndarray:
    """(size, size, 3) I = 10^u (u uniform over the decades) x a colour whose largest channel is 1
    and whose others lie in [0.3, 1]: every channel reported is at least 0.3 of its texel's peak."""
    rng = np.random.default_rng(seed)
    level = 10.0 ** rng.uniform(DECADES.start, DECADES.stop, (size, size, 1))
    colour = rng.uniform(0.3, 1.0, (size, size, 3))
    colour /= colour.max(axis=-1, keepdims=True)
    return (level * colour).astype(np.float32)


def three_decode(kind: str, path: Path, precision: str) -> np.ndarray:
    """(H, W, 3) as three.js's loader hands it to WebGL, turned to row 0 = the file's top row."""
    out = path.with_suffix(f".{precision}.bin")
    subprocess.run(["node", str(DECODE), kind, str(path), precision, str(out)], check=True)
    data = out.read_bytes()
    head, _, body = data.partition(b"\n")
    import json
    meta = json.loads(head)
    rgba = np.frombuffer(body, np.float32).reshape(meta["height"], meta["width"], 4)[..., :3]
    return rgba if kind == "hdr" else rgba[::-1]  # EXRLoader hands rows bottom first


def rgbm(values: np.ndarray) -> np.ndarray:
    """The RGBM PNG scene.glb used to carry (range = peak), decoded exactly: rgb a range."""
    value_range = float(values.max())
    v = values / value_range
    m = np.ceil(np.clip(v.max(axis=-1, keepdims=True), 1e-6, 1.0) * 255) / 255
    q = np.round(np.concatenate([np.clip(v / m, 0, 1), m], -1) * 255) / 255
    return q[..., :3] * q[..., 3:] * value_range


def eight_bit(values: np.ndarray, srgb: bool) -> np.ndarray:
    scale = float(values.max())
    v = values / scale
    if srgb:
        return srgb_to_linear(np.round(linear_to_srgb(v) * 255) / 255) * scale
    return np.round(v * 255) / 255 * scale


def main() -> None:
    truth = synthetic()
    level = truth.max(axis=-1)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        write_hdr(tmp / "lightmap.hdr", truth / truth.max())  # as scene.glb stores it: I / scale
        write_exr(tmp / "lightmap.exr", truth)
        scale = float(truth.max())
        candidates = {
            "RGBE .hdr, HDRLoader half": three_decode("hdr", tmp / "lightmap.hdr", "half") * scale,
            "RGBE .hdr, HDRLoader float": three_decode("hdr", tmp / "lightmap.hdr", "float") * scale,
            "EXR float, EXRLoader half": three_decode("exr", tmp / "lightmap.exr", "half"),
            "EXR float, EXRLoader float": three_decode("exr", tmp / "lightmap.exr", "float"),
            "RGBM PNG (range = peak)": rgbm(truth),
            "8-bit linear PNG (/ peak)": eight_bit(truth, srgb=False),
            "8-bit sRGB PNG (/ peak)": eight_bit(truth, srgb=True),
        }
    header = "".join(f"  1e{d:+d}..     " for d in DECADES)
    print(f"relative error per channel, median / 99th percentile, by decade of I (peak {truth.max():.0f})")
    print(f"{'encoding':<28}{header}")
    for name, decoded in candidates.items():
        error = np.abs(decoded - truth) / truth
        cells = []
        for d in DECADES:
            rows = (level >= 10.0 ** d) & (level < 10.0 ** (d + 1))
            e = error[rows]
            cells.append(f"{100 * np.median(e):5.2f}/{100 * np.percentile(e, 99):6.2f}%")
        within = [d for d, cell in zip(DECADES, cells) if float(cell.split("/")[1][:-1]) <= 1.0]
        print(f"{name:<28}" + " ".join(cells) + f"   {len(within)} decades at <= 1 %")


if __name__ == "__main__":
    main()
