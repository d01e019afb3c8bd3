"""Adaptive lightmap sampling, after the radiosity article.

Compute every 4th texel (spacing 4). Then, halving the spacing each round: Pass Type 1
examines texels halfway between two decided texels (horizontally or vertically), Pass
Type 2 the centre of four. A texel gets its own gather only when its neighbours' ratio falls
below threshold = accuracy ** spacing in any channel, or below what the gather's own noise
allows if that is lower (a noise-aware threshold); otherwise it is their mean. Texels
whose neighbours are uncovered, in another UV chart or inside geometry are always computed,
so nothing is interpolated across chart borders or from darkness inside walls.

As the article suggests, the sampler runs twice: first at a low accuracy (0.5) for the first
passes, then, on the solution those passes give, at the final accuracy (0.98). The second
run decides every interpolated texel again; computed texels keep their gather.

What is interpolated is the gathered light G = S + F B (sky and bounces). Direct light is
ray traced at every texel, so sun-shadow edges stay sharp whatever the sampler decides.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..atlas.patches import Patches
from . import _kernels

UNDECIDED, COMPUTED, INTERPOLATED, INSIDE = 0, 1, 2, 3
STATUS_COLOURS = np.array([[0, 0, 0], [220, 40, 40], [40, 200, 60], [40, 80, 230]], np.uint8)  # sRGB, by status
SPACING = 4
NOISE_SIGMAS = 2.0  # neighbours differing by less than this many standard deviations of noise agree


def gather_noise(rays: int) -> float:
    """Relative standard deviation of a gather of `rays` cosine rays over light of unit
    contrast (std / mean = 1): 1 / sqrt(rays)."""
    return 1.0 / np.sqrt(rays)


@dataclass
class Step:
    """One pass of the sampler: texels `targets` (K,) i32 patch ids, ascending, each with
    neighbours `neighbours` (K, 2 or 4) i32 patch ids, -1 where the neighbour is missing,
    uncovered or in another chart. spacing: the round's spacing (4 or 2), for the threshold;
    rise: the rows between a target and its farthest neighbour; row_starts (H + 1,) i64:
    where the targets of each lightmap row begin (the last: K)."""

    targets: np.ndarray
    neighbours: np.ndarray
    spacing: int
    rise: int
    row_starts: np.ndarray


def _step(p: Patches, phase: tuple[int, int], offsets: list[tuple[int, int]], spacing: int) -> Step:
    """The patches whose texel (y, x) has (y % spacing, x % spacing) == phase, with their
    neighbours at offsets (dy, dx) (`_kernels.step_targets`)."""
    targets, neighbours, row_starts = _kernels.step_targets(p.index, p.chart, spacing, *phase,
                                                            np.array(offsets, np.int64).reshape(-1, 2))
    return Step(targets, neighbours, spacing, max((abs(dy) for dy, _ in offsets), default=0), row_starts)


def sampler_plan(p: Patches) -> tuple[np.ndarray, list[list[Step]]]:
    """The initial grid (patch ids on every 4th texel) and the rounds of steps that follow:
    [[type 1 horizontal, type 1 vertical], [type 2]] for spacing 4, then for spacing 2."""
    grid = _step(p, (0, 0), [], SPACING).targets.astype(np.int64)
    phases = []
    spacing = SPACING
    while spacing > 1:
        s, h = spacing, spacing // 2
        phases.append([_step(p, (0, h), [(0, -h), (0, h)], s), _step(p, (h, 0), [(-h, 0), (h, 0)], s)])
        phases.append([_step(p, (h, h), [(-h, 0), (h, 0), (0, -h), (0, h)], s)])
        spacing = h
    return grid, phases


def decide(step: Step, status: np.ndarray, G: np.ndarray, accuracy: float, noise: float, spread) -> np.ndarray:
    """Decide every target of `step` in place in `status` (`_kernels.decide_targets`, in
    spans on `spread`, Tracer.over_spans); returns the ids to compute now, in the step's order.

    G: (N, 3) f32 current gathered light of every decided patch. A target is interpolated
    when its neighbours' ratio (1 when both are 0, 0 when one is, else min / max) passes
    threshold = accuracy ** spacing in every channel. noise: the relative standard deviation
    of one gather (`gather_noise`); two gathers of the same light differ by up to
    NOISE_SIGMAS sqrt(2) of it, so the threshold never asks for more than that (a neighbour
    pair that differs only by noise is interpolated: the mean has less noise than a gather)."""
    threshold = min(accuracy ** step.spacing, 1.0 - NOISE_SIGMAS * np.sqrt(2.0) * noise)
    parts = spread(lambda a, b: _kernels.decide_targets(
        status, G, step.targets[a:b], step.neighbours[a:b], threshold, UNDECIDED, COMPUTED, INTERPOLATED),
        0, len(step.targets))
    return np.concatenate(parts) if parts else np.zeros(0, np.int64)


def reopen(status: np.ndarray) -> None:
    """Mark every interpolated texel undecided again, for the sampler's next run."""
    status[status == INTERPOLATED] = UNDECIDED


@dataclass
class Order:
    """The sampler's steps in their order (the interpolation's), as flat arrays for
    `_kernels.interpolate_rows`: step s's targets are targets[starts[s]:starts[s + 1]] (i32),
    its neighbours neighbours[nb_starts[s]:nb_starts[s + 1]] (i32, widths[s] per target),
    row_starts (S, H + 1) i64 where each lightmap row's targets of each step begin in
    `targets`, and reach (S,) the rows around a texel that its value at step s depends on
    (the steps' rises summed up to s). The steps' arrays are views of these."""

    steps: list[Step]
    height: int
    targets: np.ndarray
    neighbours: np.ndarray
    starts: np.ndarray
    nb_starts: np.ndarray
    widths: np.ndarray
    row_starts: np.ndarray
    reach: np.ndarray


def flatten(phases: list[list[Step]], height: int) -> Order:
    """Every step in the sampler's order, its interpolation order, on a lightmap of `height`
    rows; the steps' arrays become views of the Order's."""
    steps = [step for phase in phases for step in phase]
    counts = np.array([len(step.targets) for step in steps], np.int64)
    widths = np.array([step.neighbours.shape[1] for step in steps], np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)])
    nb_starts = np.concatenate([[0], np.cumsum(counts * widths)])
    targets = np.concatenate([step.targets for step in steps] or [np.zeros(0, np.int32)])
    neighbours = np.concatenate([step.neighbours.ravel() for step in steps] or [np.zeros(0, np.int32)])
    row_starts = np.array([step.row_starts + start for step, start in zip(steps, starts)], np.int64).reshape(
        len(steps), height + 1)
    for s, step in enumerate(steps):
        step.targets = targets[starts[s]:starts[s + 1]]
        step.neighbours = neighbours[nb_starts[s]:nb_starts[s + 1]].reshape(-1, widths[s])
    reach = np.cumsum([step.rise for step in steps], dtype=np.int64)
    return Order(steps, height, targets, neighbours, starts, nb_starts, widths, row_starts, reach)


INTERPOLATION_TASKS = 4  # row chunks an interpolation is cut into: more than the cores, so a busy core holds up less


def interpolate(G: np.ndarray, status: np.ndarray, order: Order, spread) -> np.ndarray:
    """Fill G (N, 3) in place at interpolated texels, in the sampler's order, each the mean of
    its neighbours. Undecided texels get the mean of whatever neighbours have values (a
    provisional estimate used while the sampler is still deciding); texels inside geometry
    end at 0. A texel's value at step s depends only on rows within order.reach[s] of it, so
    chunks of rows run as tasks on `spread` (Tracer.over_spans) at once, each but for the
    bands of rows around its edges, then those bands, at once too; a task takes every step
    over its rows in a wavefront (`_kernels.interpolate_rows`)."""
    have = (status == COMPUTED) | (status == INTERPOLATED)
    if order.steps:
        height, reach = order.height, order.reach
        rows = max(-(-height // INTERPOLATION_TASKS), 4 * int(reach[-1]) + 1)  # a chunk is taller than 2 reaches
        # only an undecided texel reads a texel inside geometry (those decided have decided neighbours): without
        # any, those inside are left to their 0
        skipped = -1 if np.any(status == UNDECIDED) else INSIDE

        def run(lo, hi):
            lo = np.minimum(lo, height)
            _kernels.interpolate_rows(G, have, status, order.targets, order.neighbours, order.starts, order.nb_starts,
                                      order.widths, order.row_starts, reach, lo, np.clip(hi, lo, height), COMPUTED,
                                      skipped)

        spread(lambda first, last: run(np.where(first > 0, first + reach, 0),
                                       np.where(last < height, last - reach, height)), 0, height, rows)
        spread(lambda first, last: run(np.maximum(first - reach, 0), np.minimum(first + reach, height))
               if first > 0 else None, 0, height, rows)
    spread(lambda a, b: _kernels.zero_where(G[a:b], status[a:b], INSIDE), 0, len(G), -(-len(G) // INTERPOLATION_TASKS))
    return G


def debug_image(p: Patches, status: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8: computed red, interpolated green, inside geometry blue, uncovered black."""
    return p.to_image(STATUS_COLOURS[status])
