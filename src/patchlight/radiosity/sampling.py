"""The adaptive sampler's driver: which patches the bake gathers, run after run.

Gather every 4th texel; then, for each run of the sampler (first at settings.first_accuracy,
then at settings.accuracy, adaptive.py), solve what is gathered so far (warm-started by the
run before) and let each of the sampler's steps decide which texels it must gather. Between
phases only the rows just gathered are multiplied by that solution's reflected light (one
product of the new rows, not passes over all of F): what the next phase decides on. Patches
found inside geometry (rays.inside: by a few probe rays first, else by their gather rays) are
marked INSIDE and get no light.
"""
from __future__ import annotations

import numpy as np

from ..atlas.patches import Patches
from ..config import BakeSettings
from ..progress import Progress
from ..rays.inside import is_inside
from ..rays.tracer import Tracer
from . import _kernels, adaptive
from .solve import FormFactors, gathered_light, solve

REFINE_MARGIN_SHARE = 0.25  # a run's solve stops when the change still to come is this share of its margin
REFINE_PASSES = 100         # (`refine_tolerance`), after at most this many passes


def refine_tolerance(accuracy: float, tolerance: float) -> float:
    """The tolerance of the solve a run of the sampler at `accuracy` decides on: a quarter of
    the margin its nearest threshold leaves, 1 - accuracy ** 2 (spacing 2's), and no tighter
    than the bake's own `tolerance`. Neighbours whose light changes by less than that agree or
    differ as they will when converged: at 0.98, 1e-2 (thresholds 8 and 4 %); at 0.5, 0.19
    (thresholds of contrasts 4 and 16: fewer passes decide them as well)."""
    return max(tolerance, REFINE_MARGIN_SHARE * (1.0 - accuracy ** 2))


def gather_adaptive(ff: FormFactors, patches: Patches, direct: np.ndarray, settings: BakeSettings,
                    progress: Progress):
    """Run the adaptive sampler, first at settings.first_accuracy, then at settings.accuracy
    (adaptive.py); returns (status, order, solution): the sampler's interpolation order
    (`adaptive.Order`) and its last run's solution (None without runs), whose arrays a
    later solve can take over."""
    n = len(patches)
    status = np.zeros(n, np.int8)
    if settings.adaptive:
        grid, phases = adaptive.sampler_plan(patches)
    else:
        grid, phases = np.arange(n), []
    order = adaptive.flatten(phases, patches.height)
    noise = adaptive.gather_noise(ff.gatherer.rays_per_patch) if settings.gather == "stratified" else 0.0
    solution = None
    with progress.stage("gather", total=n) as advance:
        _compute(ff, grid, status, advance)
        for accuracy in (settings.first_accuracy, settings.accuracy) if phases else ():
            adaptive.reopen(status)
            solution = solve(ff, direct, patches.rho, patches.emission, status, order, REFINE_PASSES,
                             refine_tolerance(accuracy, settings.tolerance), start=solution, warm=solution is not None)
            first = len(ff.ids)
            for k, phase in enumerate(phases):
                if k:  # the rows the phase before gathered, lit by the run's solution
                    gathered_light(ff, solution.reflected, status, order, solution.gathered, first)
                    first = len(ff.ids)
                for step in phase:
                    rows = adaptive.decide(step, status, solution.gathered, accuracy, noise,
                                           ff.gatherer.tracer.over_spans)
                    _compute(ff, rows, status, advance)
    return status, order, solution


def _compute(ff: FormFactors, rows: np.ndarray, status: np.ndarray, advance) -> None:
    """Gather patches `rows`, but for those a probe or their own gather finds inside geometry."""
    inside = is_inside(ff.probe_back_share(rows), "patch probe")
    status[rows[inside]] = adaptive.INSIDE
    advance(int(inside.sum()))
    rows = rows[~inside]
    status[rows] = adaptive.COMPUTED
    back = ff.add(rows.astype(np.int64), progress=advance)
    status[rows[is_inside(back, "patch")]] = adaptive.INSIDE


def walled_inside(patches: Patches, inside: np.ndarray, tracer: Tracer, offset: np.ndarray) -> np.ndarray:
    """(N,) bool: patches inside geometry (inside (N,) bool) whose valid 8-neighbours lie on
    both sides of it (the foot of a wall thinner than a texel): the straight line between two
    of them, lifted off the surface by offset (N,), is blocked. Filled from either side, such
    a texel would carry that side's light through the wall; it stays dark instead."""
    texel, first, other = _kernels.wall_pairs(patches.index, inside, patches.texel_y, patches.texel_x)
    start, end = _lifted(patches, offset, first), _lifted(patches, offset, other)
    length = np.linalg.norm(end - start, axis=1)
    blocked = tracer.occluded(start, (end - start) / np.maximum(length, 1e-30)[:, None], length)
    walled = np.zeros(len(patches), bool)
    walled[texel[blocked]] = True
    return walled


def _lifted(patches: Patches, offset: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """(K, 3) the positions of patches `ids` (K,) lifted off their surface by offset (N,)."""
    return patches.position[ids] + offset[ids, None] * patches.normal[ids]
