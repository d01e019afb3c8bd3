"""Bake the built-in scenes and say where the time goes.

Prints, per scene: patches, computed patches, rays traced, rays per second, seconds per
stage, and the ratio of the whole bake's time to the time embreex alone needs to trace the
same rays (the same gather and shadow rays, re-traced with bare `EmbreeScene.run` calls on
a thread per core). Run by hand: `.venv/bin/python bench/bench_bake.py [--resolution N]`.
"""
from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from patchlight.bake import bake, ray_offsets
from patchlight.config import BakeSettings
from patchlight.radiosity import _kernels, adaptive
from patchlight.radiosity.gather import Gatherer
from patchlight.scene import load_scene


def embree_alone(result, settings) -> float:
    """Seconds bare embreex needs for the bake's gather rays (computed patches x rays)."""
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    scene, patches = result.scene, result.patches
    es = rtcore_scene.EmbreeScene()
    TriangleMesh(es, scene.positions.astype(np.float32), scene.indices.astype(np.int32))
    size = settings.hemicube_size if settings.gather == "hemicube" else settings.rays
    g = Gatherer(patches, None, None, None, settings.gather, size, ray_offsets(scene, patches), settings.seed)
    rows = np.flatnonzero((result.status == adaptive.COMPUTED) | (result.status == adaptive.INSIDE))
    threads = os.cpu_count() or 1
    pool = ThreadPoolExecutor(threads)
    seconds = 0.0
    per_chunk = max(1, (1 << 20) // g.rays_per_patch)
    for s in range(0, len(rows), per_chunk):
        r = rows[s:s + per_chunk]
        o, d = _kernels.make_rays(patches.position, patches.normal, g.offset, r.astype(np.int64), g.dirs, g._angles(r))
        parts = np.array_split(np.arange(len(o)), threads * 4)
        start = time.perf_counter()
        list(pool.map(lambda idx: es.run(o[idx], d[idx], output=1), parts))
        seconds += time.perf_counter() - start
    return seconds


def run(name: str, settings: BakeSettings) -> None:
    scene = load_scene(name)
    bake(scene, BakeSettings(resolution=128, passes=2))  # JIT warm-up, not timed
    start = time.perf_counter()
    result = bake(scene, settings)
    total = time.perf_counter() - start
    s = result.stats
    alone = embree_alone(result, settings)
    print(f"\n== {name} {s['resolution'][0]}x{s['resolution'][1]}, {settings.gather} "
          f"({s['rays_per_patch']} rays/patch)")
    print(f"patches {s['patches']}: computed {s['computed_patches']}, interpolated {s['interpolated_patches']}, "
          f"inside geometry {s['inside_geometry_patches']}")
    print(f"rays traced {s['rays_traced'] / 1e6:.2f} M, gather {s['rays_per_second'] / 1e6:.2f} Mrays/s, "
          f"F {s['form_factor_matrix']['nonzeros'] / 1e6:.1f} M nonzeros "
          f"({s['form_factor_matrix']['bytes'] / 2**20:.0f} MiB), {s['passes']} passes")
    for stage, seconds in s["seconds_per_stage"].items():
        print(f"  {stage:<14} {seconds:7.3f} s")
    print(f"  {'total':<14} {total:7.3f} s   texels/s {s['patches'] / total:,.0f}")
    print(f"embreex alone on the gather rays: {alone:.3f} s ({s['rays_gather'] / alone / 1e6:.2f} Mrays/s); "
          f"bake / embreex = {total / alone:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=512)
    parser.add_argument("--gather", default="stratified", choices=("stratified", "hemicube"))
    args = parser.parse_args()
    for name in ("room", "cornell"):
        run(name, BakeSettings(resolution=args.resolution, gather=args.gather))


if __name__ == "__main__":
    main()
