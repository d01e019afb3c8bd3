"""Bake the built-in scenes and say where the time goes.

Prints, per scene: patches, computed patches, rays traced, rays per second, seconds per
stage, and the ratio of the whole bake's time to the time bare Embree needs to trace the
same rays: the bake runs twice, timed and then untimed while the rays it casts (closest-hit
and occlusion) are recorded (the bake is deterministic: both cast the same rays), and the
recorded rays are re-traced on a thread per core, twice: by bare embreex (`EmbreeScene.run`,
one Embree call a ray) and by the tracer's own packet kernels alone (`TriangleBvh`, 16 rays
a call, what the bake traces with): the first ratio is how the bake compares with tracing
through embreex, the second what the bake adds to its own tracing. The JIT is warmed up
first, untimed. The recording costs memory (about 50 bytes a ray). Large
lightmaps record one tracer call in `--sample` K (default: 1 at 512, more above, so the
copies stay under about 1.5 G); bare Embree's time is then that of the recorded calls
scaled by all rays over recorded rays, per kind. Also prints each stage's CPU utilisation and
the same ratios in CPU seconds (bake's process against bare Embree's), which a shared
machine's load distorts less than the wall clock. A lone ratio moves by a tenth with the
machine's load: `--repeat K` runs every scene K times, in turn, and ends with each scene's
ratios and their median.
Run by hand: `.venv/bin/python bench/bench_bake.py [--resolution N ...] [--gather G] [--scenes ...] [--repeat K]`.
"""
from __future__ import annotations

import argparse
import itertools
import os
import statistics
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import patchlight.bake as bake_module
from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.radiosity.emitters import TEXELS_PER_CHUNK, next_event_rays
from patchlight.rays.embree import TriangleBvh
from patchlight.rays.tracer import Tracer
from patchlight.scene import load_scene


def packed_emitter_light(emitters, patches, tri_uv1, points, side, lift, tracer, gather_rays, seed=1):
    """The bake's emitter_light with its shadow rays packed first (next_event_rays) and traced
    through Tracer.occluded_chunk, where RecordedRays sees them: the same rays and the same
    light (tests/radiosity/test_emitters.py), where the bake traces them inside its kernel."""
    out = np.zeros((len(patches), 3), np.float32)

    def chunk(first, last):
        rows = np.arange(first, last, dtype=np.int64)
        ray, origins, dirs, tmax, value = next_event_rays(emitters, patches, tri_uv1, points, side, lift, rows,
                                                          gather_rays, seed)
        blocked = tracer.occluded_chunk(origins, dirs, tmax)
        np.add.at(out[first:last], ray // (side * side), value * ~blocked[:, None])  # in ray order

    tracer.over_spans(chunk, 0, len(patches), TEXELS_PER_CHUNK)
    return out


class RecordedRays:
    """Keeps a copy of the rays of one tracer call in `sample` while active: (origins,
    directions, tmax or None for closest hit) per call; `cast` counts every ray by kind. The
    emitters' shadow rays, which the bake traces inside its kernel, are packed and traced
    through the tracer meanwhile (`packed_emitter_light`)."""

    def __init__(self, sample: int = 1):
        self.batches = []
        self.cast = {False: 0, True: 0}  # occlusion? -> rays
        self.sample = sample
        self._calls = itertools.count()
        self._originals = (Tracer.intersect_chunk, Tracer.occluded_chunk, bake_module.emitter_light)

    def _record(self, origins, directions, far):
        self.cast[far is not None] += len(origins)
        if next(self._calls) % self.sample == 0:
            self.batches.append((np.array(origins, np.float32), np.array(directions, np.float32), far))

    def __enter__(self):
        intersect_chunk, occluded_chunk, _ = self._originals
        record = self._record

        def recorded_intersect_chunk(tracer, origins, directions):
            record(origins, directions, None)
            return intersect_chunk(tracer, origins, directions)

        def recorded_occluded_chunk(tracer, origins, directions, tmax):
            record(origins, directions, np.array(tmax, np.float32))
            return occluded_chunk(tracer, origins, directions, tmax)

        Tracer.intersect_chunk, Tracer.occluded_chunk = recorded_intersect_chunk, recorded_occluded_chunk
        bake_module.emitter_light = packed_emitter_light
        return self

    def __exit__(self, *exc):
        Tracer.intersect_chunk, Tracer.occluded_chunk, bake_module.emitter_light = self._originals

    def recorded(self, occlusion: bool) -> int:
        return sum(len(o) for o, _, far in self.batches if (far is not None) == occlusion)


def embreex_tracer(scene):
    """Bare embreex: one `EmbreeScene.run` call (rtcIntersect1 / rtcOccluded1 a ray) on
    contiguous arrays, closest hit or occlusion when far is given."""
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    es = rtcore_scene.EmbreeScene()
    TriangleMesh(es, scene.positions.astype(np.float32), scene.indices.astype(np.int32))

    def trace(origins, directions, far):
        if far is None:
            return es.run(origins, directions, output=1)
        return es.run(origins, directions, dists=far, query="OCCLUDED")
    return trace


def packet_tracer(scene):
    """Bare Embree packets: the tracer's own kernels (rtcIntersect16 / rtcOccluded16) alone."""
    bvh = TriangleBvh(scene.positions, scene.indices)
    return lambda origins, directions, far: (bvh.closest(origins, directions) if far is None
                                             else bvh.occluded(origins, directions, far))


def embree_alone(trace, rays: RecordedRays) -> tuple[float, float, float]:
    """Seconds `trace` needs for all the closest-hit and occlusion rays the bake cast (the
    recorded ones' time scaled by cast over recorded), and the CPU seconds of both."""
    threads = os.cpu_count() or 1
    pool = ThreadPoolExecutor(threads)
    seconds = {True: 0.0, False: 0.0}
    cpu = {True: 0.0, False: 0.0}
    o, d, far = rays.batches[0]
    trace(o[:64], d[:64], None if far is None else far[:64])  # the kernels loaded, not timed
    for o, d, far in rays.batches:
        bounds = np.linspace(0, len(o), threads + 1).astype(int)
        parts = [(o[a:b], d[a:b], None if far is None else far[a:b].copy()) for a, b in zip(bounds, bounds[1:])]
        start, start_cpu = time.perf_counter(), time.process_time()
        list(pool.map(lambda part: trace(*part), parts))
        seconds[far is not None] += time.perf_counter() - start
        cpu[far is not None] += time.process_time() - start_cpu
    scale = {k: rays.cast[k] / max(rays.recorded(k), 1) for k in (False, True)}
    return seconds[False] * scale[False], seconds[True] * scale[True], sum(cpu[k] * scale[k] for k in scale)


def run(name: str, settings: BakeSettings, sample: int) -> tuple[float, float]:
    """Bake `name` as described above and print the report; returns the ratios bake / embreex
    in wall-clock and in CPU seconds."""
    scene = load_scene(name)
    bake(scene, BakeSettings(resolution=128, passes=2))  # JIT warm-up, not timed
    start = time.perf_counter()
    result = bake(scene, settings)
    total = time.perf_counter() - start
    with RecordedRays(sample) as rays:  # the same bake again (it is deterministic), untimed
        bake(scene, settings)
    s = result.stats
    n_closest, n_occlusion = rays.cast[False], rays.cast[True]
    if n_closest + n_occlusion != s["rays_traced"]:  # bare Embree re-traces what the tracer cast
        print(f"(the tracer cast {n_closest + n_occlusion:,} rays, bake.json counts {s['rays_traced']:,})")
    busy = sum(s["cpu_utilisation_per_stage"][k] * t for k, t in s["seconds_per_stage"].items()) / total
    bake_cpu = busy * total * (os.cpu_count() or 1)
    print(f"\n== {name} {s['resolution'][0]}x{s['resolution'][1]}, {settings.gather} "
          f"({s['rays_per_patch']} rays/patch)")
    print(f"patches {s['patches']}: computed {s['computed_patches']}, interpolated {s['interpolated_patches']}, "
          f"inside geometry {s['inside_geometry_patches']}")
    print(f"rays traced {s['rays_traced'] / 1e6:.2f} M, gather {s['rays_per_second'] / 1e6:.2f} Mrays/s, "
          f"F {s['form_factor_matrix']['entries'] / 1e6:.1f} M entries "
          f"({s['form_factor_matrix']['bytes'] / 2**20:.0f} MiB), {s['passes']} passes")
    for stage, seconds in s["seconds_per_stage"].items():
        print(f"  {stage:<14} {seconds:7.3f} s   CPU {100 * s['cpu_utilisation_per_stage'][stage]:3.0f} % of the cores")
    print(f"  {'total':<14} {total:7.3f} s   CPU {100 * busy:3.0f} % of the cores   texels/s {s['patches'] / total:,.0f}")
    ratios = []
    for label, tracer in (("embreex alone", embreex_tracer), ("Embree packets alone", packet_tracer)):
        closest, occlusion, embree_cpu = embree_alone(tracer(result.scene), rays)
        print(f"{label}: {n_closest / 1e6:.2f} M closest-hit rays {closest:.3f} s "
              f"({n_closest / max(closest, 1e-9) / 1e6:.2f} Mrays/s), {n_occlusion / 1e6:.2f} M occlusion rays "
              f"{occlusion:.3f} s ({n_occlusion / max(occlusion, 1e-9) / 1e6:.2f} Mrays/s)"
              f"{f', from 1 call in {sample}' if sample > 1 else ''}; "
              f"bake / it = {total / (closest + occlusion):.2f}; "
              f"CPU seconds: bake {bake_cpu:.1f}, it {embree_cpu:.1f}, bake / it = {bake_cpu / embree_cpu:.2f}")
        ratios += [total / (closest + occlusion), bake_cpu / embree_cpu]
    return tuple(ratios)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, nargs="+", default=[512])
    parser.add_argument("--sample", type=int, help="record one tracer call in K (default: (N / 512)^2)")
    parser.add_argument("--gather", default="stratified", choices=("stratified", "hemicube"))
    parser.add_argument("--scenes", nargs="+", default=["room", "cornell"])
    parser.add_argument("--repeat", type=int, default=1, help="runs of every scene, in turn (default 1)")
    args = parser.parse_args()
    ratios = {}  # (scene, resolution) -> [(wall, cpu vs embreex, wall, cpu vs packets) per run]
    for resolution in args.resolution:
        sample = args.sample or max(1, (resolution // 512) ** 2)
        for _ in range(args.repeat):
            for name in args.scenes:
                ratio = run(name, BakeSettings(resolution=resolution, gather=args.gather), sample)
                ratios.setdefault((name, resolution), []).append(ratio)
    if args.repeat > 1:
        for k, label in ((0, "embreex"), (2, "Embree packets")):
            print(f"\n== bake / {label}, run by run [median]")
            for (name, resolution), runs in ratios.items():
                wall, cpu = [r[k] for r in runs], [r[k + 1] for r in runs]
                print(f"{name} {resolution}: wall {', '.join(f'{r:.2f}' for r in wall)} [{statistics.median(wall):.2f}]; "
                      f"CPU {', '.join(f'{r:.2f}' for r in cpu)} [{statistics.median(cpu):.2f}]")


if __name__ == "__main__":
    main()
