"""Light-volume bake speed: the room at 0.5 m spacing (goal: under 10 s on 2 cores).

Bakes the room's lightmap once (not timed), then the volume with each ray count, and prints
seconds, probes/s and rays/s, and with --noise the RMS relative error of the probe values
against a 4096-ray reference. Run by hand: `.venv/bin/python bench/bench_volume.py`.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

from patchlight.config import BakeSettings
from patchlight.solved import load_solved
from patchlight.volumes import VolumeSettings, bake_volume, grid_over

GOAL_SECONDS = 10.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="room", help="a bake directory or a scene (baked first)")
    parser.add_argument("--spacing", type=float, default=0.5)
    parser.add_argument("--rays", type=int, nargs="+", default=[VolumeSettings().rays])
    parser.add_argument("--noise", action="store_true", help="also measure the error against 4096 rays per axis")
    args = parser.parse_args()
    start = time.perf_counter()
    solved = load_solved(args.scene, BakeSettings())
    print(f"{args.scene}: solved in {time.perf_counter() - start:.1f} s; {os.cpu_count()} cores")
    grid = grid_over(*solved.scene.bounds(), spacing=args.spacing)
    bake_volume(solved, grid_over(*solved.scene.bounds(), dims=(2, 2, 2)))  # JIT and thread-pool warm-up
    reference = bake_volume(solved, grid, VolumeSettings(rays=4096))[0] if args.noise else None
    print(f"grid {grid.dims[0]} x {grid.dims[1]} x {grid.dims[2]} = {grid.count} probes at {args.spacing} m")
    print(f"{'rays/axis':>9} {'seconds':>8} {'probes/s':>9} {'Mrays/s':>8} {'inside':>7}" + ("  RMS error" if args.noise else ""))
    for rays in args.rays:
        volume, stats = bake_volume(solved, grid, VolumeSettings(rays=rays))
        line = (f"{stats['rays_per_axis']:>9} {stats['seconds']:>8.2f} {stats['probes_per_second']:>9.0f} "
                f"{stats['rays_per_second'] / 1e6:>8.2f} {stats['inside_geometry_probes']:>7}")
        if reference is not None:
            ok = ~volume.inside
            a, b = volume.cube[:, ok].sum(-1), reference.cube[:, ok].sum(-1)
            lit = b > 1e-3 * b.mean()
            line += f"  {np.sqrt(np.mean(((a[lit] - b[lit]) / b[lit]) ** 2)):>9.4f}"
        verdict = "meets" if stats["seconds"] < GOAL_SECONDS else "MISSES"
        print(f"{line}   {verdict} the {GOAL_SECONDS:.0f} s goal")


if __name__ == "__main__":
    main()
