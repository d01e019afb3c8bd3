"""patchlight against Blender Cycles on the same scenes, UVs and lights, in one run.

For each scene (the Cornell box at 256 x 256, lit by its emissive quad; the room at 512 x 512,
sun + uniform sky), bakes the lightmap with Cycles at --cycles-samples and with the
`patchlight bake` command at its defaults, and prints for both the time and the relative RMSE
against a converged Cycles reference, and patchlight's speed-up at equal error: Cycles' error
falls as 1 / sqrt(samples), so Cycles needs t x (e_cycles / e_patchlight)^2 to reach
patchlight's error e_patchlight.

  .venv/bin/python bench/bench_vs_cycles.py --anchors DIR [--cycles-samples 64] [--scenes cornell room]
                                            [-- extra patchlight bake options]

DIR holds SCENE.glb, its SCENE.json sidecar (sky, sun, Lambert albedos, emitter radiance,
lightmap resolution) and ref/SCENE_s*_ref.npz (`lightmap` (H, W, 4): RGB incident light,
A = 1 where Cycles baked the texel). The first run makes .venv-cycles (python3.11, bpy
5.0.1, about 400 MB; gitignored). patchlight is given --passes 5 (the references' 4
bounces), --resolution and, for the room, the sidecar's sky, nothing else. Times are wall
clock: Cycles' bake call alone (its import and set-up excluded), patchlight's whole command
(start-up and writing included). Both use 2 threads.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from patchlight.imaging.io import read_exr

ROOT = Path(__file__).resolve().parent.parent
CYCLES_VENV = ROOT / ".venv-cycles"
CYCLES_PYTHON = CYCLES_VENV / "bin" / "python"
REFERENCE_BOUNCES_AS_PASSES = 5


def ensure_cycles() -> Path:
    """The Python of .venv-cycles, made and given bpy on first use."""
    if not CYCLES_PYTHON.exists():
        print("making .venv-cycles (bpy 5.0.1, about 400 MB) ...", flush=True)
        subprocess.run(["python3.11", "-m", "venv", str(CYCLES_VENV)], check=True)
        subprocess.run([str(CYCLES_PYTHON), "-m", "pip", "install", "-q", "bpy==5.0.1", "numpy"], check=True)
    return CYCLES_PYTHON


def relative_rmse(lightmap: np.ndarray, reference: np.ndarray) -> float:
    """RMSE over the RGB of the texels Cycles baked (alpha > 0, not black), over their mean."""
    mask = (reference[..., 3] > 0) & np.any(reference[..., :3] != 0, axis=-1)
    ref = reference[..., :3][mask].astype(np.float64)
    return float(np.sqrt(np.mean((lightmap[..., :3][mask] - ref) ** 2)) / ref.mean())


def bake_cycles(python: Path, glb: Path, sidecar: Path, samples: int, resolution: int, out: Path) -> tuple[float, np.ndarray]:
    run = subprocess.run([str(python), str(Path(__file__).with_name("cycles_bake.py")), str(glb), str(sidecar),
                          str(out), "--samples", str(samples), "--resolution", str(resolution)],
                         capture_output=True, text=True)
    if run.returncode != 0:
        raise SystemExit(f"cycles failed on {glb.name}: {run.stderr.strip().splitlines()[-1:]}")
    return json.loads(run.stdout.strip().splitlines()[-1])["bake_seconds"], np.load(out)


def bake_patchlight(glb: Path, sidecar: dict, resolution: int, out: Path, extra: list[str]) -> tuple[float, np.ndarray, dict]:
    command = [str(Path(sys.executable).with_name("patchlight")), "bake", str(glb), "-o", str(out), "--quiet",
               "--resolution", str(resolution), "--passes", str(REFERENCE_BOUNCES_AS_PASSES)]
    world = sidecar.get("world", {})
    if world.get("strength", 0) > 0:
        command += ["--sky", ",".join(str(c * world["strength"]) for c in world["color"])]
    start = time.perf_counter()
    run = subprocess.run(command + extra, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if run.returncode != 0:
        raise SystemExit(f"patchlight failed on {glb.name}: {run.stderr.strip()}")
    return seconds, read_exr(out / "lightmap.exr"), json.loads((out / "bake.json").read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--anchors", type=Path, required=True, help="folder of the scenes, sidecars and ref/")
    ap.add_argument("--cycles-samples", type=int, default=64)
    ap.add_argument("--scenes", nargs="+", default=["cornell", "room"])
    ap.add_argument("extra", nargs="*", help="after --: more patchlight bake options")
    args = ap.parse_args()
    python = ensure_cycles()
    print("machine: 2 cores shared with other work; wall-clock figures vary by tens of percent")
    for name in args.scenes:
        glb, sidecar_path = args.anchors / f"{name}.glb", args.anchors / f"{name}.json"
        sidecar = json.loads(sidecar_path.read_text())
        resolution = sidecar["lightmap"]["resolution"]
        reference = np.load(next((args.anchors / "ref").glob(f"{name}_s*_ref.npz")))["lightmap"]
        with tempfile.TemporaryDirectory() as tmp:
            tc, cycles = bake_cycles(python, glb, sidecar_path, args.cycles_samples, resolution, Path(tmp) / "c.npy")
            tp, ours, summary = bake_patchlight(glb, sidecar, resolution, Path(tmp) / "p", args.extra)
        ec, ep = relative_rmse(cycles, reference), relative_rmse(ours, reference)
        stages = ", ".join(f"{k} {v:.2f}" for k, v in summary["seconds_per_stage"].items() if v >= 0.05)
        print(f"{name} {resolution}x{resolution}: cycles {args.cycles_samples} spp {tc:.1f} s, {ec:.2%} | "
              f"patchlight {tp:.1f} s, {ep:.2%} | speed-up at equal error {tc * (ec / ep) ** 2 / tp:.1f}x")
        print(f"  patchlight stages (s): {stages}; bake {summary['seconds_total']:.1f} s, "
              f"{summary['computed_patches']}/{summary['patches']} patches gathered, {summary['rays_traced'] / 1e6:.1f} M rays")


if __name__ == "__main__":
    main()
