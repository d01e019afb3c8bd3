"""The passes: incident = direct + gathered, excident = incident x reflectance + emission.

Pass 1 lights the scene with the lights, the sky and the emitters (B = E); pass k adds the
(k-1)th bounce. Gathered light G = S + F B is known at computed patches and interpolated
at the rest (adaptive.py); patches inside geometry get no light of their own.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from . import _kernels, adaptive
from .gather import Gatherer


@dataclass
class FormFactors:
    """The computed patches' rows: ids (C,), sky terms S (C, 3), and F (C, N) CSR when it is
    kept; otherwise F is re-gathered for every product (bounded memory, slower)."""

    gatherer: Gatherer
    keep: bool
    ids: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    S: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.float32))
    blocks: list = field(default_factory=list)
    lost_rays: int = 0
    rays: int = 0            # gather rays traced, here or on a cluster, once per computed patch
    rays_regathered: int = 0  # and again for every product when F is not kept

    def add(self, rows: np.ndarray, progress=None) -> np.ndarray:
        """Gather patches `rows`; returns their share of rays that hit back faces."""
        g = self.gatherer.gather(rows, progress)
        self.rays += len(rows) * self.gatherer.rays_per_patch
        self.ids = np.concatenate([self.ids, rows])
        self.S = np.concatenate([self.S, g.S])
        self.blocks.append(g.F if self.keep else rows)
        self.lost_rays += g.lost
        return g.back_fraction

    def product(self, B: np.ndarray) -> np.ndarray:
        """(C, 3) F @ B for the computed rows, in `ids` order."""
        if not self.blocks:
            return np.zeros((0, 3), np.float32)
        if not self.keep:
            self.rays_regathered += len(self.ids) * self.gatherer.rays_per_patch
        matrices = self.blocks if self.keep else (self.gatherer.gather(rows).F for rows in self.blocks)
        B = np.ascontiguousarray(B, np.float32)
        return np.concatenate([_kernels.csr_times_rgb(F.indptr, F.indices, F.data, B) for F in matrices])

    @property
    def nnz(self) -> int:
        return int(sum(F.nnz for F in self.blocks)) if self.keep else 0

    @property
    def nbytes(self) -> int:
        if not self.keep:
            return 0
        return int(sum(F.data.nbytes + F.indices.nbytes + F.indptr.nbytes for F in self.blocks))


@dataclass
class Solution:
    """incident I (N, 3), excident B (N, 3), gathered G (N, 3), change after each pass."""

    incident: np.ndarray
    excident: np.ndarray
    gathered: np.ndarray
    changes: list[float]


def gathered_light(ff: FormFactors, B: np.ndarray, status: np.ndarray, order) -> np.ndarray:
    """G (N, 3) = S + F B at computed patches, interpolated elsewhere."""
    G = np.zeros_like(B)
    G[ff.ids] = ff.S + ff.product(B)
    return adaptive.interpolate(G, status, order)


def solve(ff: FormFactors, direct: np.ndarray, rho: np.ndarray, emission: np.ndarray,
          status: np.ndarray, order, passes: int, tolerance: float, B0: np.ndarray | None = None,
          on_pass=None) -> Solution:
    """Run passes until the largest relative change of I (`relative_change`) is below
    `tolerance`, or `passes` passes. on_pass(k, change, I) is called after each pass."""
    inside = status == adaptive.INSIDE
    B = emission.copy() if B0 is None else B0
    previous, changes = None, []
    I = G = np.zeros_like(direct)
    for k in range(1, passes + 1):
        G = gathered_light(ff, B, status, order)
        I = direct + G
        I[inside] = 0.0
        B = rho * I + emission
        change = 1.0 if previous is None else relative_change(I, previous)
        changes.append(change)
        if on_pass is not None:
            on_pass(k, change, I)
        if change < tolerance:
            break
        previous = I
    return Solution(I, B, G, changes)


def relative_change(current: np.ndarray, previous: np.ndarray) -> float:
    """Largest per-texel change |I_k - I_k-1| / I_k, over texels brighter than a hundredth of
    the mean (so that nearly black texels' noise does not decide)."""
    floor = 1e-2 * float(current.mean()) + 1e-30
    return float((np.abs(current - previous) / np.maximum(current, floor)).max())


def estimate_matrix_bytes(n_rows: int, rays_per_patch: int) -> int:
    """Upper bound on the bytes of F: one f32 weight and one i32 column per ray."""
    return int(n_rows) * int(rays_per_patch) * 8
