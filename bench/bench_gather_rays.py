"""The gather's work per ray beside Embree's: what a chunk costs on top of its trace.

Lays out a built-in scene's lightmap as the bake does, picks patches spread evenly over it,
gathers them chunk by chunk on one thread (`Gatherer.gather_chunk`: ray generation, the
Embree trace, the item buffer, the rows of F dealt to their panels) and traces the same rays
again with one bare call of the tracer's packet kernel per chunk (`TriangleBvh.closest`).
Prints nanoseconds of thread CPU time per ray for both and the difference, the work around
the Embree call. The best of `--repeat` runs counts; thread
CPU time is what a shared machine's load distorts least, but caches are shared: say the load.
Run by hand: `.venv/bin/python bench/bench_gather_rays.py [--resolution N ...] [--scenes ...]`.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

from patchlight.atlas.raster import rasterize
from patchlight.atlas.uvs import ensure_lightmap_uvs
from patchlight.config import BakeSettings
from patchlight.radiosity.emitters import find_emitters, samples_per_texel
from patchlight.radiosity.gather import Gatherer
from patchlight.rays.embree import TriangleBvh
from patchlight.rays.hemisphere import hemisphere_rays
from patchlight.rays.tracer import Tracer
from patchlight.scene import load_scene


def gatherer_of(name: str, resolution: int, emitter_samples: int) -> Gatherer:
    """The bake's Gatherer for scene `name` at `resolution`, with the default settings but
    `emitter_samples` (next-event samples per texel towards emissive triangles; 0: none)."""
    settings = BakeSettings(resolution=resolution)
    scene, width, height, _ = ensure_lightmap_uvs(load_scene(name), resolution=resolution)
    patches, _ = rasterize(scene, width, height)
    samples = samples_per_texel(emitter_samples)
    return Gatherer(scene, patches, Tracer(scene.positions, scene.indices), settings.gather, settings.rays,
                    settings.seed, find_emitters(scene, patches) if samples else None, samples)


def thread_seconds(fn, chunks) -> float:
    start = time.thread_time()
    for chunk in chunks:
        fn(chunk)
    return time.thread_time() - start


def run(name: str, resolution: int, patches: int, repeat: int, emitter_samples: int) -> None:
    g = gatherer_of(name, resolution, emitter_samples)
    p = g.patches
    rows = np.linspace(0, len(p) - 1, min(patches, len(p))).astype(np.int64)
    chunks = g._chunks(rows)
    bvh = TriangleBvh(g.tracer.positions, g.tracer.indices)

    def bare(chunk):
        origins, dirs = hemisphere_rays(p.position, p.normal, g.offset, chunk, g.dirs, g.seed)
        start = time.thread_time()
        bvh.closest(origins, dirs)
        return time.thread_time() - start

    g.gather_chunk(chunks[0])  # JIT and BVH warm-up, not timed
    gather = min(thread_seconds(g.gather_chunk, chunks) for _ in range(repeat))
    embree = min(sum(bare(chunk) for chunk in chunks) for _ in range(repeat))
    rays = len(rows) * g.rays_per_patch
    ns = 1e9 / rays
    print(f"{name} {p.width}x{p.height} (emitter samples {g.nee_samples}): {rays / 1e6:.1f} M rays from {len(rows):,} patches in {len(chunks)} chunks; "
          f"gather_chunk {gather * ns:.1f} ns/ray, bare Embree {embree * ns:.1f} ns/ray, around Embree "
          f"{(gather - embree) * ns:.1f} ns/ray ({(gather - embree) / embree:.0%} of Embree)   "
          f"load {os.getloadavg()[0]:.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, nargs="+", default=[512, 2048])
    parser.add_argument("--scenes", nargs="+", default=["room", "cornell"])
    parser.add_argument("--patches", type=int, default=8192, help="patches gathered per scene and size")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--emitter-samples", type=int, default=BakeSettings().emitter_samples)
    args = parser.parse_args()
    for resolution in args.resolution:
        for name in args.scenes:
            run(name, resolution, args.patches, args.repeat, args.emitter_samples)


if __name__ == "__main__":
    main()
