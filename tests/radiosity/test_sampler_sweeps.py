"""The sampler's sweeps run in spans on the tracer's pool: the same answer as one sequential
sweep in the sampler's order, whichever order the spans run in."""
from types import SimpleNamespace

import numpy as np
import pytest

from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.radiosity import adaptive
from patchlight.rays import tracer
from patchlight.scene import load_scene


@pytest.fixture(scope="module")
def plan():
    patches = bake(load_scene("cornell"), BakeSettings(resolution=64, passes=1)).patches
    grid, phases = adaptive.sampler_plan(patches)
    return len(patches), grid, phases, adaptive.flatten(phases, patches.height)


@pytest.fixture(params=[1, -1], ids=["first_first", "last_first"])
def one_by_one(monkeypatch, request):
    """Tracer.over_spans on a pool that runs small spans one by one, first first or last first
    (a span reading rows of the span after it, or of the one before, then sees them unwritten);
    interpolations cut into chunks as short as they can be."""
    monkeypatch.setattr(tracer, "TASK_ROWS", 7)
    monkeypatch.setattr(adaptive, "INTERPOLATION_TASKS", 1000)
    step = request.param
    return lambda fn, first, last, size=None: [fn(*span) for span in tracer.spans(first, last, size)[::step]][::step]


def _light(n, rng):
    G = rng.random((n, 3), dtype=np.float32)
    G[rng.random(n) < 0.1] = 0.0                 # dark texels: ratio 1 between two, 0 beside light
    G[rng.random(n) < 0.3] = G[0]                # neighbours that agree exactly
    return G


def _decide_reference(step, status, G, threshold):
    """The sampler's rule, one target after another."""
    compute = []
    for t, nbs in zip(step.targets, step.neighbours):
        if status[t] != adaptive.UNDECIDED:
            continue
        usable = all(n >= 0 and status[n] in (adaptive.COMPUTED, adaptive.INTERPOLATED) for n in nbs)
        similar = True
        for i in range(0, len(nbs), 2):
            a, b = G[nbs[i]], G[nbs[i + 1]]
            for c in range(3):
                hi, lo = max(a[c], b[c]), min(a[c], b[c])
                ratio = 1.0 if a[c] == 0 and b[c] == 0 else (float(np.float32(lo / hi)) if hi > 0 else 0.0)
                similar &= ratio > threshold
        status[t] = adaptive.INTERPOLATED if usable and similar else adaptive.COMPUTED
        if not (usable and similar):
            compute.append(t)
    return np.array(compute, np.int64)


def test_decide_in_spans_equals_one_target_after_another(plan, one_by_one):
    n, grid, phases, _ = plan
    rng = np.random.default_rng(5)
    G = _light(n, rng)
    status = np.zeros(n, np.int8)
    status[grid] = rng.choice([adaptive.COMPUTED, adaptive.INSIDE], len(grid), p=[0.9, 0.1])
    for phase in phases:
        for step in phase:
            expected = status.copy()
            want = _decide_reference(step, expected, G, 0.5 ** step.spacing)
            got = adaptive.decide(step, status, G, 0.5, 0.0, one_by_one)
            assert len(want) > 0 and len(want) < len(step.targets)
            np.testing.assert_array_equal(got, want)
            np.testing.assert_array_equal(status, expected)


def _interpolate_reference(G, status, order):
    """The interpolation, one target after another in the sampler's order."""
    expected = G.copy()
    have = (status == adaptive.COMPUTED) | (status == adaptive.INTERPOLATED)
    for t, nbs in ((t, nbs) for step in order.steps for t, nbs in zip(step.targets, step.neighbours)):
        if status[t] != adaptive.COMPUTED:
            valued = [expected[m].astype(np.float64) for m in nbs if m >= 0 and have[m]]
            expected[t] = np.mean(valued, axis=0) if valued else 0.0
            have[t] |= bool(valued)
    expected[status == adaptive.INSIDE] = 0.0
    return expected


def test_interpolation_in_spans_equals_the_sequential_sweep(plan, one_by_one):
    n, grid, phases, order = plan
    assert order.height > 2 * (4 * order.reach[-1] + 1)  # in chunks: more than one boundary between them
    rng = np.random.default_rng(6)
    status = rng.choice([adaptive.COMPUTED, adaptive.INTERPOLATED, adaptive.UNDECIDED, adaptive.INSIDE], n,
                        p=[0.3, 0.4, 0.2, 0.1]).astype(np.int8)
    G = _light(n, rng)
    expected = _interpolate_reference(G, status, order)
    np.testing.assert_array_equal(adaptive.interpolate(G, status, order, one_by_one), expected)


def test_once_all_is_decided_the_texels_inside_need_no_interpolation(plan, one_by_one):
    """With no texel undecided, the interpolation leaves those inside geometry out (nothing
    decided reads them): the same G as the full sweep, on statuses the sampler's rule made."""
    n, grid, phases, order = plan
    rng = np.random.default_rng(8)
    G = _light(n, rng)
    status = np.zeros(n, np.int8)
    status[grid] = rng.choice([adaptive.COMPUTED, adaptive.INSIDE], len(grid), p=[0.8, 0.2])
    for step in order.steps:
        computed = _decide_reference(step, status, G, 0.5 ** step.spacing)
        status[computed[rng.random(len(computed)) < 0.2]] = adaptive.INSIDE  # some found inside by their gather
    assert not np.any(status == adaptive.UNDECIDED) and np.count_nonzero(status == adaptive.INTERPOLATED) > 100
    expected = _interpolate_reference(G, status, order)
    np.testing.assert_array_equal(adaptive.interpolate(G, status, order, one_by_one), expected)


def test_the_plan_has_every_texel_once_with_its_neighbours_in_its_own_chart():
    """On a map with holes and two charts side by side: the grid and the steps' targets
    together are every covered texel, once; each target's neighbours are the texels at its
    step's offsets, -1 off the map, uncovered or in the other chart."""
    rng = np.random.default_rng(9)
    height, width = 13, 18
    covered = rng.random((height, width)) < 0.8
    index = np.full((height, width), -1, np.int32)
    index[covered] = np.arange(covered.sum())
    y, x = np.nonzero(covered)
    chart = (x >= 7).astype(np.int32)  # columns 0..6 one chart, 7.. the other
    patches = SimpleNamespace(index=index, chart=chart, height=height)
    grid, phases = adaptive.sampler_plan(patches)
    steps = [step for phase in phases for step in phase]
    np.testing.assert_array_equal(np.sort(np.concatenate([grid] + [s.targets for s in steps])), np.arange(len(y)))
    np.testing.assert_array_equal(grid, np.flatnonzero((y % 4 == 0) & (x % 4 == 0)))
    kinds = [(s, phase, offsets) for s in (4, 2) for phase, offsets in (  # horizontal, vertical, centre
        ((0, s // 2), [(0, -s // 2), (0, s // 2)]), ((s // 2, 0), [(-s // 2, 0), (s // 2, 0)]),
        ((s // 2, s // 2), [(-s // 2, 0), (s // 2, 0), (0, -s // 2), (0, s // 2)]))]
    assert len(steps) == len(kinds)
    for step, (spacing, phase, offsets) in zip(steps, kinds):
        assert step.spacing == spacing
        np.testing.assert_array_equal(step.targets, np.flatnonzero((y % spacing == phase[0]) & (x % spacing == phase[1])))
        np.testing.assert_array_equal(step.row_starts, np.searchsorted(y[step.targets], np.arange(height + 1)))
        for t, nbs in zip(step.targets, step.neighbours):
            for (dy, dx), got in zip(offsets, nbs):
                yy, xx = y[t] + dy, x[t] + dx
                inside_map = 0 <= yy < height and 0 <= xx < width
                other = index[yy, xx] if inside_map else -1
                assert got == (other if other >= 0 and chart[other] == chart[t] else -1)
