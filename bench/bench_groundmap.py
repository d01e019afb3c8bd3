"""Time a 1024 x 1024 ground map of the built-in track (goal: under 10 s on 2 cores).

The track is baked once (2 texels per metre, not timed); then each encoding's ground map is
made and written, and the seconds per stage are printed: prepare (polygons left out and
turned up), look down (one ray per texel and the bake's light at each hit), shadows (a ray
to the sun per texel), encode (noise, shadow amount, encoding) and write (the map as PNG
and DDS, the other two encodings as PNG for the viewer, json).
Run by hand: `.venv/bin/python bench/bench_groundmap.py [--size N] [--bake DIR]`.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from patchlight.bake import bake
from patchlight.bakedir import write_bake
from patchlight.config import BakeSettings
from patchlight.ground.groundmap import GroundMapSettings, make_groundmap, write_groundmap
from patchlight.scene import load_scene
from patchlight.solved import load_solved

GOAL_SECONDS = 10.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--bake", type=Path, help="an existing bake directory of the track to reuse")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bake_dir = args.bake
        if bake_dir is None:
            bake_dir = Path(tmp) / "track"
            settings = BakeSettings(texels_per_unit=2.0)
            start = time.perf_counter()
            write_bake(bake(load_scene("track"), settings), bake_dir, settings)
            print(f"baked the track in {time.perf_counter() - start:.1f} s (not counted)")
        solved = load_solved(bake_dir)
        print(f"{args.size} x {args.size} ground map of {solved.scene.n_triangles} triangles, "
              f"{os.cpu_count()} cores")
        for encoding in ("hsv", "alpha", "separate"):
            start = time.perf_counter()
            ground_map = make_groundmap(solved, GroundMapSettings(size=args.size, shadows=encoding))
            write_groundmap(ground_map, Path(tmp) / encoding, str(bake_dir), str(bake_dir))
            seconds = time.perf_counter() - start
            stages = "  ".join(f"{k} {v:.2f}" for k, v in ground_map.seconds.items())
            verdict = "ok" if seconds < GOAL_SECONDS else "over the goal"
            print(f"{encoding:>8}: {seconds:5.2f} s ({seconds / GOAL_SECONDS:.0%} of {GOAL_SECONDS:g} s, {verdict})"
                  f"   {stages}   shadowed {100 * ground_map.shadowed:.1f}%")


if __name__ == "__main__":
    main()
