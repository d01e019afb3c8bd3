"""Which gather reaches a given error faster: the hemicube or stratified cosine rays?

Bakes `cornell` (and `room`) at a small resolution with each method at growing sizes,
without adaptive sampling so that both gather every texel, and prints seconds and the
RMS relative error of the incident light against a reference bake with a 128-pixel
hemicube (49,152 rays per patch). Run by hand: `.venv/bin/python bench/bench_gather.py`.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.radiosity import adaptive
from patchlight.scene import load_scene

HEMICUBES = (8, 16, 32, 64)
STRATIFIED = (64, 256, 1024, 4096)


def error(result, reference) -> float:
    ok = (result.status != adaptive.INSIDE) & (reference.status != adaptive.INSIDE)
    p = result.patches
    a = result.lightmap[p.texel_y, p.texel_x][ok].sum(1)
    b = reference.lightmap[p.texel_y, p.texel_x][ok].sum(1)
    lit = b > 1e-3 * b.mean()
    return float(np.sqrt(np.mean(((a[lit] - b[lit]) / b[lit]) ** 2)))


def timed(scene, settings):
    start = time.perf_counter()
    result = bake(scene, settings)
    return result, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument("--scenes", nargs="+", default=["cornell", "room"])
    args = parser.parse_args()
    for name in args.scenes:
        scene = load_scene(name)
        base = dict(resolution=args.resolution, adaptive=False, tolerance=1e-4)
        bake(scene, BakeSettings(resolution=args.resolution))  # JIT warm-up
        reference, seconds = timed(scene, BakeSettings(gather="hemicube", hemicube_size=128, **base))
        print(f"\n== {name} {args.resolution}x{args.resolution}: reference hemicube 128 in {seconds:.1f} s")
        print(f"{'gather':<11} {'size':>5} {'rays/patch':>10} {'seconds':>8} {'RMS error':>10}")
        for method, sizes in (("hemicube", HEMICUBES), ("stratified", STRATIFIED)):
            for size in sizes:
                extra = {"hemicube_size": size} if method == "hemicube" else {"rays": size}
                result, seconds = timed(scene, BakeSettings(gather=method, **extra, **base))
                print(f"{method:<11} {size:>5} {result.stats['rays_per_patch']:>10} {seconds:>8.2f} "
                      f"{error(result, reference):>10.4f}")
        for rays in STRATIFIED[:3]:
            result, seconds = timed(scene, BakeSettings(rays=rays, denoise=True, **base))
            print(f"{'+ OIDN':<11} {rays:>5} {rays:>10} {seconds:>8.2f} {error(result, reference):>10.4f}")


if __name__ == "__main__":
    main()
