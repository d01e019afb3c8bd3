"""A level-sized bake: a generated glTF town (a few hundred buildings, columns and a dome of
tens of thousands of triangles) written to a .glb, then baked through the CLI at 1024 x 1024.

Prints the glTF's size, seconds per stage, rays per second and memory of F, so the figures
of a real-sized level sit beside the built-in scenes'. Run by hand:
    .venv/bin/python bench/bench_large.py [--resolution 1024] [--out /tmp/patchlight-large]
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from patchlight.cli.main import main as patchlight
from patchlight.scene import Light, SceneBuilder, Sky
from patchlight.scene.gltf import save_baked_glb


def dome(b: SceneBuilder, centre, radius: float, material: int, rings: int = 96) -> None:
    """A hemisphere of quads facing out."""
    c = np.asarray(centre, float)
    theta = np.linspace(0, np.pi / 2, rings // 2 + 1)
    phi = np.linspace(0, 2 * np.pi, rings + 1)
    for t0, t1 in zip(theta, theta[1:]):
        for p0, p1 in zip(phi, phi[1:]):
            corners = [c + radius * np.array([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)])
                       for t, p in ((t0, p0), (t0, p1), (t1, p1), (t1, p0))]
            b.quad(corners, material, np.mean(corners, axis=0) - c)


def town(seed: int = 3):
    rng = np.random.default_rng(seed)
    b = SceneBuilder()
    ground = b.material("ground", (0.35, 0.33, 0.3))
    walls = [b.material(f"wall{i}", rgb) for i, rgb in enumerate(rng.uniform(0.3, 0.8, (6, 3)))]
    b.box((-60, -1, -60), (60, 0, 60), ground)
    for x in range(-50, 50, 8):
        for z in range(-50, 50, 8):
            if abs(x) < 12 and abs(z) < 12:
                continue
            w, d, h = rng.uniform(3, 6.5), rng.uniform(3, 6.5), rng.uniform(3, 20)
            b.box((x, 0, z), (x + w, h, z + d), walls[rng.integers(len(walls))])
    for angle in np.linspace(0, 2 * np.pi, 24, endpoint=False):
        px, pz = 9 * np.cos(angle), 9 * np.sin(angle)
        b.box((px - 0.3, 0, pz - 0.3), (px + 0.3, 6, pz + 0.3), walls[0])
    dome(b, (0, 6, 0), 8.0, walls[1])
    sun = Light("directional", np.array([1.0, 0.95, 0.85], np.float32), 100.0,
                direction=np.array([0.4, -0.7, 0.3], np.float32) / np.linalg.norm([0.4, -0.7, 0.3]), name="sun")
    sky = Sky.gradient((1.2, 1.9, 3.6), (2.6, 2.9, 3.2), (0.5, 0.45, 0.4))
    return b.scene("town", lights=[sun], sky=sky)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=1024)
    parser.add_argument("--out", type=Path, default=Path("/tmp/patchlight-large"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    scene = town()
    glb = args.out / "town.glb"
    save_baked_glb(scene, glb)
    print(f"town.glb: {scene.n_triangles:,} triangles, {glb.stat().st_size / 2**20:.1f} MiB")
    start = time.perf_counter()
    status = patchlight(["bake", str(glb), "-o", str(args.out / "bake"), "--resolution", str(args.resolution),
                         "--quiet"])
    seconds = time.perf_counter() - start
    s = json.loads((args.out / "bake" / "bake.json").read_text())
    print(f"exit {status}: {s['patches']:,} patches ({s['computed_patches']:,} gathered) in {seconds:.1f} s "
          f"end to end, {s['rays_traced'] / 1e6:.1f} M rays, {s['rays_per_second'] / 1e6:.2f} Mrays/s gather, "
          f"F {s['form_factor_matrix']['bytes'] / 2**20:.0f} MiB, {s['passes']} passes")
    for stage, t in s["seconds_per_stage"].items():
        print(f"  {stage:<14} {t:7.2f} s")


if __name__ == "__main__":
    main()
