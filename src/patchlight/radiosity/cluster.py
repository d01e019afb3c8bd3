"""Scaling out: the gather's chunks as Ray tasks.

Each chunk of patches needs the whole scene and returns its form-factor rows; the solve is
cheap and stays here. The Gatherer (scene triangles, patches, ray pattern) goes into Ray's
object store once; each worker builds its Embree BVH on first use and keeps it for the
bake's later chunks. `address` is a Ray cluster's address (`host:port` of its head, `auto`,
or `ray://host:port` for Ray Client), or "local" for a Ray started on this machine.

Every wait is bounded: the head's port is probed for CONNECT_SECONDS, Ray's own attempt to
join is held to one try of CONNECT_SECONDS, and a gather whose cluster finishes no task for
TASK_SECONDS is stopped; each failure is one line (PatchlightError).
"""
from __future__ import annotations

import contextlib
import os
import socket
import tempfile
import uuid
from collections import Counter

from ..errors import PatchlightError

CONNECT_SECONDS = 5   # TCP probe of the head, and each of Ray's connection timeouts
TASK_SECONDS = 600    # no chunk finished for this long: the cluster is stuck (or has no CPU)

_WORKER_GATHERERS: dict = {}  # per Ray worker process: bake token -> Gatherer with its BVH


def _run_chunk(token: str, gatherer, rows):
    """Ray task body: (the node that ran it, one chunk's rows), reusing this worker's
    Gatherer for the bake."""
    import ray

    cached = _WORKER_GATHERERS.setdefault(token, gatherer)
    return ray.get_runtime_context().get_node_id(), cached.gather_chunk(rows)


def _host_port(address: str) -> tuple[str, int] | None:
    """(host, port) of a `host:port` or `ray://host:port` address; None for "auto"."""
    if address == "auto":
        return None
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not host or not port.isdigit():
        raise PatchlightError(f"`ray` {address}: expected HOST:PORT of the cluster's head, auto or local")
    return host.strip("[]"), int(port)


def _probe(address: str) -> None:
    """Fail in CONNECT_SECONDS when nothing listens at the address (Ray itself would retry
    for minutes)."""
    where = _host_port(address)
    if where is None:
        return
    try:
        socket.create_connection(where, timeout=CONNECT_SECONDS).close()
    except OSError as exc:
        reason = "no answer" if isinstance(exc, TimeoutError) else (exc.strerror or str(exc))
        raise PatchlightError(f"`ray` {address}: cannot reach the Ray cluster's head ({reason} "
                              f"within {CONNECT_SECONDS} s)") from None


@contextlib.contextmanager
def _stderr_kept():
    """Holds what Ray's core writes straight to file descriptor 2 (retry warnings) while
    joining; yields a callable that returns it. A failure is then reported in one line."""
    with tempfile.TemporaryFile() as held:
        saved = os.dup(2)
        os.dup2(held.fileno(), 2)
        try:
            yield lambda: (held.seek(0), held.read().decode(errors="replace"))[1]
        finally:
            os.dup2(saved, 2)
            os.close(saved)


def _join(address: str):
    """The imported ray module, connected to `address` (or to a Ray started here)."""
    if address != "local":
        _probe(address)
        # Ray retries a silent head 20 times for 35 s each; one bounded try is enough once
        # the port answered. Read when ray is imported and when it connects.
        os.environ.setdefault("RAY_NUM_REDIS_GET_RETRIES", "1")
        os.environ.setdefault("RAY_py_gcs_connect_timeout_s", str(CONNECT_SECONDS))
    try:
        import ray
    except ImportError:
        raise PatchlightError("`ray` needs the ray package: pip install 'patchlight[cluster]'") from None
    if ray.is_initialized():
        return ray
    with _stderr_kept() as kept:
        try:
            ray.init(address=None if address == "local" else address, include_dashboard=False,
                     log_to_driver=False, configure_logging=False)
        except Exception as exc:  # ConnectionError, RpcError, AuthenticationError, ...
            detail = str(exc).strip().splitlines() or kept().strip().splitlines() or [type(exc).__name__]
            raise PatchlightError(f"`ray` {address}: cannot join the Ray cluster ({detail[0]})") from None
    if not ray.cluster_resources().get("CPU"):
        raise PatchlightError(f"`ray` {address}: the Ray cluster has no CPU to run the gather on")
    return ray


class RayCluster:
    """Runs Gatherer chunks as Ray tasks on the cluster at `address` ("local": start one).
    tasks_per_node counts the chunks each Ray node ran (node id -> tasks)."""

    def __init__(self, address: str):
        self.address = address
        self._ray = _join(address)
        self._task = self._ray.remote(_run_chunk).options(scheduling_strategy="SPREAD")  # every node works
        self._token = uuid.uuid4().hex
        self._shipped = None  # (gatherer, its object-store reference): shipped once per bake
        self.tasks_per_node: Counter = Counter()

    def gather(self, gatherer, chunks, progress=None) -> list:
        """GatherRows of every chunk, in order."""
        ray = self._ray
        if self._shipped is None or self._shipped[0] is not gatherer:
            self._shipped = (gatherer, ray.put(gatherer))
        futures = [self._task.remote(self._token, self._shipped[1], rows) for rows in chunks]
        pending, done = list(futures), {}
        while pending:
            ready, pending = ray.wait(pending, num_returns=1, timeout=TASK_SECONDS)
            if not ready:
                for future in pending:
                    ray.cancel(future, force=True)
                raise PatchlightError(f"`ray` {self.address}: no gather task finished within "
                                      f"{TASK_SECONDS} s ({len(pending)} of {len(futures)} waiting)")
            for future in ready:
                node, done[future] = ray.get(future)
                self.tasks_per_node[node] += 1
                if progress is not None:
                    progress(len(done[future].S))
        return [done[f] for f in futures]

    def to_json(self) -> dict:
        return {"address": self.address, "tasks_per_node": dict(self.tasks_per_node)}
