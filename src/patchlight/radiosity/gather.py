"""The gather: each computed patch looks at the scene through its hemicube (or stratified
cosine rays), and the item buffer turns what each ray hits into a patch id or the sky.

One patch's row of the form-factor matrix F holds the weight of every patch it sees (the
multiplier-map weights of the pixels that see it, summed; the stratified gather, whose rays
all weigh the same, keeps an entry per ray instead, see `Gatherer.unit`), and its constant term S the
weighted sky radiance of the rays that escaped plus the emission of the emitters they hit
(its MIS share, see emitters.py). Geometry does not change between passes, so F is traced
once and every pass is a sparse product of the reflected light: I = D + S + F (B - E).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..atlas.patches import Patches
from ..rays.hemisphere import hemisphere_rays
from ..rays.inside import back_faces, back_share, two_sided_triangles
from ..rays.tracer import Tracer, tapered_spans
from ..scene.model import Scene
from . import _kernels
from ._kernels import BACK_FACE, LOST, SKY  # what a ray of the item buffer saw, beside a patch id
from .emitters import Emitters
from .hemicube import multiplier_map, stratified_directions

FLOAT32_REACH = 1e-5      # relative lift that clears float32 rounding of hit points (2^-24 ~ 6e-8)
RAYS_PER_CHUNK = 1 << 16  # one task: ray generation, trace and item buffer on one core
LAST_CHUNK_RAYS = 1 << 13  # the smallest a call's tapering chunks get
PROBE_RAYS = 16           # cosine rays that first test whether a patch lies inside geometry


def ray_offsets(scene: Scene, patches: Patches) -> np.ndarray:
    """(N,) distance to lift ray origins off each patch: a twentieth of its texel, and never
    less than float32's reach where the patch lies (FLOAT32_REACH of its largest coordinate,
    over a hundred float32 steps, plus a millionth of the scene's size)."""
    lo, hi = scene.bounds()
    return _kernels.ray_offsets(patches.position, patches.size, np.float32(FLOAT32_REACH),
                                np.float32(1e-6 * float(np.max(hi - lo))))


def load_first_kernel() -> bool:
    """Load `ray_offsets`' kernel from numba's cache as a bake will call it: a process's first
    kernel starts numba's code generator, 0.2 s, which a bake pays on a thread while it waits
    for the UVs. Returns False when numba had to compile it for this call, as on a machine's
    first bake after installing or changing the kernels, which compiles each as the bake
    first calls it (about a minute of one core in all); True when it came from the cache or
    the process had it already."""
    misses = _kernels.ray_offsets.stats.cache_misses  # numba's running count, per signature
    before = sum(misses.values())
    _kernels.ray_offsets(np.zeros((1, 3), np.float32), np.ones(1, np.float32), np.float32(0), np.float32(0))
    return sum(misses.values()) == before


@dataclass
class PanelRows:
    """Consecutive rows of F, one chunk's (`_kernels.item_buffer_rows`), column panel by column
    panel (`_kernels.PANEL_BITS` columns each), each panel in row order: panel p's entries
    are starts[p]..starts[p + 1] (starts: (panels + 1,) int64) of entries, u64 words
    (`_kernels.entry_word`: weight, column within the panel, row among the n_rows; weight
    bits 0 when the gather is uniform, `Gatherer.unit`)."""

    starts: np.ndarray
    entries: np.ndarray
    n_rows: int

    @property
    def nbytes(self) -> int:
        return self.starts.nbytes + self.entries.nbytes


@dataclass
class GatherRows:
    """Rows of the gather for some patches. F: their rows of F in pieces of consecutive rows,
    one PanelRows per chunk; S: (R, 3) f32 constant term; back_fraction: (R,) share of rays
    that hit back faces; lost: rays on uncovered texels."""

    F: list[PanelRows]
    S: np.ndarray
    back_fraction: np.ndarray
    lost: int


class Gatherer:
    """Traces gather rays for chosen patches of one scene.

    method: "hemicube" (size = pixels across the front face) or "stratified" (size = rays).
    From the scene it keeps the corners' lightmap UVs (`Scene.triangle_uv1`), two_sided: (T,) bool,
    the triangles whose back faces are ordinary surfaces (doubleSided), the sky, and offset:
    how far each patch's rays start off it (`ray_offsets`).
    emitters: the scene's `Emitters` when the direct stage samples them with `nee_samples`
    shadow rays per texel; a ray that hits an emitter then counts its emission with the
    complementary MIS weight into the constant term S. None: the gather alone sees emitters.
    unit: the weight every ray carries when all are the same (stratified), else None (the
    hemicube's multiplier map): F then keeps one entry per ray that sees a patch and no
    weights (`_kernels.item_buffer_rows`, `solve.PanelBlock`).
    """

    def __init__(self, scene: Scene, patches: Patches, tracer: Tracer, method: str, size: int, seed: int = 1,
                 emitters: Emitters | None = None, nee_samples: int = 0):
        self.patches, self.tracer, self.sky = patches, tracer, scene.sky
        self.tri_uv1, self.two_sided = scene.triangle_uv1(), two_sided_triangles(scene)
        self.method, self.seed, self.offset = method, seed, ray_offsets(scene, patches)
        self.emitters, self.nee_samples = emitters, nee_samples
        self.emitting = _kernels.emitting_patches(patches.emission)
        self.emits = bool(np.any(self.emitting[1]))
        self.ranks = _kernels.texel_ranks(patches.index)
        self.panels = _kernels.panel_count(len(patches))
        if method == "hemicube":
            self.dirs, self.weights = multiplier_map(size)
        elif method == "stratified":
            self.dirs, self.weights = stratified_directions(size, np.random.default_rng(seed))
        else:
            raise ValueError(f"unknown gather method {method!r}")
        self.unit = float(self.weights[0]) if np.all(self.weights == self.weights[0]) else None
        self.probe_dirs, _ = stratified_directions(PROBE_RAYS, np.random.default_rng(seed))
        self.cluster = None  # a cluster.RayCluster runs the chunks as Ray tasks; None: here

    def __getstate__(self):
        return dict(self.__dict__, cluster=None)

    @property
    def rays_per_patch(self) -> int:
        return len(self.dirs)

    def _chunks(self, rows: np.ndarray, rays_per_patch: int | None = None) -> list[np.ndarray]:
        """`rows` in chunks of at most RAYS_PER_CHUNK rays, tapering (`tapered_spans`) to
        LAST_CHUNK_RAYS: both cores finish a gather's (or probe's) call together."""
        per_patch = rays_per_patch or self.rays_per_patch
        cut = tapered_spans(0, len(rows), max(1, RAYS_PER_CHUNK // per_patch), 2 * self.tracer.threads,
                            max(1, LAST_CHUNK_RAYS // per_patch))
        return [rows[first:last] for first, last in cut]

    def probe_back_fraction(self, rows: np.ndarray) -> np.ndarray:
        """(R,) share of PROBE_RAYS cosine rays from each patch of `rows` that hit back faces:
        a cheap look before a patch inside a wall or under an object pays for its gather."""
        def probe(chunk):  # back faces only: no texel look-ups
            hits = self.tracer.intersect_chunk(*self._rays(chunk, self.probe_dirs))
            return back_share(back_faces(hits.tri, hits.front, self.two_sided).reshape(len(chunk), -1))

        parts = self.tracer.map(probe, self._chunks(rows, PROBE_RAYS))
        return np.concatenate(parts) if parts else np.zeros(0)

    def gather(self, rows: np.ndarray, progress=None) -> GatherRows:
        """Trace and resolve the rays of patches `rows` (R,) into their F rows (chunk by chunk)
        and sky term."""
        chunks = self._chunks(rows)
        if self.cluster is not None:
            parts = self.cluster.gather(self, chunks, progress)
        else:
            parts = self.tracer.map(lambda chunk: self.gather_chunk(chunk, progress), chunks)
        if not parts:
            return GatherRows([], np.zeros((0, 3), np.float32), np.zeros(0, np.float32), 0)
        return GatherRows([piece for p in parts for piece in p.F],
                          np.concatenate([p.S for p in parts]),
                          np.concatenate([p.back_fraction for p in parts]),
                          sum(p.lost for p in parts))

    def product(self, rows: np.ndarray, B: np.ndarray) -> np.ndarray:
        """(R, 3) the rows `rows` of F B (B: the reflected light, emission is in S), traced again chunk by chunk and never stored: the
        re-gathering pass of a bake whose F does not fit in memory (runs here, not on Ray)."""
        B = np.ascontiguousarray(B, np.float32)
        parts = self.tracer.map(lambda chunk: _kernels.item_buffer_times(self._see(chunk, self.dirs)[0],
                                                                         self.weights, B), self._chunks(rows))
        return np.concatenate(parts) if parts else np.zeros((0, 3), np.float32)

    def look(self, row: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What patch `row` sees through the bake's own pattern, turned as in its gather: the
        item buffer (D,) (patch id or SKY / BACK_FACE / LOST), the world directions (D, 3) and
        the share of its emission each ray counts (D,) (`emission_shares`)."""
        seen, dirs, hits = self._see(np.array([row], np.int64), self.dirs)
        return seen, dirs, self.emission_shares(seen, hits, dirs)

    def look_rows(self, rows: np.ndarray, fn) -> list:
        """fn(chunk, seen, dirs) for each of the gather's chunks of patches `rows`, on the
        tracer's threads, results in order: chunk (C,) the patches, seen (C * D,) what their
        rays see (as `look`) and dirs (C * D, 3) the rays' world directions, turned as in
        their gather."""
        return self.tracer.map(lambda chunk: fn(chunk, *self._see(chunk, self.dirs)[:2]), self._chunks(rows))

    def _rays(self, rows: np.ndarray, local_dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Origins and directions (R * D, 3) f32 of patches `rows` looking along `local_dirs` (D, 3)."""
        p = self.patches
        return hemisphere_rays(p.position, p.normal, self.offset, rows.astype(np.int64), local_dirs, self.seed)

    def _see(self, rows: np.ndarray, local_dirs: np.ndarray):
        """The item buffer of patches `rows` looking along `local_dirs` (D, 3): (R * D,) patch
        id or SKY / BACK_FACE / LOST per ray, the rays' directions (R * D, 3) and their Hits."""
        p = self.patches
        origins, dirs = self._rays(rows, local_dirs)
        hits = self.tracer.intersect_chunk(origins, dirs)
        seen = _kernels.resolve_hits(hits.tri, hits.normal, dirs, hits.u, hits.v, self.two_sided, self.tri_uv1,
                                     p.width, p.height, self.ranks)
        return seen, dirs, hits

    def sky_seen(self, seen: np.ndarray, dirs: np.ndarray) -> np.ndarray:
        """(K, 3) the sky's radiance along the K rays of `seen` that escape, in ray order (0
        without a sky)."""
        sky_dirs = _kernels.sky_directions(seen, dirs)
        if self.sky is None or len(sky_dirs) == 0:
            return np.zeros((len(sky_dirs), 3), np.float32)
        return self.sky.radiance(sky_dirs)

    def gather_chunk(self, rows: np.ndarray, progress=None) -> GatherRows:
        """One chunk's rows (the unit of work a Ray task runs)."""
        seen, dirs, hits = self._see(rows, self.dirs)
        starts, entries, S, back, lost = _kernels.item_buffer_rows(seen, self.weights, self.sky_seen(seen, dirs),
                                                                   self.panels, self.unit is not None)
        if self.emits:
            S += self._emission_seen(seen, hits, dirs)
        if progress is not None:
            progress(len(rows))
        return GatherRows([PanelRows(starts, entries, len(rows))], S, back, lost)

    def emission_shares(self, seen: np.ndarray, hits, dirs: np.ndarray) -> np.ndarray:
        """(R * D,) f32 the share of its emission each ray counts: 1 on emitters without
        next-event estimation, else its MIS weight (the direct stage's `emitter_light`
        holds the rest); 0 for rays that meet no emitting patch."""
        return _kernels.emission_shares(seen, hits.tri, hits.t, dirs, self.dirs, self.emitting, *self._next_event())

    def _emission_seen(self, seen: np.ndarray, hits, dirs: np.ndarray) -> np.ndarray:
        """(R, 3) f32 the emitted light the rays count (`emission_shares`), weighted."""
        return _kernels.weighted_emission(seen, hits.tri, hits.t, dirs, self.dirs, self.weights, self.emitting,
                                          self.patches.emission, *self._next_event())

    def _next_event(self) -> tuple[np.ndarray, np.ndarray, float]:
        """What the emission shares weigh against: the emitters' next-event pdf per m^2 (T,),
        their normals (T, 3) and the samples per texel (0: the gather alone sees emitters)."""
        e = self.emitters
        if e is None or self.nee_samples == 0:
            return np.zeros(0), np.zeros((0, 3)), 0.0
        return e.pdf_area, e.tri_normal, float(self.nee_samples)
