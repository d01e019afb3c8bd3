"""Emissive triangles as area lights: next-event estimation beside the gather, against exact
form factors, and the cost of many emitters."""
import numpy as np
import pytest

from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.scene import SceneBuilder
from patchlight.solved import SolvedScene

from form_factors import point_form_factor

UP = (0.0, 1.0, 0.0)
FLOOR = [[0, 0, 0], [0, 0, 1], [1, 0, 1], [1, 0, 0]]


def mean_over_floor(result, height=0.0) -> np.ndarray:
    """(3,) the lightmap as a renderer reads it (bilinear), averaged over the area of the
    triangles lying in the plane y = height: the area mean, rim texels weighed rightly."""
    solved = SolvedScene(result.scene, result.lightmap, "test")
    corners = result.scene.positions[result.scene.indices]
    tris = np.flatnonzero(np.abs(corners[:, :, 1] - height).max(axis=1) < 1e-6)
    g = (np.arange(60) + 0.5) / 60
    u, v = np.meshgrid(g, g)
    keep = u + v < 1
    u, v = u[keep], v[keep]
    return np.mean([solved.incident(np.full(len(u), t), u, v).mean(axis=0) for t in tris], axis=0)


@pytest.mark.parametrize("lamp, facing, expected", [
    ([[0, 1, 0], [1, 1, 0], [1, 1, 1], [0, 1, 1]], (0, -1, 0), 0.19982),  # parallel, one unit above
    ([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], (0, 0, 1), 0.20004),   # perpendicular, a shared edge
])
def test_a_unit_square_emitter_gives_howells_form_factor_at_the_defaults(lamp, facing, expected):
    b = SceneBuilder()
    floor, light = b.material("white", (1.0, 1.0, 1.0)), b.material("lamp", (0, 0, 0), emissive=(2.0, 2.0, 2.0))
    b.quad(FLOOR, floor, UP)
    b.quad(lamp, light, facing)
    result = bake(b.scene("howell"), BakeSettings(resolution=48))
    assert result.stats["rays_direct"] > 0
    np.testing.assert_allclose(mean_over_floor(result), 2.0 * expected, rtol=1e-2)


def _panel_over_floor(emitter_samples: int):
    """A 0.1 m panel of radiance 400, facing down 1 m above a black 2 x 2 m floor."""
    b = SceneBuilder()
    floor, light = b.material("black", (0, 0, 0)), b.material("panel", (0, 0, 0), emissive=(400.0, 400.0, 400.0))
    b.quad([[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]], floor, UP)
    panel = np.array([[-0.05, 1, -0.05], [0.05, 1, -0.05], [0.05, 1, 0.05], [-0.05, 1, 0.05]])
    b.quad(panel, light, (0, -1, 0))
    result = bake(b.scene("panel"), BakeSettings(resolution=64, emitter_samples=emitter_samples))
    p = result.patches
    on_floor = np.flatnonzero(np.abs(p.position[:, 1]) < 1e-6)
    exact = np.array([400.0 * point_form_factor(p.position[i].astype(np.float64), np.array(UP), panel)
                      for i in on_floor])
    return result.solution.incident[on_floor, 0], exact


def test_a_tiny_bright_panel_lights_every_floor_texel_within_a_few_percent():
    """The issue's case: the gather alone (no shadow rays) left a median error of 29 % and
    6 % of the texels at 0. Next-event estimation finds the panel from every texel."""
    baked, exact = _panel_over_floor(16)
    error = np.abs(baked / exact - 1)
    assert baked.min() > 0
    assert np.median(error) < 0.02 and np.percentile(error, 99) < 0.06
    gathered, _ = _panel_over_floor(0)
    assert np.median(np.abs(gathered / exact - 1)) > 5 * np.median(error)



def test_a_tiny_bright_panel_is_as_close_with_a_sample_count_not_a_power_of_two():
    """25 samples (5 x 5): the strata and the weights divide by K, not multiply by 1 / K."""
    baked, exact = _panel_over_floor(25)
    error = np.abs(baked / exact - 1)
    assert np.median(error) < 0.02 and np.percentile(error, 99) < 0.06

def _facade(cells: int) -> tuple:
    """A 1 x 1 m emissive wall over a 2 x 1 m grey floor, the wall made of cells x cells quads."""
    b = SceneBuilder()
    grey, glow = b.material("grey", (0.5, 0.5, 0.5)), b.material("glow", (0.2, 0.2, 0.2), emissive=(3.0, 2.0, 1.0))
    b.quad([[0, 0, 0], [0, 0, 1], [2, 0, 1], [2, 0, 0]], grey, UP)
    edges = np.linspace(0.0, 1.0, cells + 1)
    for y0, y1 in zip(edges[:-1], edges[1:]):
        for z0, z1 in zip(edges[:-1], edges[1:]):
            b.quad([[0, y0, z0], [0, y1, z0], [0, y1, z1], [0, y0, z1]], glow, (1, 0, 0))
    scene = b.scene(f"facade {cells}")
    # lightmap UVs by hand: the floor on the left half, the wall's cells tiled on the right
    corners = scene.positions.reshape(-1, 3, 3)
    floor = np.abs(corners[:, :, 1]).max(axis=1) < 1e-6
    uv = np.where(floor[:, None, None], corners[:, :, [0, 2]] * [0.23, 0.46] + 0.02,
                  corners[:, :, [2, 1]] * 0.46 + [0.52, 0.02])
    scene.uv1 = uv.reshape(-1, 2).astype(np.float32)
    return scene


def test_ten_thousand_emitters_light_the_floor_as_the_same_area_merged():
    merged = bake(_facade(1), BakeSettings(resolution=64))
    many = bake(_facade(100), BakeSettings(resolution=64))
    floor = np.abs(merged.patches.position[:, 1]) < 1e-6
    a, b = merged.solution.incident[floor], many.solution.incident[floor]
    assert merged.patches.position.shape == many.patches.position.shape
    np.testing.assert_allclose(b.mean(axis=0), a.mean(axis=0), rtol=1e-2)
    assert np.percentile(np.abs(b / a - 1), 90) < 0.05


def _two_emitters_and_a_normal(rng):
    """Two random emitter triangles (corners (2, 3, 3), unit normals (2, 3)) and a random
    unit texel normal (3,), as the culling tests draw them."""
    corners = rng.normal(size=(2, 3, 3)) * 3
    em_normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    em_normal /= np.linalg.norm(em_normal, axis=1, keepdims=True)
    n = rng.normal(size=3)
    return corners, em_normal, n / np.linalg.norm(n)


def test_a_texel_is_skipped_only_where_no_sample_could_reach_an_emitter():
    """next_event_samples skips the texels `_faces_no_emitter` finds facing away from every emitter
    (or behind every one): brute force over 300 points of each emitter (its corners among
    them) and every origin must then find each pair's cos <= 0, as next_event_samples computes it,
    also at a hair's breadth: an emitter's corner in the texel's plane, origins in an emitter's."""
    from patchlight.radiosity._kernels import _faces_no_emitter

    rng = np.random.default_rng(5)
    culled = kept = 0
    for case in range(400):
        corners, em_normal, n = _two_emitters_and_a_normal(rng)
        points = rng.normal(size=(4, 3)) * 0.01 + rng.normal(size=3) * 3
        points -= np.outer(points @ n - (points @ n).mean(), n)  # on one plane, as a texel's points
        if case % 4 == 1:    # an emitter's corner in the plane of the texel's points
            points += n * (corners[0, case % 3] @ n - points[0] @ n)
        elif case % 4 == 2:  # the texel's points in an emitter's plane
            points -= np.outer(points @ em_normal[0] - corners[0, 0] @ em_normal[0], em_normal[0])
        two_sided = np.array([case % 8 == 3, False])
        lift = 1e-3 * (case % 3)
        if not _faces_no_emitter(np.ascontiguousarray(points.T), *(lift * n), *n, corners, em_normal, two_sided,
                                 np.abs(corners).max()):
            kept += 1
            continue
        culled += 1
        u, v = rng.random((2, 300))
        u[:3], v[:3] = [0, 1, 0], [0, 0, 1]
        u, v = np.where(u + v > 1, 1 - u, u), np.where(u + v > 1, 1 - v, v)
        for e in range(2):
            lights = (1 - u - v)[:, None] * corners[e, 0] + u[:, None] * corners[e, 1] + v[:, None] * corners[e, 2]
            d = lights[:, None] - (points + lift * n)[None]
            d /= np.linalg.norm(d, axis=2, keepdims=True)
            cos_r, cos_l = d @ n, -(d @ em_normal[e])
            cos_l = np.abs(cos_l) if two_sided[e] else cos_l
            assert np.all((cos_r <= 0) | (cos_l <= 0)), case
    assert culled > 50 and kept > 50


def test_the_corners_of_a_texels_grid_cull_as_all_its_points_do():
    """next_event_samples tests the four corner points of a texel's grid of points (an affine image
    of the cells, none past a rim): the culling decision equals the one over all 64 points,
    emitters in front, behind and edge-on among the cases."""
    from patchlight.radiosity._kernels import _faces_no_emitter

    rng = np.random.default_rng(8)
    culled = 0
    across = (np.arange(8) + 0.5) / 8
    for case in range(300):
        corners, em_normal, n = _two_emitters_and_a_normal(rng)
        u, v = np.cross(n, rng.normal(size=3)), rng.normal(size=3)
        v -= (v @ n) * n
        base = rng.normal(size=3) * 3
        if case % 3 == 1:  # the texel's plane through an emitter's corner
            base += n * (corners[0, case % 3] @ n - base @ n)
        i, j = np.meshgrid(across, across, indexing="ij")
        points = (base[:, None] + 2.0 * (u[:, None] * i.ravel() + v[:, None] * j.ravel()))  # (3, 64)
        hull = np.ascontiguousarray(points[:, [0, 7, 56, 63]])
        two_sided = np.array([case % 5 == 2, False])
        args = (0.0, 0.0, 0.0, *n, corners, em_normal, two_sided, np.abs(corners).max())
        whole = _faces_no_emitter(np.ascontiguousarray(points), *args)
        assert _faces_no_emitter(hull, *args) == whole, case
        culled += whole
    assert 30 < culled < 270


def test_an_emitter_stands_for_one_patch_only_where_every_point_of_it_reads_that_emission():
    """uniform_patches against `_patch_at` at 2,000 points of each triangle (its corners among
    them) on a 16 x 16 map: a block of equal emission, a block of two, uncovered texels."""
    from patchlight.radiosity._kernels import _patch_at, uniform_patches

    index = np.full((16, 16), -1, np.int32)
    index[2:14, 2:14] = np.arange(144).reshape(12, 12)
    emission = np.full((144, 3), 5.0, np.float32)
    emission[index[2:14, 9:14].ravel()] = (5.0, 5.0, 6.0)                     # columns 9..13 differ
    rng = np.random.default_rng(3)
    uv = np.concatenate([rng.uniform(2.5, 8.5, (40, 3, 2)),                   # inside the uniform block
                         rng.uniform(1.5, 14.5, (40, 3, 2)),                  # across blocks or uncovered
                         [[[2, 2], [9, 2], [2, 9]], [[3, 3], [8.999, 3], [3, 5]]]]) / 16
    uv = uv.astype(np.float32)
    patch = uniform_patches(uv, 16, 16, index, emission)
    u, v = rng.random((2, 2000))
    u[:3], v[:3] = [0, 1, 0], [0, 0, 1]
    u, v = np.where(u + v > 1, 1 - u, u), np.where(u + v > 1, 1 - v, v)
    for t in range(len(uv)):
        seen = np.array([_patch_at(t, a, b, uv, 16, 16, index) for a, b in zip(u, v)])
        reads_one = np.all(seen >= 0) and np.all(emission[seen] == emission[seen[0]])
        if patch[t] >= 0:
            assert reads_one and np.array_equal(emission[patch[t]], emission[seen[0]]), t
        elif t < 40:
            pytest.fail(f"triangle {t} lies inside the uniform block")
    assert np.all(patch[:40] >= 0) and np.count_nonzero(patch[40:80] < 0) > 30
    assert patch[80] == -1 and patch[81] >= 0  # the first touches texel column 9 (and 1: uncovered)


def test_the_branch_free_search_picks_the_emitter_a_plain_search_picks():
    """_emitters_picked against np.searchsorted (the number of cdf values <= each pick, at
    most M - 1), for 1 to 20 emitters (counted and selected up to LINEAR_PICK, searched and
    gathered beyond), emitters of no power (repeated cdf values) among them, picks exactly on
    cdf values, on the last and just below 1 (the last emitter, whatever the cdf's rounding);
    each pick's table column is its emitter's."""
    from patchlight.radiosity._kernels import E_COLUMNS, _emitters_picked
    from numba import njit

    picked = njit(lambda out, pick, cdf, table, t: _emitters_picked(out, pick, cdf, table, t))
    rng = np.random.default_rng(3)
    for m in range(1, 21):
        power = rng.random(m) * (rng.random(m) > 0.3)
        power[-1] = 1.0
        cdf = np.cumsum(power / power.sum())
        pick = np.concatenate([rng.random(64), cdf[:-1], [0.0, cdf[-1], np.nextafter(1.0, 0.0)]])
        out = np.empty(len(pick), np.int64)
        table = rng.random((E_COLUMNS, m))
        t = np.empty((E_COLUMNS, len(pick)))
        picked(out, pick, cdf, table, t)
        expected = np.minimum(np.searchsorted(cdf, pick, side="right"), m - 1)
        np.testing.assert_array_equal(out, expected)
        np.testing.assert_array_equal(t, table[:, expected])


def test_the_traced_samples_light_each_texel_as_its_packed_rays_do():
    """emitter_light traces its shadow rays as the kernel makes them; the same rays packed
    (next_event_rays), traced by the tracer and their unblocked light added texel by texel in
    ray order give the same light to the bit, with the same rays counted, in a box whose
    walls and a block cast shadows (some texels see the lamp, some part of it, some none)."""
    from patchlight.atlas.raster import TexelPoints, rasterize
    from patchlight.atlas.uvs import ensure_lightmap_uvs
    from patchlight.radiosity.emitters import emitter_light, find_emitters, next_event_rays
    from patchlight.radiosity.gather import Gatherer
    from patchlight.rays.tracer import Tracer
    from patchlight.scene import load_scene

    scene, width, height, _ = ensure_lightmap_uvs(load_scene("cornell"), resolution=64)
    patches, _ = rasterize(scene, width, height)
    tracer = Tracer(scene.positions, scene.indices)
    gatherer = Gatherer(scene, patches, tracer, "stratified", 64, 1)
    emitters, points, side = find_emitters(scene, patches), TexelPoints(scene, patches), 4
    traced = emitter_light(emitters, patches, gatherer.tri_uv1, points, side, gatherer.offset, tracer, 64, seed=3)
    rays_traced = tracer.rays_traced
    rows = np.arange(len(patches), dtype=np.int64)
    ray, origins, dirs, tmax, value = next_event_rays(emitters, patches, gatherer.tri_uv1, points, side,
                                                      gatherer.offset, rows, 64.0, 3)
    blocked = tracer.occluded(origins, dirs, tmax)
    expected = np.zeros((len(patches), 3), np.float32)
    np.add.at(expected, ray // (side * side), value * (~blocked[:, None]).astype(np.float32))  # in ray order
    assert rays_traced == len(ray) and 0.1 < blocked.mean() < 0.9
    assert np.count_nonzero(expected.max(axis=1) > 0) > len(patches) // 4
    np.testing.assert_array_equal(traced, expected)
