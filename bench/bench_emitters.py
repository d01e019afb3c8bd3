"""Many emitters against the same area merged: a night facade of N x N lit windows.

Bakes a 1 x 1 m emissive wall over a 2 x 1 m floor twice, once as one quad and once as N x N
small quads (default 100 x 100: 10,000 emitters, 20,000 triangles), at the same lightmap
resolution, and prints each bake's seconds (direct light and total) and the ratio; the
floor's light should agree within noise. Each bake's time is the least of REPEATS runs. Next-event estimation picks emitters by a binary
search in their power table, so the ratio should stay near 1 (the goal: at most 2).
Run by hand: `.venv/bin/python bench/bench_emitters.py [--cells 100] [--resolution 128]`.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.scene.model import Material, Scene, face_normals

REPEATS = 3


def facade(cells: int) -> Scene:
    """The scene as arrays: the floor quad, then the wall's cells x cells quads (x = 0, facing
    +x), with lightmap UVs laid by hand: floor on the left half, wall on the right."""
    edges = np.linspace(0.0, 1.0, cells + 1)
    y0, z0 = (a.ravel() for a in np.meshgrid(edges[:-1], edges[:-1], indexing="ij"))
    y1, z1 = y0 + 1.0 / cells, z0 + 1.0 / cells
    zero = np.zeros_like(y0)
    quads = np.concatenate([[[[0, 0, 0], [0, 0, 1], [2, 0, 1], [2, 0, 0]]],
                            np.stack([np.stack([zero, y0, z0], -1), np.stack([zero, y1, z0], -1),
                                      np.stack([zero, y1, z1], -1), np.stack([zero, y0, z1], -1)], axis=1)])
    tris = quads[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3, 3).astype(np.float32)   # (2 Q, 3, 3)
    uv = np.where(np.arange(len(tris))[:, None, None] < 2, tris[:, :, [0, 2]] * [0.23, 0.46] + 0.02,
                  tris[:, :, [2, 1]] * 0.46 + [0.52, 0.02])
    positions = tris.reshape(-1, 3)
    indices = np.arange(len(positions), dtype=np.int32).reshape(-1, 3)
    normal, _ = face_normals(positions, indices)
    materials = [Material("grey", base_color=np.array([0.5, 0.5, 0.5, 1], np.float32)),
                 Material("glow", base_color=np.array([0.2, 0.2, 0.2, 1], np.float32),
                          emissive=np.array([3.0, 2.0, 1.0], np.float32))]
    return Scene(positions=positions, normals=np.repeat(normal, 3, axis=0), uv0=uv.reshape(-1, 2).astype(np.float32),
                 indices=indices, material_ids=(np.arange(len(tris)) >= 2).astype(np.int32), materials=materials,
                 uv1=uv.reshape(-1, 2).astype(np.float32), name=f"facade {cells} x {cells}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cells", type=int, default=100)
    ap.add_argument("--resolution", type=int, default=128)
    args = ap.parse_args()
    settings = BakeSettings(resolution=args.resolution)
    bake(facade(2), BakeSettings(resolution=32, passes=2))  # compile the kernels, untimed
    print("machine: 2 cores shared with other work; wall-clock figures vary by tens of percent")
    results = {}
    for cells in (1, args.cells):
        scene, seconds = facade(cells), []
        for _ in range(REPEATS):  # the least of a few: the machine is shared
            start = time.perf_counter()
            result = bake(scene, settings)
            seconds.append(time.perf_counter() - start)
        seconds = min(seconds)
        floor = np.abs(result.patches.position[:, 1]) < 1e-6
        results[cells] = (seconds, result.solution.incident[floor].mean(axis=0))
        print(f"{cells * cells:6d} emitters: {seconds:.2f} s (direct light "
              f"{result.stats['seconds_per_stage']['direct light']:.2f} s), floor mean {results[cells][1].round(4)}")
    (one, merged), (many, split) = results[1], results[args.cells]
    print(f"ratio {many / one:.2f} (goal <= 2); floor mean differs by {np.abs(split / merged - 1).max():.2%}")


if __name__ == "__main__":
    main()
