"""The sun's shadow rays dealt over a texel's points, against a plain reference: ray j of a
texel leaves point j % K along disc direction (j + j // S) % S, and each point's light is the
mean of its unblocked rays' cosines times Es / pi."""
import numpy as np
import pytest

from patchlight.radiosity.direct import _Sun, sun_light


class HalfBlocked:
    """A stand-in tracer whose rays are blocked where origin x + direction x / 10 > 0.5."""

    def occluded_chunk(self, origins, dirs, tmax):
        assert origins.dtype == dirs.dtype == tmax.dtype == np.float32
        return origins[:, 0] + dirs[:, 0] / np.float32(10) > np.float32(0.5)


def reference(origins, normals, sun):
    n, k = origins.shape[:2]
    s = len(sun.directions)
    cos = [normals @ d for d in sun.directions]
    out = np.zeros((n, k, 3))
    for i in range(n):
        for p in range(k):
            rays = [j for j in range(max(s, k)) if j % k == p]
            seen = 0.0
            for j in rays:
                d = (j + j // s) % s
                blocked = np.float32(origins[i, p, 0]) + np.float32(sun.directions[d, 0]) / np.float32(10) > np.float32(0.5)
                if cos[d][i] > 0 and not blocked:
                    seen += cos[d][i]
            out[i, p] = seen / len(rays) * sun.light / np.pi
    return out


@pytest.mark.parametrize("directions, points", [(16, 4), (4, 16), (1, 4), (9, 9)])
def test_sun_light_deals_the_disc_over_the_points_as_the_reference(directions, points):
    rng = np.random.default_rng(directions * 100 + points)
    dirs = rng.normal(size=(directions, 3))
    sun = _Sun(dirs / np.linalg.norm(dirs, axis=1, keepdims=True), np.array([1.0, 0.5, 2.0]))
    normals = rng.normal(size=(40, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    origins = rng.random((40, points, 3))
    total = np.zeros((40, points, 3))
    sun_light(origins, normals, sun, HalfBlocked(), total)
    assert 0 < np.count_nonzero(total) < total.size
    np.testing.assert_array_equal(total, reference(origins, normals, sun))
