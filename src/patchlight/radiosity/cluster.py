"""Scaling out: the gather's chunks as Ray tasks (DESIGN.md, "Scaling out").

Each chunk of patches needs the whole scene and returns its form-factor rows; the solve is
cheap and stays here. The Gatherer (scene triangles, patches, ray pattern) goes into Ray's
object store once; each worker builds its Embree BVH on first use and keeps it for the
bake's later chunks. `address` is a Ray cluster address, or "local" for a Ray started on
this machine (the same code path, handy for trying it out).
"""
from __future__ import annotations

import uuid

from ..errors import PatchlightError

_WORKER_GATHERERS: dict = {}  # per Ray worker process: bake token -> Gatherer with its BVH


def _run_chunk(token: str, gatherer, rows):
    """Ray task body: one chunk's rows, reusing this worker's Gatherer for the bake."""
    cached = _WORKER_GATHERERS.setdefault(token, gatherer)
    return cached.gather_chunk(rows)


class RayCluster:
    """Runs Gatherer chunks as Ray tasks on the cluster at `address` ("local": start one)."""

    def __init__(self, address: str):
        try:
            import ray
        except ImportError:
            raise PatchlightError("--ray needs the ray package: pip install 'patchlight[cluster]'") from None
        self._ray = ray
        if not ray.is_initialized():
            try:
                ray.init(address=None if address == "local" else address, include_dashboard=False,
                         log_to_driver=False, configure_logging=False)
            except (ConnectionError, ValueError, RuntimeError) as exc:
                raise PatchlightError(f"--ray {address}: cannot join the Ray cluster ({exc})") from None
        self._task = ray.remote(_run_chunk)
        self._token = uuid.uuid4().hex
        self._shipped = None  # (gatherer, its object-store reference): shipped once per bake

    def gather(self, gatherer, chunks, progress=None) -> list:
        """GatherRows of every chunk, in order."""
        ray = self._ray
        if self._shipped is None or self._shipped[0] is not gatherer:
            self._shipped = (gatherer, ray.put(gatherer))
        futures = [self._task.remote(self._token, self._shipped[1], rows) for rows in chunks]
        pending, done = list(futures), {}
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            for future in ready:
                done[future] = ray.get(future)
                if progress is not None:
                    progress(done[future].F.shape[0])
        return [done[f] for f in futures]
