"""The passes: incident = direct + gathered, excident = incident x reflectance + emission.

Pass 1 lights the scene with the lights, the sky and the emitters (direct light holds the
emitters' next-event share, the gather's constant term S the rest); pass k adds the
(k-1)th bounce. Gathered light G = S + F B is known at computed patches and interpolated
at the rest (adaptive.py); patches inside geometry get no light of their own.
"""
from __future__ import annotations

import mmap
from dataclasses import dataclass, field

import numpy as np

from . import _kernels, adaptive
from .gather import Gatherer, PanelRows


ROWS_PER_BLOCK = 1 << 14  # patches gathered at a time, kept as one PanelBlock (at most 2^16 rows)
MIN_SPLIT_ROWS = 1 << 10  # rows gathered at once go to two blocks a core, down to blocks of this size: a product
                          # multiplies each run of blocks on one core (the sampler's first grid was one block)
RUN_BLOCKS = 4  # blocks one product task multiplies panel by panel (`BlockRun`): a fifth less CPU than 1, as 5; 10 lost it


@dataclass
class FormFactors:
    """The computed patches' rows: ids (C,), constant terms S (C, 3) (sky and the gather's share
    of emitted light), and F (C, N) as panel-major blocks (PanelBlock) while it fits in
    `budget` bytes. When the next block of rows would not fit, F is dropped, and every
    product re-gathers its rows chunk by chunk (Gatherer.product): bounded memory, the same
    answer (the ray pattern is seeded per patch), more rays."""

    gatherer: Gatherer
    budget: int
    kept: bool = True
    id_parts: list = field(default_factory=list)  # ids and S block by block, joined when read
    S_parts: list = field(default_factory=list)
    blocks: list = field(default_factory=list)
    lost_rays: int = 0
    rays: int = 0            # gather rays traced, here or on a cluster, once per computed patch
    rays_regathered: int = 0  # and again for every product once F is not kept
    rays_probed: int = 0      # probe rays that looked for patches inside geometry first
    _run_cache: tuple = ((0, 0), ())  # (first block, blocks kept) and the product's BlockRuns over them

    def probe_back_share(self, rows: np.ndarray) -> np.ndarray:
        """(R,) the share of a few probe rays from each patch of `rows` that meet back faces:
        patches it puts inside geometry (rays.inside) need no gather."""
        self.rays_probed += len(rows) * len(self.gatherer.probe_dirs)
        return self.gatherer.probe_back_fraction(rows)

    def add(self, rows: np.ndarray, progress=None) -> np.ndarray:
        """Gather patches `rows`; returns their share of rays that hit back faces."""
        size = min(ROWS_PER_BLOCK, max(MIN_SPLIT_ROWS, -(-len(rows) // (2 * self.gatherer.tracer.threads))))
        back = [self._add_block(rows[s:s + size], progress) for s in range(0, len(rows), size)]
        return np.concatenate(back) if back else np.zeros(0, np.float32)

    def _add_block(self, rows: np.ndarray, progress) -> np.ndarray:
        g = self.gatherer.gather(rows, progress)
        self.rays += len(rows) * self.gatherer.rays_per_patch
        self.id_parts.append(rows)
        self.S_parts.append(g.S)
        self.lost_rays += g.lost
        if self.kept and self.nbytes + PanelBlock.size_of(g.F, self.gatherer.unit) <= self.budget:
            self.blocks.append(PanelBlock.of(g.F, self.gatherer.tracer.map, self.gatherer.unit))
        else:
            self.kept, self.blocks, self._run_cache = False, [], ((0, 0), ())
        return g.back_fraction

    def product(self, B: np.ndarray, first: int = 0) -> np.ndarray:
        """(C - first, 3) F @ B for the computed rows first.. in `ids` order."""
        if not self.kept:
            ids = self.ids[first:]
            self.rays_regathered += len(ids) * self.gatherer.rays_per_patch
            return self.gatherer.product(ids, B)
        ends = np.cumsum([0] + [block.n_rows for block in self.blocks])
        k = max(int(np.searchsorted(ends, first, side="right")) - 1, 0)  # the block that holds row first
        if k >= len(self.blocks):
            return np.zeros((0, 3), np.float32)
        B = np.ascontiguousarray(B, np.float32)
        runs = self._runs_from(k)
        largest_first = sorted(range(len(runs)), key=lambda i: -runs[i].entries)  # the cores then end together
        parts = dict(zip(largest_first, self.gatherer.tracer.map(lambda i: runs[i].times(B), largest_first)))
        return np.concatenate([parts[i] for i in range(len(runs))])[first - ends[k]:]

    def _runs_from(self, k: int) -> list[BlockRun]:
        """The product's tasks over blocks k.. (`_runs`), made once while the blocks stay the same."""
        if self._run_cache[0] != (k, len(self.blocks)):
            runs = _runs(self.blocks[k:], self.gatherer.tracer.threads)
            self._run_cache = ((k, len(self.blocks)), [BlockRun(run) for run in runs])
        return self._run_cache[1]

    @property
    def ids(self) -> np.ndarray:
        """(C,) the computed patches, in the order of F's rows."""
        return _joined(self.id_parts, np.zeros(0, np.int64))

    @property
    def S(self) -> np.ndarray:
        """(C, 3) f32 their constant terms."""
        return _joined(self.S_parts, np.zeros((0, 3), np.float32))

    @property
    def entries(self) -> int:
        """F's entries kept: one per (row, patch seen), or, uniform, per ray that sees a patch."""
        return int(sum(len(block.entries) for block in self.blocks))

    @property
    def nbytes(self) -> int:
        return int(sum(block.nbytes for block in self.blocks))


@dataclass
class PanelBlock:
    """Rows of F (a gathered block, at most 2^16) column panel by column panel, each panel in
    column order, rows ascending within a column: panel p's entries are starts[p]..starts[p + 1]
    of entries (u32: the column within the panel << 16 | the block's row) and weights (f32),
    or, a uniform block (weights empty), each entry weighs `unit`, once per ray. The unit of
    F B one core multiplies at a time."""

    starts: np.ndarray
    entries: np.ndarray
    weights: np.ndarray
    unit: float
    n_rows: int

    @classmethod
    def of(cls, pieces: list[PanelRows], run, unit: float | None = None) -> PanelBlock:
        """The rows of `pieces` (the gather's chunks, one after the other, at most 2^16 rows in
        all) put together panel by panel on `run` (Tracer.map): each panel's task sorts the
        pieces' entries of its panel by column into the block. unit: the weight of every
        entry of a uniform gather's pieces (`Gatherer.unit`); None: each word holds its own.
        Empties `pieces`."""
        n_rows = sum(piece.n_rows for piece in pieces)
        if n_rows > 1 << 16:
            raise ValueError(f"a panel block holds at most 2^16 rows (u16 row ids), not {n_rows}")
        unit_f32 = np.float32(0.0 if unit is None else unit)
        if not pieces:
            return cls(np.zeros(1, np.int64), np.zeros(0, np.uint32), np.zeros(0, np.float32), unit_f32, 0)
        piece_starts = np.stack([piece.starts for piece in pieces])
        starts = piece_starts.sum(axis=0)  # each panel starts where it starts in the pieces together
        first_rows = np.cumsum([0] + [piece.n_rows for piece in pieces[:-1]])
        words = [piece.entries for piece in pieces]  # kept until the block is made, no longer
        table = _kernels.address_table(words)
        pieces.clear()
        nnz = int(starts[-1])
        entries, weights = _small_paged(nnz, np.uint32), _small_paged(0 if unit is not None else nnz, np.float32)
        run(lambda p: _kernels.panel_in_column_order(p, piece_starts, first_rows, table, entries[starts[p]:starts[p + 1]],
                                                     weights[starts[p]:starts[p + 1]]), list(range(len(starts) - 1)))
        return cls(starts, entries, weights, unit_f32, n_rows)

    @property
    def nbytes(self) -> int:
        return self.starts.nbytes + self.entries.nbytes + self.weights.nbytes

    @staticmethod
    def size_of(pieces: list[PanelRows], unit: float | None = None) -> int:
        """The bytes `of` makes of these pieces: four an entry, four more for its weight unless
        uniform (their words take eight), and the panels' starts."""
        entries = sum(len(piece.entries) for piece in pieces)
        return entries * (4 if unit is not None else 8) + 8 * len(pieces[0].starts if pieces else [0])


def _small_paged(count: int, dtype) -> np.ndarray:
    """(count,) of dtype, uninitialised, in an anonymous mapping of its own: 4 KiB pages,
    where NumPy asks for huge pages for every array of 4 MiB or more. For what the bake
    writes once and keeps, read in order: F's blocks and the passes' float16 records. Huge
    pages spare them no TLB misses, and a huge page new to the process costs more to fault
    in than its 512 small ones (on a VM measured here, system CPU s: the room at 2048, 450
    MB of F, 1.05-1.28 -> 0.38-0.64 in the gather; the passes' records at 2048, 0.48-0.65
    -> 0.11-0.12 in the Cornell box's passes, 0.83-0.90 -> 0.61-0.70 in the room's)."""
    if count == 0:
        return np.empty(0, dtype)
    private = mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS  # mmap's default, MAP_SHARED, is shared memory: twice the cost
    return np.frombuffer(mmap.mmap(-1, count * np.dtype(dtype).itemsize, flags=private), dtype)


class BlockRun:
    """Consecutive blocks of F that one task multiplies by B, panel by panel across the blocks
    (`_kernels.blocks_times_rgb`), their arrays' address tables made once for every product
    (the run keeps the blocks, so their arrays outlive every call)."""

    def __init__(self, blocks: list[PanelBlock]):
        self._blocks = blocks
        self.entries = sum(len(block.entries) for block in blocks)
        self._lists = (*(_kernels.address_table([getattr(b, name) for b in blocks])
                         for name in ("starts", "entries", "weights")),
                       np.float32([b.unit for b in blocks]),
                       np.array([b.n_rows for b in blocks], np.int64)) if blocks else None

    def times(self, B: np.ndarray) -> np.ndarray:
        """(the blocks' rows, 3) f32: their rows of F times B (N, 3) f32, one after the other,
        on the calling thread."""
        if self._lists is None:
            return np.zeros((0, 3), np.float32)
        return _kernels.blocks_times_rgb(*self._lists, B)


def _runs(blocks: list[PanelBlock], threads: int) -> list[list[PanelBlock]]:
    """The blocks cut into runs of consecutive blocks (about RUN_BLOCKS each, as many runs as a
    multiple of the threads), each with about as many entries: one product task each."""
    if not blocks:
        return []
    count = threads * -(-len(blocks) // (threads * RUN_BLOCKS))
    ends = np.cumsum([len(b.entries) + 1 for b in blocks])
    cuts = np.searchsorted(ends, ends[-1] * np.arange(1, count) / count, side="right")
    bounds = np.unique(np.concatenate([[0], cuts, [len(blocks)]]))
    return [blocks[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


def _joined(parts: list, empty: np.ndarray) -> np.ndarray:
    """The parts concatenated, kept in `parts` as its one part: joined once, not block by block."""
    if len(parts) != 1:
        parts[:] = [np.concatenate(parts) if parts else empty]
    return parts[0]


@dataclass
class Solution:
    """incident I (N, 3), excident B (N, 3), gathered G (N, 3) and reflected B - E (N, 3) f32,
    the change after each pass."""

    incident: np.ndarray
    excident: np.ndarray
    gathered: np.ndarray
    reflected: np.ndarray
    changes: list[float]


def gathered_light(ff: FormFactors, reflected: np.ndarray | None, status: np.ndarray, order: adaptive.Order,
                   G: np.ndarray, first: int = 0) -> np.ndarray:
    """Fill G (N, 3) f32 in place with S + F (B - E) at the computed patches of rows first..
    (in `ids` order; those before keep their G), interpolated elsewhere, and return it: the
    gather's emitted light is in S with the sky (its MIS share beside the direct stage's), F
    carries the reflected light rho I (None: nothing is reflected yet, F (B - E) = 0 is not
    computed). Every patch is computed, a target of the sampler or inside geometry (0), so
    all of G is written."""
    spread = ff.gatherer.tracer.over_spans
    ids, S = ff.ids[first:], ff.S[first:]
    product = np.zeros(S.shape, np.float32) if reflected is None else ff.product(reflected, first)
    spread(lambda a, b: _kernels.scatter_sum(G, ids[a:b], S[a:b], product[a:b]), 0, len(ids))
    return adaptive.interpolate(G, status, order, spread)


def solve(ff: FormFactors, direct: np.ndarray, rho: np.ndarray, emission: np.ndarray, status: np.ndarray,
          order: adaptive.Order, passes: int, tolerance: float, start: Solution | None = None, warm: bool = False,
          on_pass=None) -> Solution:
    """Run passes until the relative change still to come (`change_to_come`) is below
    `tolerance`, or `passes` passes. start: an earlier solution whose arrays this one takes
    over and writes (None: fresh arrays); warm: begin from its reflected light, else from
    B = E (pass 1 lights the scene with what is emitted). on_pass(k, change, half) is called
    after each pass, half: its incident light as float16 (N, 3), a fresh array written by
    the pass's sweep. Every sweep runs in tasks on both cores."""
    if warm and start is None:
        raise ValueError("a warm solve starts from an earlier solution: pass it as start")
    spread = ff.gatherer.tracer.over_spans
    inside = status == adaptive.INSIDE
    if start is None:  # fresh buffers, their pages first touched by the pool's tasks, not here
        I, previous, G, reflected = (np.empty(emission.shape, np.float32) for _ in range(4))
    else:
        I, previous, G, reflected = start.incident, start.excident, start.gathered, start.reflected
    changes = []
    for k in range(1, passes + 1):
        I, previous = previous, I  # this pass writes over the one before the last
        gathered_light(ff, reflected if warm or k > 1 else None, status, order, G)  # B = E: F (B - E) = 0
        half = (_small_paged(I.size, np.float16) if on_pass is not None else np.zeros(0, np.float16)).reshape(-1, 3)
        bits = half.view(np.uint16)
        spread(lambda a, b: _kernels.pass_light(
            direct[a:b], G[a:b], inside[a:b], rho[a:b], emission[a:b], I[a:b], reflected[a:b], bits[a:b]), 0, len(I))
        changes.append(1.0 if k == 1 else relative_change(I, previous, spread))
        if on_pass is not None:
            on_pass(k, changes[-1], half)
        if change_to_come(changes) < tolerance:
            break
    B = previous  # the pass before the last is done with
    spread(lambda a, b: _kernels.excident(I[a:b], rho[a:b], emission[a:b], B[a:b]), 0, len(I))
    return Solution(I, B, G, reflected, changes)


def change_to_come(changes: list[float]) -> float:
    """How much I may still change in all passes to come, from the changes so far (the first
    is a placeholder, 1: nothing to compare with). The passes contract by r, estimated as the
    larger of the last two ratios of real changes (one ratio alone is fooled by a jump, e.g.
    after the sampler marks texels inside); the rest is the geometric series last r / (1 - r).
    Infinite until three real changes shrink. A bright closed scene (rho 0.9, r ~ 0.9) thus
    runs until its last change is tolerance / 9, where the plain last change would stop it
    ten times too early."""
    real = changes[1:]
    if real and real[-1] == 0.0:
        return 0.0
    if len(real) < 3:
        return float("inf")
    r = max(real[-1] / real[-2], real[-2] / real[-3])
    return float("inf") if r >= 1.0 else real[-1] * r / (1.0 - r)


def relative_change(current: np.ndarray, previous: np.ndarray, spread) -> float:
    """Largest per-texel change |I_k - I_k-1| / I_k, over texels brighter than a hundredth of
    the mean (so that nearly black texels' noise does not decide); in spans on `spread`
    (Tracer.over_spans)."""
    floor = np.float32(1e-2 * float(current.mean()) + 1e-30)
    return float(max(spread(lambda a, b: _kernels.largest_relative_change(
        current[a:b], previous[a:b], floor), 0, len(current)), default=0.0))
