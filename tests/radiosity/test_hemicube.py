"""The multiplier map against the analytic delta form factors, and form factors between
unit squares against their closed forms (parallel 0.1998, perpendicular 0.2000)."""
import numpy as np
import pytest

from patchlight.radiosity.hemicube import (delta_form_factors, lambert, multiplier_map,
                                           hemicube_directions, perspective_compensation,
                                           stratified_directions)
from patchlight.rays.tracer import Tracer

from form_factors import point_form_factor

PARALLEL = 0.19982   # two unit squares, directly opposite, one unit apart
PERPENDICULAR = 0.20004  # two unit squares sharing an edge at a right angle


@pytest.mark.parametrize("n", [4, 16, 64])
def test_multiplier_map_sums_to_one_and_is_the_delta_form_factors(n):
    dirs, weights = multiplier_map(n)
    assert len(weights) == 3 * n * n
    assert weights.sum() == pytest.approx(1.0, abs=1e-6)
    analytic = delta_form_factors(n)
    np.testing.assert_allclose(weights, analytic / analytic.sum(), rtol=1e-5)
    # the unnormalised analytic map sums to 1 in the limit, not exactly at finite n
    assert abs(analytic.sum() - 1) < 2.0 / n ** 2
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1, atol=1e-6)
    assert np.all(dirs[:, 2] > 0)


def test_map_is_one_at_the_centre_and_falls_to_the_corners():
    vecs, axes = hemicube_directions(64)
    product = perspective_compensation(vecs, axes) * lambert(vecs)
    front = axes[:, 2] == 1
    centre = np.argmin(np.linalg.norm(vecs[:, :2], axis=1) + ~front)
    assert product[centre] == pytest.approx(1.0, abs=2e-3)
    assert product.min() < 0.02


def _square(corners):
    c = np.asarray(corners, np.float32)
    return c, np.array([[0, 1, 2], [0, 2, 3]], np.int32)


def _form_factor(receiver_points, normal, tracer, dirs, weights):
    """Mean over receiver points of the weights of rays that hit the other square."""
    normal = np.asarray(normal, float)
    t = np.cross(normal, [0.0, 1.0, 0.3]); t /= np.linalg.norm(t)
    b = np.cross(normal, t)
    world = dirs[:, :1] * t + dirs[:, 1:2] * b + dirs[:, 2:3] * normal
    total = 0.0
    for p in receiver_points:
        hits = tracer.intersect(np.broadcast_to(p, world.shape), world)
        total += weights[hits.tri >= 0].sum()
    return total / len(receiver_points)


def _grid(m, make_point):
    s = (np.arange(m) + 0.5) / m
    return [make_point(a, b) for a in s for b in s]


def _parallel(n):
    v, i = _square([[0, 1, 0], [1, 1, 0], [1, 1, 1], [0, 1, 1]])
    points = _grid(8, lambda a, b: np.array([a, 1e-6, b]))
    return _form_factor(points, [0, 1, 0], Tracer(v, i), *multiplier_map(n))


def _perpendicular(n):
    v, i = _square([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])  # the wall z = 0
    points = _grid(24, lambda a, b: np.array([a, 1e-6, b]))       # the floor y = 0, z in (0, 1)
    return _form_factor(points, [0, 1, 0], Tracer(v, i), *multiplier_map(n))


def test_parallel_squares_converge_to_the_closed_form():
    errors = [abs(_parallel(n) - PARALLEL) / PARALLEL for n in (8, 32, 128)]
    assert errors[-1] < 0.01
    assert errors[0] > errors[-1]


def test_perpendicular_squares_converge_to_the_closed_form():
    errors = [abs(_perpendicular(n) - PERPENDICULAR) / PERPENDICULAR for n in (8, 32, 128)]
    assert errors[-1] < 0.01
    assert errors[0] > errors[-1]


def test_stratified_directions_are_cosine_distributed():
    dirs, weights = stratified_directions(4096, np.random.default_rng(0))
    assert weights.sum() == pytest.approx(1.0)
    # E[cos] under p = cos/pi is 2/3; E[cos^2] is 1/2
    assert dirs[:, 2].mean() == pytest.approx(2 / 3, abs=2e-3)
    assert (dirs[:, 2] ** 2).mean() == pytest.approx(0.5, abs=2e-3)


@pytest.mark.parametrize("wall", [
    [[0, 1, 0], [1, 1, 0], [1, 1, 1], [0, 1, 1]],   # parallel, one unit above
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],   # perpendicular, sharing the edge z = 0
])
def test_hemicube_error_against_exactpoint_form_factors_falls_at_every_doubling(wall):
    v, i = _square(wall)
    tracer = Tracer(v, i)
    rng = np.random.default_rng(3)
    points = np.stack([rng.uniform(0.05, 0.95, 40), np.full(40, 1e-6), rng.uniform(0.05, 0.95, 40)], axis=1)
    up = np.array([0.0, 1.0, 0.0])
    exact = np.array([point_form_factor(p, up, v.astype(float)) for p in points])
    errors = []
    for n in (8, 16, 32, 64, 128):
        estimate = np.array([_form_factor([p], up, tracer, *multiplier_map(n)) for p in points])
        errors.append(np.abs(estimate - exact).mean() / exact.mean())
    assert all(b < a for a, b in zip(errors, errors[1:])), errors
    assert errors[-1] < 0.005
