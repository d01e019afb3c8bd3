"""Benchmark the CPU renderer: 1024 x 1024 of the built-in room, every model, per-pixel.

Run by hand:  .venv/bin/python bench/bench_render.py [--size 1024] [--scene room | BAKE_DIR]
Prints seconds per frame and Mpixels/s per model (best of three); the target is under 2 s
on 2 cores. Set PATCHLIGHT_THREADS to change how many threads trace.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

from patchlight.errors import PatchlightError
from patchlight.inputs import open_input
from patchlight.render import Renderer, target_settings
from patchlight.scene.model import Light
from patchlight.shading import MODELS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--scene", default="room")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    target, _ = open_input(args.scene).target()
    renderer = Renderer(target)
    camera = renderer.default_camera()
    lights = target.scene.lights + [Light("point", np.ones(3, np.float32), 200.0,
                                          position=renderer.center + [0.0, 0.5, 0.0], name="bench lamp")]
    print(f"{args.scene}: {target.scene.n_triangles} triangles, {args.size}x{args.size}, "
          f"{len(lights)} lights, {os.cpu_count()} cores")
    pixels = args.size * args.size
    for model in MODELS:
        settings = target_settings(target, model=model, lights=lights)
        try:
            renderer.require_inputs(settings)
        except PatchlightError as missing:
            print(f"  {model:12s} skipped: {missing}")
            continue
        renderer.render(settings, camera, 64, 64)  # warm up
        best = float("inf")
        for _ in range(args.repeat):
            start = time.perf_counter()
            renderer.render(settings, camera, args.size, args.size)
            best = min(best, time.perf_counter() - start)
        print(f"  {model:12s} {best:6.3f} s  {pixels / best / 1e6:6.2f} Mpixels/s")


if __name__ == "__main__":
    main()
