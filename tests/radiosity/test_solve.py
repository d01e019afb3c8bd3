"""The passes: the stop rule (the change still to come, from the changes so far), their sweep, and the
products of F."""
import math

import pytest

from patchlight.radiosity.gather import PanelRows
from patchlight.radiosity.solve import change_to_come


def test_a_geometric_tail_is_summed():
    # real changes 0.5, 0.25, 0.125 after the placeholder: r = 0.5, the rest 0.125 x 0.5 / 0.5
    assert change_to_come([1.0, 0.5, 0.25, 0.125]) == pytest.approx(0.125)
    # r = 0.9: nine times the last change is still to come
    assert change_to_come([1.0, 0.1, 0.09, 0.081]) == pytest.approx(0.081 * 9)


@pytest.mark.parametrize("changes", [
    [1.0], [1.0, 0.2], [1.0, 3.65, 0.042],   # too few real changes to trust a ratio
    [1.0, 0.1, 3.0, 0.03],                   # a jump (texels marked inside): no contraction yet
    [1.0, 1.0, 1.0, 1.0],                    # light still spreading
])
def test_no_stop_without_a_contraction_seen_twice(changes):
    assert math.isinf(change_to_come(changes))


def test_an_exact_fixed_point_stops_at_once():
    assert change_to_come([1.0, 0.0]) == 0.0


def _pieces(n_cols, cuts, rays=24, seed=3):
    """The gather's pieces of rows cuts[0]..cuts[-1] (item_buffer_rows of random item buffers,
    one piece per cut, some empty), and the same rows as one CSR matrix (duplicates summed)."""
    import numpy as np
    import scipy.sparse as sp

    from patchlight.radiosity import _kernels

    rng = np.random.default_rng(seed)
    weights = rng.random(rays, dtype=np.float32)
    seen = rng.integers(-3, n_cols, (cuts[-1], rays)).astype(np.int32)  # SKY, BACK_FACE, LOST or a patch
    seen[:, ::3] = seen[:, :1]  # duplicates within a row
    pieces = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        starts, entries, *_ = _kernels.item_buffer_rows(seen[a:b].ravel(), weights, np.ones((rays * (b - a), 3),
                                                        np.float32), _kernels.panel_count(n_cols))
        pieces.append(PanelRows(starts, entries, b - a))
    hit = seen >= 0
    F = sp.csr_matrix((np.broadcast_to(weights, seen.shape)[hit], (np.nonzero(hit)[0], seen[hit])),
                      shape=(cuts[-1], n_cols), dtype=np.float32)
    return pieces, F


@pytest.mark.parametrize("n_cols", [1000, 65536, 3 * 65536 + 17])  # one column panel, one and an empty one, four
def test_a_panel_block_holds_its_rows_panel_by_panel_in_column_order(n_cols):
    import numpy as np

    from patchlight.radiosity.solve import PanelBlock

    cuts = [0, 700, 700, 701, 1500, 2000]  # the gather's chunks: pieces of consecutive rows, one empty
    pieces, F = _pieces(n_cols, cuts)
    last_first = []  # the panels' tasks run last first

    def run(fn, items):
        last_first.append(len(items))
        return [fn(item) for item in reversed(items)][::-1]

    block = PanelBlock.of(pieces, run)
    assert block.n_rows == 2000 and not pieces and last_first == [(n_cols >> 16) + 1]
    F.sort_indices()  # the expected order: panel, then column, then row
    rows, cols = np.repeat(np.arange(F.shape[0]), np.diff(F.indptr)), F.indices
    order = np.lexsort((rows, cols))
    np.testing.assert_array_equal(block.starts, np.searchsorted(cols[order], np.arange(len(block.starts)) << 16))
    np.testing.assert_array_equal(block.rows, rows[order])
    np.testing.assert_array_equal(block.cols, cols[order] & 0xFFFF)
    np.testing.assert_allclose(block.weights, F.data[order], rtol=1e-6)
    B = np.random.default_rng(4).random((n_cols, 3), dtype=np.float32)
    np.testing.assert_allclose(block.times(B), F @ B, rtol=1e-5, atol=1e-6)
    whole = PanelBlock.of(_pieces(n_cols, [0, 2000])[0], run)  # the pieces make the block the rows make at once
    for name in ("starts", "rows", "cols", "weights"):
        np.testing.assert_array_equal(getattr(block, name), getattr(whole, name))


def test_a_panel_block_takes_at_most_2_16_rows_and_may_be_empty():
    import numpy as np

    from patchlight.radiosity.solve import PanelBlock

    def run(fn, items):
        return [fn(item) for item in items]

    assert PanelBlock.of([], run).times(np.ones((70000, 3), np.float32)).shape == (0, 3)
    words = (np.float32([2.0, 3.0]).view(np.uint32).astype(np.uint64) << 32) | (np.uint64([5, 0]) << 16)
    block = PanelBlock.of([PanelRows(np.array([0, 1, 2]), words, 1)], run)  # row 0: columns 5 and 65536
    np.testing.assert_array_equal(block.times(np.ones((70000, 3), np.float32)), [[5.0, 5.0, 5.0]])
    many = PanelRows(np.zeros(2, np.int64), np.zeros(0, np.uint64), 65537)
    with pytest.raises(ValueError, match="2\\^16 rows"):
        PanelBlock.of([many], run)


def test_a_panel_block_of_2_16_rows_reaches_its_last_row_from_a_later_piece():
    """Row 65,535, the last a u16 holds, comes from the second piece: its row offset is added
    to the words and must not spill into the column bits."""
    import numpy as np

    from patchlight.radiosity._kernels import entry_word
    from patchlight.radiosity.solve import PanelBlock

    def word(weight, column, row):
        return entry_word(row, column, np.float32(weight).view(np.uint32))

    first = PanelRows(np.array([0, 1, 1]), np.array([word(2.0, 7, 0)]), 65535)  # row 0: column 7
    last = PanelRows(np.array([0, 1, 2]), np.array([word(3.0, 65535, 0), word(5.0, 1, 0)]), 1)
    block = PanelBlock.of([first, last], lambda fn, items: [fn(item) for item in items])
    B = np.arange(3 * 70000, dtype=np.float32).reshape(70000, 3)
    out = block.times(B)
    assert out.shape == (65536, 3)
    np.testing.assert_array_equal(out[0], 2.0 * B[7])
    np.testing.assert_array_equal(out[65535], 3.0 * B[65535] + 5.0 * B[65536 + 1])
    assert not out[1:65535].any()


@pytest.fixture(scope="module")
def room_gatherer():
    import numpy as np

    from patchlight.atlas.raster import rasterize
    from patchlight.atlas.uvs import ensure_lightmap_uvs
    from patchlight.radiosity.gather import Gatherer
    from patchlight.rays.tracer import Tracer
    from patchlight.scene import load_scene

    scene, width, height, _ = ensure_lightmap_uvs(load_scene("room"), resolution=96)
    patches, _ = rasterize(scene, width, height)
    rows = np.random.default_rng(0).permutation(len(patches))[:600].astype(np.int64)
    return Gatherer(scene, patches, Tracer(scene.positions, scene.indices), "stratified", 64, 1), rows


@pytest.mark.parametrize("kept", [True, False])  # F kept in blocks, or re-gathered for every product
def test_the_rows_from_any_first_multiply_as_the_whole_product_does(room_gatherer, monkeypatch, kept):
    """FormFactors.product(B, first) is the whole product's rows first.., whether first is
    where an add() began or inside a block; gathered_light(first) updates those rows only,
    and then equals a sweep of all rows."""
    import numpy as np

    from patchlight.radiosity import adaptive, solve

    gatherer, rows = room_gatherer
    monkeypatch.setattr(solve, "ROWS_PER_BLOCK", 100)  # several blocks per add()
    ff = solve.FormFactors(gatherer, 1 << 40 if kept else 0)
    status = np.full(len(gatherer.patches), adaptive.UNDECIDED, np.int8)
    B = np.random.default_rng(1).random((len(gatherer.patches), 3), dtype=np.float32)
    cuts = [0, 130, 131, 131, 400, 600]  # add() calls, one of them empty
    G = np.zeros(B.shape, np.float32)
    order = adaptive.flatten([], gatherer.patches.height)  # no sampler: nothing interpolated
    for a, b in zip(cuts[:-1], cuts[1:]):
        ff.add(rows[a:b])
        status[rows[a:b]] = adaptive.COMPUTED
        solve.gathered_light(ff, B, status, order, G, a)
    assert ff.kept == kept and (len(ff.blocks) == 8 if kept else not ff.blocks)
    whole = ff.product(B)
    for first in (0, 50, 100, 130, 131, 250, 400, 599, 600):
        np.testing.assert_array_equal(ff.product(B, first), whole[first:])
    np.testing.assert_array_equal(G, solve.gathered_light(ff, B, status, order, np.zeros(B.shape, np.float32)))


def test_the_pass_sweep_writes_numpys_float16_cast():
    """pass_light's float16 copy of the incident light (the pass store) is NumPy's cast, bit
    for bit: ties to even (normal and subnormal), the smallest subnormals, overflow to inf,
    negative values, NaNs with and without a payload that survives."""
    import numpy as np

    from patchlight.radiosity import _kernels

    rng = np.random.default_rng(7)
    bits = rng.integers(0, 0x7F800001, 60000, dtype=np.uint32) | rng.choice(np.uint32([0, 0x80000000]), 60000)
    ties = (bits & ~np.uint32(0x1FFF)) | np.uint32(0x1000)       # halfway between two normal float16
    below = bits >> np.uint32(5) & ~np.uint32(0xFFF) | np.uint32(0x33000000)  # small: subnormal or 0
    edges = np.float32([0, 2 ** -25, 2 ** -25 * 1.0000001, 3 * 2 ** -25, 2 ** -24, 2 ** -14 * (1 - 2 ** -11),
                        65504, 65519.996, 65520, 1e30, np.inf, -np.inf, -0.0, -65520]).view(np.uint32)
    nans = np.uint32([0x7F800001, 0x7F801FFF, 0x7F802000, 0x7FC00000, 0x7FFFFFFF, 0xFF800001, 0xFFC00000])
    light = np.concatenate([bits, ties, below, edges, nans]).view(np.float32)
    light = light.reshape(-1, 3)
    n = len(light)
    zeros = np.zeros((n, 3), np.float32)
    incident, reflected, half = np.empty_like(zeros), np.empty_like(zeros), np.empty((n, 3), np.uint16)
    _kernels.pass_light(light, zeros, np.zeros(n, bool), zeros, zeros, incident, reflected, half)
    np.testing.assert_array_equal(incident, light)  # D + 0: the same values (a NaN made quiet)
    with np.errstate(over="ignore", invalid="ignore"):  # the float16 of 1e30 and more is inf
        np.testing.assert_array_equal(half, incident.astype(np.float16).view(np.uint16))
