"""The ray tracer: Intel Embree (`embree.TriangleBvh`) behind one small interface.

Embree traces in numba kernels with the GIL released, so large batches are split into
chunks that the calling thread and a pool share (`Tracer.map`): every core works. Embree
takes float32 only and starts every ray at t = 0: callers offset their origins off the
surface themselves.
"""
from __future__ import annotations

import itertools
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..errors import PatchlightError
from .embree import TriangleBvh

CHUNK = 65536  # rays per task: large enough to amortise the call, small enough to balance 2 cores
TASK_ROWS = 1 << 16  # the most rows of a sweep one task takes (`spans`)
MIN_TASK_ROWS = 1 << 12


@nb.njit(cache=True, inline="always")
def faces_ray(normal, directions, i):
    """Ray i meets its triangle's front face: the geometric normal normal[i] (f32, its
    winding's) points back at the ray's direction directions[i] (the dot product in
    float32, summed in order x, y, z)."""
    dot = normal[i, 0] * directions[i, 0] + normal[i, 1] * directions[i, 1] + normal[i, 2] * directions[i, 2]
    return dot < np.float32(0.0)


@nb.njit(cache=True, nogil=True)
def _front_faces(tri, normal, directions):
    """(N,) bool `faces_ray` of the rays that hit a triangle (tri >= 0)."""
    out = np.empty(tri.shape[0], np.bool_)
    for i in range(tri.shape[0]):
        out[i] = tri[i] >= 0 and faces_ray(normal, directions, i)
    return out


@dataclass
class Hits:
    """Closest hits of N rays along directions (N, 3) f32. tri (N,) i32, -1 where the ray
    escaped; u, v (N,) barycentrics of corners 1 and 2; t (N,) distance along the (unit)
    direction; normal (N, 3) f32 the hit triangle's geometric normal (its winding's)."""

    tri: np.ndarray
    u: np.ndarray
    v: np.ndarray
    t: np.ndarray
    normal: np.ndarray
    directions: np.ndarray

    @property
    def front(self) -> np.ndarray:
        """(N,) bool: True where the ray met the triangle's front face (`faces_ray`), derived
        on each read, so it follows tri, normal and directions when a caller changes them."""
        return _front_faces(self.tri, self.normal, self.directions)


def spans(first: int, last: int, size: int | None = None) -> list[tuple[int, int]]:
    """Rows first..last-1 as (start, stop) spans of `size` rows; by default TASK_ROWS, or
    quarters of the rows (of at least MIN_TASK_ROWS) when that is shorter, so that both
    cores share small sweeps too."""
    size = size or min(TASK_ROWS, max(MIN_TASK_ROWS, -(-(last - first) // 4)))
    return [(s, min(s + size, last)) for s in range(first, last, size)]


def tapered_spans(first: int, last: int, size: int, parts: int, smallest: int = 1) -> list[tuple[int, int]]:
    """Rows first..last-1 as spans of at most `size` rows that taper towards the end, each
    1/parts of the rows still left (and at least `smallest`): workers taking them in order
    (`Tracer.map`) finish nearly together, where equal spans leave all but one waiting on
    the last (a guided schedule; parts = 2 x threads). For tasks whose rows are independent."""
    out, start = [], first
    while start < last:
        stop = min(start + min(size, max(smallest, -(-(last - start) // parts))), last)
        out.append((start, stop))
        start = stop
    return out


def _threads() -> int:
    return max(1, int(os.environ.get("PATCHLIGHT_THREADS", os.cpu_count() or 1)))


class _Batch:
    """Items handed out one at a time to whichever worker asks next (`Tracer.map`). The first
    exception an item raises stops the handing out and is raised by `results` once every
    item taken has finished (an interrupt that arrives between items, or while the caller
    waits, is raised at once). A helper that starts after the caller took every item finds
    none left: a map inside a pool's task cannot wait on itself."""

    def __init__(self, fn, items: list):
        self._fn, self._items = fn, items
        self._out = [None] * len(items)
        self._next = itertools.count()  # next() on a count is atomic under the GIL
        self._left = len(items)
        self._lock = threading.Lock()
        self._finished = threading.Event()
        self._error = None

    def work(self) -> None:
        """Take items until none is left; run each unless one has failed."""
        while (i := next(self._next)) < len(self._items):
            if self._error is None:
                try:
                    self._out[i] = self._fn(self._items[i])
                except BaseException as exc:  # an interrupt inside an item too: raised once the others stop
                    self._error = self._error or exc
            with self._lock:
                self._left -= 1
                if self._left == 0:
                    self._finished.set()

    def results(self) -> list:
        """Every item's result, in order, once all have finished; or the first exception."""
        self._finished.wait()
        if self._error is not None:
            raise self._error
        return self._out


class Tracer:
    """Closest-hit and occlusion queries against a fixed triangle soup.

    positions: (V, 3) float; indices: (T, 3) int. Triangle ids in results index `indices`.
    """

    def __init__(self, positions: np.ndarray, indices: np.ndarray):
        if len(indices) == 0:
            raise PatchlightError("cannot trace rays against a scene with no triangles")
        self.positions = np.ascontiguousarray(positions, np.float32)
        self.indices = np.ascontiguousarray(indices, np.int32)
        self._bvh = None
        self._pool = None
        self.rays_traced = 0
        self._count_lock = threading.Lock()  # chunks finish on several threads

    def _count(self, n: int) -> None:
        with self._count_lock:
            self.rays_traced += n

    def __reduce__(self):
        """Pickles as its triangles; the BVH is rebuilt where it is first used (a Ray worker)."""
        return Tracer, (self.positions, self.indices)

    def _ready(self) -> TriangleBvh:
        if self._bvh is None:
            self._bvh = TriangleBvh(self.positions, self.indices)
            self._pool = ThreadPoolExecutor(max(1, _threads() - 1))  # the caller of `map` is a worker too
        return self._bvh

    @property
    def threads(self) -> int:
        """How many items `map` runs at once: one per core, or PATCHLIGHT_THREADS."""
        return _threads()

    def map(self, fn, items: list) -> list:
        """fn over items, the results in order, on `threads` workers at once: the calling
        thread and threads - 1 of the tracer's pool, each taking the next item left (`_Batch`).
        For pipelines whose every stage releases the GIL: numba nogil kernels, Embree calls.
        The caller works too, so a batch costs a hand-off per helper, not a future per item."""
        self._ready()
        helpers = min(self.threads, len(items)) - 1
        if helpers <= 0:
            return [fn(item) for item in items]
        batch = _Batch(fn, items)
        for _ in range(helpers):
            self._pool.submit(batch.work)
        batch.work()
        return batch.results()

    def over_spans(self, fn, first: int, last: int, size: int | None = None) -> list:
        """fn(start, stop) over rows first..last-1 cut into `spans` (of `size` rows), as
        tasks on the pool (`map`), the results in order: how every sweep over rows is split."""
        return self.map(lambda span: fn(*span), spans(first, last, size))

    def _map(self, fn, n: int, *arrays):
        """fn over CHUNK-row slices of the row-aligned arrays; the list of chunk results."""
        return self.over_spans(lambda a, b: fn(*(x[a:b] for x in arrays)), 0, n, CHUNK)

    def intersect_chunk(self, origins: np.ndarray, directions: np.ndarray) -> Hits:
        """Closest hit of each ray, traced on the calling thread (see `intersect`)."""
        o = np.ascontiguousarray(origins, np.float32)
        d = np.ascontiguousarray(directions, np.float32)
        self._count(len(o))
        return Hits(*self._ready().closest(o, d), d)

    def intersect(self, origins: np.ndarray, directions: np.ndarray) -> Hits:
        """Closest hit of each ray. origins, directions: (N, 3); directions unit length."""
        d = np.ascontiguousarray(directions, np.float32)
        parts = self._map(self.intersect_chunk, len(origins), origins, d)
        if not parts:
            empty = np.zeros(0, np.float32)
            return Hits(np.zeros(0, np.int32), empty, empty, empty, np.zeros((0, 3), np.float32), d)
        return Hits(*(np.concatenate(x) for x in zip(*((h.tri, h.u, h.v, h.t, h.normal) for h in parts))), d)

    def occluded_chunk(self, origins: np.ndarray, directions: np.ndarray, tmax: np.ndarray) -> np.ndarray:
        """(N,) bool occlusion traced on the calling thread (see `occluded`); tmax (N,) f32."""
        self._count(len(origins))
        return self._ready().occluded(np.ascontiguousarray(origins, np.float32),
                                      np.ascontiguousarray(directions, np.float32), np.ascontiguousarray(tmax, np.float32))

    def occluding(self, kernel, *args):
        """kernel(occluded16, scene, *args) -> (result, rays traced), run on the calling
        thread: a function whose nopython kernel makes its own shadow rays and traces them in
        packets as it goes (`embree.occlude_packet`), no ray arrays between. Its rays are
        counted as `occluded_chunk`'s are; returns its result."""
        result, rays = self._ready().occluding(kernel, *args)
        self._count(rays)
        return result

    def occluded(self, origins: np.ndarray, directions: np.ndarray, tmax: np.ndarray | float) -> np.ndarray:
        """(N,) bool: True where something lies along the ray before distance tmax."""
        o = np.ascontiguousarray(origins, np.float32)
        d = np.ascontiguousarray(directions, np.float32)
        far = np.ascontiguousarray(np.broadcast_to(np.asarray(tmax, np.float32), (len(o),)))
        parts = self._map(self.occluded_chunk, len(o), o, d, far)
        return np.concatenate(parts) if parts else np.zeros(0, bool)
