"""The passes: the stop rule (the change still to come, from the changes so far), their sweep, and the
products of F."""
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
