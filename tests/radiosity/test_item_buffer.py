"""The item buffer's compact tables (texel ranks, emitting patches) answer as the arrays they pack."""
import numba as nb
import numpy as np
import pytest

from patchlight.radiosity import _kernels


@nb.njit
def _patches_at(u, v, tri_uv1, width, height, index):
    """_patch_at of points (u, v) of triangle 0, one by one."""
    out = np.empty(u.shape[0], np.int64)
    for i in range(u.shape[0]):
        out[i] = _kernels._patch_at(0, u[i], v[i], tri_uv1, width, height, index)
    return out


def _index(covered):
    index = np.full(covered.shape, -1, np.int32)
    index[covered] = np.arange(np.count_nonzero(covered))
    return index


@pytest.mark.parametrize("width", [1, 31, 32, 70])
def test_the_rank_table_finds_every_texel_and_neighbour_as_the_index(width):
    rng = np.random.default_rng(width)
    covered = rng.random((9, width)) < 0.3
    covered[:2] = False  # row 0 sees nothing within a texel (LOST); row 1 falls back to row 2
    covered[2, ::2] = True
    covered[5] = True
    index = _index(covered)
    tri_uv1 = np.array([[[0, 0], [1, 0], [0, 1]]], np.float32)  # triangle 0: (u, v) is the UV
    y, x = np.mgrid[:9, :width]
    u, v = ((x.ravel() + 0.5) / width).astype(np.float32), ((y.ravel() + 0.5) / 9).astype(np.float32)
    expected = _patches_at(u, v, tri_uv1, width, 9, index)
    assert np.array_equal(_patches_at(u, v, tri_uv1, width, 9, _kernels.texel_ranks(index)), expected)
    assert np.array_equal(expected[covered.ravel()], np.arange(np.count_nonzero(covered)))
    assert np.all(expected[:width] == _kernels.LOST) and np.all(expected[width:2 * width] >= 0)


def test_a_rank_table_needs_patch_ids_in_texel_order():
    index = _index(np.ones((2, 3), bool))
    index[0, :2] = index[0, 1::-1]
    with pytest.raises(ValueError, match="texel"):
        _kernels.texel_ranks(index)


def test_the_emitting_bits_find_the_rays_that_see_emission():
    rng = np.random.default_rng(3)
    n = 3 * _kernels.LINE_PATCHES + 13  # not whole bytes, nor whole lines of the second level
    emission = np.zeros((n, 3), np.float32)
    emission[:13] = rng.random((13, 3)) * (rng.random((13, 1)) < 0.4)
    emission[4] = [0, 0, 0.5]
    emission[n - 1, 1] = 2.0  # the last line's last patch; the lines between emit nothing
    seen = rng.integers(_kernels.LOST, n, 5000).astype(np.int32)
    seen[:20] = np.arange(13).repeat(2)[:20]
    seen[20] = n - 1
    expected = (seen >= 0) & np.any(emission[np.maximum(seen, 0)] > 0, axis=1)
    assert 0 < expected.sum() < np.count_nonzero(seen >= 0)
    rays = len(seen)
    tri, dist, dirs = np.zeros(rays, np.int32), np.ones(rays, np.float32), np.tile(np.float32([0, 0, 1]), (rays, 1))
    shares = _kernels.emission_shares(seen, tri, dist, dirs, dirs[:1], _kernels.emitting_patches(emission),
                                      np.zeros(0), np.zeros((0, 3)), 0.0)  # no next-event samples: whole shares
    assert np.array_equal(shares, expected.astype(np.float32))


def _rows_one_ray_at_a_time(seen, weights, radiance, panels, uniform):
    """item_buffer_rows' answer, ray by ray in float32: each row's patches in first-seen order,
    their weights summed (uniform: one entry per ray, weight bits 0), then dealt to their
    column panels, rows ascending within a panel."""
    d = len(weights)
    entries, sky, back, lost, k_sky = [], np.zeros((len(seen) // d, 3), np.float32), [], 0, 0
    for r in range(len(seen) // d):
        row, per_ray = {}, []
        for j, s in enumerate(seen[r * d:(r + 1) * d]):
            if s >= 0:
                row[s] = row[s] + weights[j] if s in row else weights[j]
                per_ray.append((s, np.float32(0.0)))
            elif s == _kernels.SKY:
                sky[r] += weights[j] * radiance[k_sky]
                k_sky += 1
            lost += s == _kernels.LOST
        entries += [(s >> 16, r, s & 0xFFFF, w) for s, w in (per_ray if uniform else row.items())]
        back.append(np.count_nonzero(seen[r * d:(r + 1) * d] == _kernels.BACK_FACE) / d)
    entries.sort(key=lambda e: e[0])  # stable: rows ascending, first-seen order within a row
    panel, rows, cols, w = (np.array([e[i] for e in entries]) for i in range(4))
    starts = np.searchsorted(panel, np.arange(panels + 1))
    return starts, rows, cols, w.astype(np.float32), sky, np.float32(back), lost


@pytest.mark.parametrize("uniform", [False, True])
def test_the_rows_of_an_item_buffer_sum_each_rows_rays_panel_by_panel(uniform):
    """Weighted, a row's duplicates are summed into one entry; uniform, each ray that sees a
    patch is an entry of its own (the sky term is summed either way)."""
    rng = np.random.default_rng(5)
    d, n = 40, 3 * 65536 + 9  # four column panels
    weights = np.full(d, 1 / d, np.float32) if uniform else rng.random(d, dtype=np.float32)
    seen = rng.integers(_kernels.LOST, n, (300, d)).astype(np.int32)
    seen[:, 1::4] = seen[:, ::4]  # duplicates within rows, some meeting in the hash table's chains
    seen[7] = _kernels.SKY
    seen[8, :] = 65536 + 7  # one patch seen by every ray of a row
    seen = seen.ravel()
    radiance = rng.random((np.count_nonzero(seen == _kernels.SKY), 3), dtype=np.float32)
    panels = _kernels.panel_count(n)
    got = _kernels.item_buffer_rows(seen, weights, radiance, panels, uniform)
    expected = _rows_one_ray_at_a_time(seen, weights, radiance, panels, uniform)
    starts, entries, sky, back, lost = got
    assert entries.dtype == np.uint64 and lost == expected[-1]
    np.testing.assert_array_equal(starts, expected[0])
    np.testing.assert_array_equal(entries & 0xFFFF, expected[1])  # the row
    np.testing.assert_array_equal(entries >> 16 & 0xFFFF, expected[2])  # the column within the panel
    np.testing.assert_array_equal((entries >> 32).astype(np.uint32).view(np.float32), expected[3])
    np.testing.assert_array_equal(sky, expected[4])
    np.testing.assert_array_equal(back, expected[5])
