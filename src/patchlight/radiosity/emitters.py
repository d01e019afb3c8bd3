"""Emissive triangles as area lights: next-event estimation, combined with the gather by MIS.

Every texel sends shadow rays to points on emissive triangles, picked in proportion to
their emitted power (emission x area, the emission read from the emitter's own lightmap
patches, so textured emission counts) with stratified numbers, and weighs each sample in the
solid-angle measure. The gather still sees emitters too; each of its rays that hits one
counts the emission with the complementary weight (`_kernels.emission_seen`), so the two
estimators add up to the emitted light exactly once (Veach's power heuristic): a tiny bright
panel is found by the shadow rays, a large dim emissive wall nearby by the gather.
Choosing an emitter is a binary search in the power table, so the cost does not grow with
the number of emitters.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..atlas.patches import Patches
from ..atlas.raster import TexelPoints
from ..rays.inside import two_sided_triangles
from ..rays.tracer import Tracer
from ..scene.model import Scene, face_normals
from . import _kernels

TEXELS_PER_CHUNK = 4096  # texels per task: kernel, shadow rays and sum on one core


@dataclass
class Emitters:
    """The emissive triangles of a scene, as next-event estimation samples them.

    triangles (M,) i32 scene triangle ids; cdf (M,) f64 cumulative share of emitted power;
    corners (M, 3, 3) f64; normals (M, 3) f64; two_sided (M,) bool; patch (M,) i64 a patch whose emission
    stands for every point of the triangle, or -1 (`_kernels.uniform_patches`).
    Per scene triangle (T,): pdf_area, the density per m^2 of a next-event sample landing on
    it (its share as the cdf gives it, over its area; 0 on triangles never sampled), which
    the next-event samples and the gather's MIS weights both read; tri_normal (T, 3) f64; tri_two_sided (T,) bool.
    """

    triangles: np.ndarray
    cdf: np.ndarray
    corners: np.ndarray
    normals: np.ndarray
    two_sided: np.ndarray
    patch: np.ndarray
    pdf_area: np.ndarray
    tri_normal: np.ndarray
    tri_two_sided: np.ndarray


def samples_per_texel(emitter_samples: int) -> int:
    """The next-event samples a texel takes: `emitter_samples` rounded down to a square
    (they lie on an n x n grid over the texel)."""
    return math.isqrt(emitter_samples) ** 2


def find_emitters(scene: Scene, patches: Patches) -> Emitters | None:
    """The scene's emitters, or None when no patch emits. A triangle's emission is the mean
    of the patches it owns (a triangle too small to own one: the material's factor)."""
    if not np.any(patches.emission > 0):
        return None
    normal, area = face_normals(scene.positions, scene.indices)
    t = scene.n_triangles
    counts = np.bincount(patches.triangle, minlength=t)
    owned = np.stack([np.bincount(patches.triangle, patches.emission[:, c], minlength=t) for c in range(3)], axis=1)
    factor = np.array([np.asarray(m.emissive, np.float64)[:3] for m in scene.materials]).reshape(-1, 3)
    emission = np.where(counts[:, None] > 0, owned / np.maximum(counts, 1)[:, None], factor[scene.material_ids])
    power = emission.mean(axis=1) * area
    triangles = np.flatnonzero(power > 0).astype(np.int32)
    share = power[triangles] / power[triangles].sum()
    cdf = np.cumsum(share)
    pdf_area = np.zeros(t)
    pdf_area[triangles] = np.diff(cdf, prepend=0.0) / area[triangles]
    two_sided = two_sided_triangles(scene)
    uv = scene.triangle_uv1()[triangles]
    return Emitters(triangles=triangles, cdf=cdf,
                    corners=scene.positions[scene.indices[triangles]].astype(np.float64),
                    normals=normal[triangles].astype(np.float64), two_sided=two_sided[triangles],
                    patch=_kernels.uniform_patches(uv, patches.width, patches.height, patches.index, patches.emission),
                    pdf_area=pdf_area, tri_normal=normal.astype(np.float64), tri_two_sided=two_sided)


def next_event_rays(emitters: Emitters, patches: Patches, tri_uv1: np.ndarray, points: TexelPoints, side: int,
                    lift: np.ndarray, rows: np.ndarray, gather_rays: float, seed: int):
    """The live next-event shadow rays of patches `rows` (R,) i64, side x side per texel
    (`_kernels.next_event_samples`: ray ids, origins, directions, tmax and light), MIS-weighted
    against gather_rays cosine rays per patch (0: at full weight)."""
    return _samples(emitters, patches, tri_uv1, points, side, lift, rows, gather_rays, seed, 0, 0,
                    np.empty((0, 3), np.float32))[:5]


def emitter_light(emitters: Emitters, patches: Patches, tri_uv1: np.ndarray, points: TexelPoints, side: int,
                  lift: np.ndarray, tracer: Tracer, gather_rays: int, seed: int = 1) -> np.ndarray:
    """(N, 3) f32 incident light from the emitters at every patch, the mean over its texel:
    one shadow ray from each point of a side x side grid over the texel (`points`, made by
    the kernel texel by texel, chunks of texels on the tracer's threads), the rays traced as
    they are made (the same rays as `next_event_rays`); lift (N,) metres off the surface;
    gather_rays: the gather's rays per patch (the MIS partner)."""
    out = np.empty((len(patches), 3), np.float32)  # each chunk's rows written by the kernel

    def traced(occluded16, scene, first, last):
        rows = np.arange(first, last, dtype=np.int64)
        rays = _samples(emitters, patches, tri_uv1, points, side, lift, rows, gather_rays, seed, occluded16, scene,
                        out[first:last])[5]
        return None, rays

    def chunk(first, last):
        tracer.occluding(traced, first, last)

    tracer.over_spans(chunk, 0, len(patches), TEXELS_PER_CHUNK)
    return out


def _samples(emitters: Emitters, patches: Patches, tri_uv1: np.ndarray, points: TexelPoints, side: int,
             lift: np.ndarray, rows: np.ndarray, gather_rays: float, seed: int, occluded16: int, scene: int,
             out: np.ndarray):
    """`_kernels.next_event_samples` of patches `rows`: with occluded16 0, the packed rays
    (ray ids, origins, directions, tmax, light) and 0; else, tracing through rtcOccluded16 at
    that address in the Embree `scene`, empty arrays and the rays traced, each texel's
    unblocked light written into out (R, 3) f32."""
    e = emitters
    return _kernels.next_event_samples(points.grid, side, patches.normal, lift, rows, e.cdf, e.pdf_area, e.triangles,
                                       e.corners, e.normals, e.two_sided, e.patch, tri_uv1, patches.width,
                                       patches.height, patches.index, patches.emission, float(gather_rays), seed,
                                       occluded16, scene, out)
