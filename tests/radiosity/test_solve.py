"""The stop rule of the passes: the change still to come, from the changes so far."""
import math

import pytest

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


def _counts(pieces, n_cols):
    import numpy as np

    from patchlight.radiosity import _kernels

    panels = _kernels.panel_count(n_cols)
    return np.array([_kernels.panel_counts(p.indptr, p.indices, panels) for p in pieces], np.int64).reshape(-1, panels)


@pytest.mark.parametrize("n_cols", [1000, 65536, 3 * 65536 + 17])  # one column panel, one and an empty one, four
def test_a_panel_block_multiplies_as_its_csr_matrix(n_cols):
    import numpy as np
    import scipy.sparse as sp

    from patchlight.radiosity.solve import PanelBlock

    rng = np.random.default_rng(3)
    F = sp.random(20000, n_cols, density=20 / n_cols, format="csr", dtype=np.float32, random_state=rng)
    F.indices = F.indices.astype(np.int32)
    B = rng.random((n_cols, 3), dtype=np.float32)
    cuts = [0, 7000, 7000, 7001, 15000, 20000]  # the gather's chunks: pieces of consecutive rows, one empty
    pieces = [F[a:b] for a, b in zip(cuts[:-1], cuts[1:])]
    last_first = []  # the pieces' tasks run last first: each writes where the pieces before it end

    def run(fn, items):
        last_first.append(len(items))
        return [fn(item) for item in reversed(items)][::-1]

    block = PanelBlock.of(pieces, _counts(pieces, n_cols), run)
    assert block.n_rows == 20000 and len(block.weights) == F.nnz and last_first[0] == 5
    assert np.all(np.diff(block.starts) >= 0) and block.starts[-1] == F.nnz
    for first, last in zip(block.starts[:-1], block.starts[1:]):  # each panel in column order
        assert np.all(np.diff(block.cols[first:last].astype(np.int64)) >= 0)
    np.testing.assert_allclose(block.times(B), F @ B, rtol=1e-5, atol=1e-6)
    whole = PanelBlock.of([F], _counts([F], n_cols), run)  # the pieces make the block F makes alone
    for a, b in zip((block.starts, block.rows, block.cols, block.weights), (whole.starts, whole.rows, whole.cols,
                                                                            whole.weights)):
        np.testing.assert_array_equal(a, b)


def test_a_panel_block_takes_at_most_2_16_rows_and_may_be_empty():
    import numpy as np
    import scipy.sparse as sp

    from patchlight.radiosity.solve import PanelBlock

    def run(fn, items):
        return [fn(item) for item in items]

    empty = PanelBlock.of([], _counts([], 70000), run)
    assert empty.times(np.ones((70000, 3), np.float32)).shape == (0, 3)
    one = sp.csr_matrix(([2.0, 3.0], ([0, 0], [5, 65536])), shape=(1, 70000), dtype=np.float32)
    block = PanelBlock.of([one], _counts([one], 70000), run)
    np.testing.assert_array_equal(block.times(np.ones((70000, 3), np.float32)), [[5.0, 5.0, 5.0]])
    many = sp.csr_matrix((65537, 4), dtype=np.float32)
    with pytest.raises(ValueError, match="2\\^16 rows"):
        PanelBlock.of([many], _counts([many], 4), run)
