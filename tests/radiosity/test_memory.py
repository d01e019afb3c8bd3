"""When the form-factor matrix would not fit, passes re-gather its rows: slower, bounded
memory, the same answer."""
import numpy as np

from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.scene import load_scene


def test_regathering_gives_the_stored_matrix_answer():
    scene = load_scene("cornell")
    kept = bake(scene, BakeSettings(resolution=32))
    bounded = bake(scene, BakeSettings(resolution=32, max_memory=0))
    assert kept.stats["form_factor_matrix"]["kept"] and kept.stats["form_factor_matrix"]["bytes"] > 0
    assert not bounded.stats["form_factor_matrix"]["kept"] and bounded.stats["form_factor_matrix"]["bytes"] == 0
    assert bounded.stats["rays_gather"] == kept.stats["rays_gather"]
    assert bounded.stats["rays_regather"] > 0 == kept.stats["rays_regather"]
    np.testing.assert_array_equal(bounded.status, kept.status)
    np.testing.assert_allclose(bounded.lightmap, kept.lightmap, rtol=1e-5, atol=1e-7)


def test_a_budget_that_fills_up_mid_gather_drops_the_matrix_and_keeps_the_answer():
    scene = load_scene("cornell")
    kept = bake(scene, BakeSettings(resolution=32))  # the sampler adds rows in several blocks
    full = kept.stats["form_factor_matrix"]["bytes"]
    half = bake(scene, BakeSettings(resolution=32, max_memory=full // 2))
    assert not half.stats["form_factor_matrix"]["kept"] and half.stats["form_factor_matrix"]["bytes"] == 0
    assert 0 < half.stats["rays_regather"] < kept.stats["rays_gather"] * half.stats["passes"] * 2
    np.testing.assert_allclose(half.lightmap, kept.lightmap, rtol=1e-5, atol=1e-7)

