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


def _pieces(n_cols, cuts, uniform=False, rays=24, seed=3):
    """The gather's pieces of rows cuts[0]..cuts[-1] (item_buffer_rows of random item buffers,
    one piece per cut, some empty), the weights (rays,), and each ray that sees a patch as
    (rows, columns), ray by ray."""
    import numpy as np

    from patchlight.radiosity import _kernels

    rng = np.random.default_rng(seed)
    weights = np.full(rays, 1 / rays, np.float32) if uniform else rng.random(rays, dtype=np.float32)
    seen = rng.integers(-3, n_cols, (cuts[-1], rays)).astype(np.int32)  # SKY, BACK_FACE, LOST or a patch
    seen[:, ::3] = seen[:, :1]  # duplicates within a row
    pieces = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        starts, entries, *_ = _kernels.item_buffer_rows(seen[a:b].ravel(), weights, np.ones((rays * (b - a), 3),
                                                        np.float32), _kernels.panel_count(n_cols), uniform)
        pieces.append(PanelRows(starts, entries, b - a))
    hit = seen >= 0
    return pieces, weights, np.nonzero(hit)[0], seen[hit], np.broadcast_to(weights, seen.shape)[hit]


def test_an_address_table_names_each_array_and_refuses_what_a_kernel_cannot_view():
    """address_table: each array's address and length, in order (an empty one too); an array
    of two dimensions or with strides is refused, not viewed wrongly."""
    import numpy as np

    from patchlight.radiosity._kernels import address_table

    arrays = [np.arange(5, dtype=np.uint32), np.zeros(0, np.float32), np.ones(3)]
    table = address_table(arrays)
    assert table.dtype == np.int64 and table.shape == (2, 3)
    assert list(table[0]) == [a.ctypes.data for a in arrays] and list(table[1]) == [5, 0, 3]
    for bad in (np.zeros((3, 2)), np.arange(10)[::2]):
        with pytest.raises(ValueError, match="1-d C-contiguous"):
            address_table([bad])


@pytest.mark.parametrize("uniform", [False, True])
@pytest.mark.parametrize("n_cols", [1000, 65536, 3 * 65536 + 17])  # one column panel, one and an empty one, four
def test_a_panel_block_holds_its_rows_panel_by_panel_in_column_order(n_cols, uniform):
    """Weighted, each (row, column) is one entry of the summed weight; uniform, one entry per
    ray, no weights, each weighing the unit."""
    import numpy as np
    import scipy.sparse as sp

    from patchlight.radiosity.solve import BlockRun, PanelBlock

    cuts = [0, 700, 700, 701, 1500, 2000]  # the gather's chunks: pieces of consecutive rows, one empty
    pieces, weights, rows, cols, w = _pieces(n_cols, cuts, uniform)
    unit = weights[0] if uniform else None
    last_first = []  # the panels' tasks run last first

    def run(fn, items):
        last_first.append(len(items))
        return [fn(item) for item in reversed(items)][::-1]

    block = PanelBlock.of(pieces, run, unit)
    assert block.n_rows == 2000 and not pieces and last_first == [(n_cols >> 16) + 1]
    F = sp.csr_matrix((w, (rows, cols)), shape=(cuts[-1], n_cols), dtype=np.float32)  # duplicates summed
    if not uniform:
        F.sort_indices()
        rows, cols, w = np.repeat(np.arange(F.shape[0]), np.diff(F.indptr)), F.indices, F.data
    order = np.lexsort((rows, cols))  # the expected order: panel, then column, then row
    np.testing.assert_array_equal(block.starts, np.searchsorted(cols[order], np.arange(len(block.starts)) << 16))
    np.testing.assert_array_equal(block.entries & 0xFFFF, rows[order])
    np.testing.assert_array_equal(block.entries >> 16, cols[order] & 0xFFFF)
    if uniform:
        assert block.weights.size == 0 and block.unit == weights[0]
    else:
        np.testing.assert_allclose(block.weights, w[order], rtol=1e-6)
    B = np.random.default_rng(4).random((n_cols, 3), dtype=np.float32)
    np.testing.assert_allclose(BlockRun([block]).times(B), F @ B, rtol=1e-5, atol=1e-6)
    whole = PanelBlock.of(_pieces(n_cols, [0, 2000], uniform)[0], run, unit)  # the rows at once make the same block
    for name in ("starts", "entries", "weights"):
        np.testing.assert_array_equal(getattr(block, name), getattr(whole, name))


def test_a_panel_block_takes_at_most_2_16_rows_and_may_be_empty():
    import numpy as np

    from patchlight.radiosity.solve import BlockRun, PanelBlock

    def run(fn, items):
        return [fn(item) for item in items]

    assert BlockRun([PanelBlock.of([], run)]).times(np.ones((70000, 3), np.float32)).shape == (0, 3)
    words = (np.float32([2.0, 3.0]).view(np.uint32).astype(np.uint64) << 32) | (np.uint64([5, 0]) << 16)
    block = PanelBlock.of([PanelRows(np.array([0, 1, 2]), words, 1)], run)  # row 0: columns 5 and 65536
    np.testing.assert_array_equal(BlockRun([block]).times(np.ones((70000, 3), np.float32)), [[5.0, 5.0, 5.0]])
    many = PanelRows(np.zeros(2, np.int64), np.zeros(0, np.uint64), 65537)
    with pytest.raises(ValueError, match="2\\^16 rows"):
        PanelBlock.of([many], run)


@pytest.mark.parametrize("uniform", [False, True])
def test_a_panel_block_of_2_16_rows_reaches_its_last_row_from_a_later_piece(uniform):
    """Row 65,535, the last a u16 holds, comes from the second piece: its row offset is added
    to the words and must not spill into the column bits (nor, uniform, past the entry's 32)."""
    import numpy as np

    from patchlight.radiosity._kernels import entry_word
    from patchlight.radiosity.solve import BlockRun, PanelBlock

    def word(weight, column, row):
        return entry_word(row, column, 0 if uniform else np.float32(weight).view(np.uint32))

    first = PanelRows(np.array([0, 1, 1]), np.array([word(2.0, 7, 0)]), 65535)  # row 0: column 7
    last = PanelRows(np.array([0, 1, 2]), np.array([word(3.0, 65535, 0), word(5.0, 1, 0)]), 1)
    block = PanelBlock.of([first, last], lambda fn, items: [fn(item) for item in items], 2.0 if uniform else None)
    B = np.arange(3 * 70000, dtype=np.float32).reshape(70000, 3)
    out = BlockRun([block]).times(B)
    assert out.shape == (65536, 3)
    np.testing.assert_array_equal(out[0], 2.0 * B[7])
    expected = 2.0 * (B[65535] + B[65536 + 1]) if uniform else 3.0 * B[65535] + 5.0 * B[65536 + 1]
    np.testing.assert_array_equal(out[65535], expected)
    assert not out[1:65535].any()


def test_blocks_multiplied_together_give_each_blocks_own_product():
    """Panel by panel across blocks (a weighted one, a uniform one, an empty one), each block's
    rows come out as they do alone, bit for bit, one after the other."""
    import numpy as np

    from patchlight.radiosity.solve import BlockRun, PanelBlock

    def run(fn, items):
        return [fn(item) for item in items]

    n_cols = 2 * 65536 + 5
    weighted = PanelBlock.of(_pieces(n_cols, [0, 300, 500])[0], run)
    uniform = PanelBlock.of(_pieces(n_cols, [0, 400], uniform=True, seed=8)[0], run, 1 / 24)
    empty = PanelBlock.of(_pieces(n_cols, [0, 0])[0], run)
    B = np.random.default_rng(6).random((n_cols, 3), dtype=np.float32)
    together = BlockRun([weighted, empty, uniform]).times(B)
    assert together.shape == (900, 3)
    alone = [BlockRun([block]).times(B) for block in (weighted, uniform)]
    np.testing.assert_array_equal(together, np.concatenate(alone))


@pytest.mark.parametrize("sizes, threads", [([5] * 20, 2), ([5] * 3, 2), ([1, 100, 1, 1], 2), ([7], 4), ([], 2)])
def test_product_runs_cover_the_blocks_in_order_with_a_multiple_of_the_threads(sizes, threads):
    import numpy as np

    from patchlight.radiosity.solve import RUN_BLOCKS, PanelBlock, _runs

    blocks = [PanelBlock(np.zeros(2, np.int64), np.zeros(n, np.uint32), np.zeros(0, np.float32), 1.0, 1) for n in sizes]
    runs = _runs(blocks, threads)
    assert [id(b) for run in runs for b in run] == [id(b) for b in blocks] and all(runs)
    if len(blocks) >= threads:
        assert len(runs) % threads == 0 or len(runs) == len(blocks)
    if sizes == [5] * 20:  # equal blocks: runs as long as one another within a block, at most RUN_BLOCKS
        lengths = [len(run) for run in runs]
        assert len(runs) == 6 and max(lengths) - min(lengths) <= 1 and max(lengths) <= RUN_BLOCKS


@pytest.mark.parametrize("uniform", [False, True])
def test_a_block_takes_the_bytes_its_size_says(uniform):
    """The keep-or-drop test of F counts what the block will hold, not the pieces' words."""
    from patchlight.radiosity.solve import PanelBlock

    pieces, weights, *_ = _pieces(3 * 65536 + 17, [0, 300, 700], uniform)
    unit = weights[0] if uniform else None
    size = PanelBlock.size_of(pieces, unit)
    block = PanelBlock.of(pieces, lambda fn, items: [fn(item) for item in items], unit)
    assert size == block.nbytes and PanelBlock.size_of([], unit) == PanelBlock.of([], None).nbytes


def test_a_pass_sweep_writes_incident_reflected_and_numpys_float16_of_the_incident():
    """pass_light on spans of texels: I = D + G, 0 inside geometry; reflected (rho I + E) - E;
    the float16 copy bit for bit NumPy's cast, over float16's whole range and past it
    (subnormals, ties, overflow to inf); and with an empty copy, the same I and reflected."""
    import numpy as np

    from patchlight.radiosity import _kernels

    rng = np.random.default_rng(11)
    n = 4099
    exponents = rng.uniform(-30, 17, (n, 3))  # 2^-30 (below float16's smallest) .. 2^17 (past its largest)
    direct = (rng.random((n, 3)) * 2.0 ** exponents).astype(np.float32)
    gathered = (rng.random((n, 3)) * 2.0 ** exponents).astype(np.float32)
    direct[:64] = np.float32(2.0 ** -24 * np.arange(64 * 3).reshape(64, 3) / 2)  # float16 subnormals and their ties
    gathered[:64] = 0.0
    inside = rng.random(n) < 0.2
    rho = rng.random((n, 3), dtype=np.float32)
    emission = np.where(rng.random((n, 1)) < 0.1, rng.random((n, 3)), 0.0).astype(np.float32)
    incident, reflected = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
    half = np.empty((n, 3), np.uint16)
    for a, b in ((0, 1000), (1000, 1001), (1001, n)):
        _kernels.pass_light(direct[a:b], gathered[a:b], inside[a:b], rho[a:b], emission[a:b], incident[a:b],
                            reflected[a:b], half[a:b])
    expected = np.where(inside[:, None], np.float32(0.0), direct + gathered)
    np.testing.assert_array_equal(incident, expected)
    np.testing.assert_array_equal(reflected, (rho * expected + emission) - emission)
    with np.errstate(over="ignore"):
        np.testing.assert_array_equal(half, expected.astype(np.float16).view(np.uint16))
    assert np.isinf(half.view(np.float16)).any() and (half.view(np.float16)[:64] != 0).any()
    again, reflected_again = np.empty_like(incident), np.empty_like(reflected)
    _kernels.pass_light(direct, gathered, inside, rho, emission, again, reflected_again, np.zeros((0, 3), np.uint16))
    np.testing.assert_array_equal(again, incident)
    np.testing.assert_array_equal(reflected_again, reflected)
