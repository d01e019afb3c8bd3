"""When the form-factor matrix would not fit, passes re-gather its rows: slower, bounded
memory, the same answer."""
import os
import re

import numpy as np
import pytest

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


def test_rows_gathered_in_several_blocks_make_the_same_matrix(monkeypatch):
    import patchlight.radiosity.solve as solve

    scene = load_scene("cornell")
    whole = bake(scene, BakeSettings(resolution=32, adaptive=False))
    monkeypatch.setattr(solve, "ROWS_PER_BLOCK", 100)   # 900-odd rows: ten blocks
    blocks = bake(scene, BakeSettings(resolution=32, adaptive=False))
    assert blocks.stats["form_factor_matrix"]["entries"] == whole.stats["form_factor_matrix"]["entries"]
    np.testing.assert_array_equal(blocks.status, whole.status)
    np.testing.assert_allclose(blocks.lightmap, whole.lightmap, rtol=1e-6, atol=1e-8)


def test_rows_gathered_at_once_go_to_two_blocks_a_core(monkeypatch):
    """A call's rows are cut into two blocks a core (down to MIN_SPLIT_ROWS rows each), and
    every product of them then has a run of blocks for each core: a product multiplies a
    run on one core, and the sampler's first grid, one block, left the other core idle."""
    import patchlight.radiosity.solve as solve

    monkeypatch.setenv("PATCHLIGHT_THREADS", "2")
    monkeypatch.setattr(solve, "MIN_SPLIT_ROWS", 256)  # the box at 64 has 2,403 patches
    calls, runs = [], []
    add_block, runs_of = solve.FormFactors._add_block, solve._runs
    monkeypatch.setattr(solve.FormFactors, "_add_block", lambda self, rows, progress: calls.append(len(rows))
                        or add_block(self, rows, progress))
    monkeypatch.setattr(solve, "_runs", lambda blocks, threads: runs.append(runs_of(blocks, threads)) or runs[-1])
    result = bake(load_scene("cornell"), BakeSettings(resolution=64, adaptive=False))
    computed = result.stats["computed_patches"] + result.stats["inside_geometry_patches"]
    assert computed >= 4 * solve.MIN_SPLIT_ROWS and sum(calls) <= computed
    assert len(calls) == 4 and max(calls) - min(calls) <= 1
    assert runs and all(len(r) == 2 for r in runs)


def test_the_estimate_refuses_what_would_not_fit_and_names_a_resolution_that_would():
    from patchlight.errors import PatchlightError
    from patchlight.radiosity.memory import HEADROOM, check_bake_memory, estimate_bake_bytes, form_factor_budget

    base = estimate_bake_bytes(0, 0)
    assert estimate_bake_bytes(2048, 1024) - base == 2 * (estimate_bake_bytes(1024, 1024) - base) > 0
    check_bake_memory(64, 64, available=10**12)
    with pytest.raises(PatchlightError, match=r"lightmap 4096x4096: the bake needs about [\d.]+ GiB \(and about \d+ "
                                              r"minutes\) .* lower `resolution` \(about 1") as refused:
        check_bake_memory(4096, 4096, available=2**30)
    side = int(re.search(r"about (\d+)\)", str(refused.value)).group(1))
    check_bake_memory(side, side, available=2**30)  # the resolution it names fits
    with pytest.raises(PatchlightError):
        check_bake_memory(side + 64, side + 64, available=2**30)  # and is about the largest that does
    # F gets what the rest leaves, never more than --max-memory, never below zero
    assert form_factor_budget(1024, 1024, 8 << 30, available=4 << 30) == int(HEADROOM * (4 << 30)
                                                                             - estimate_bake_bytes(1024, 1024))
    assert form_factor_budget(64, 64, 1 << 20, available=64 << 30) == 1 << 20
    assert form_factor_budget(4096, 4096, 8 << 30, available=1 << 30) == 0


def test_a_resolution_too_large_for_memory_is_refused_before_any_work(monkeypatch):
    import patchlight.atlas.uvs as uvs
    from patchlight.errors import PatchlightError

    monkeypatch.setattr("patchlight.bake.available_memory", lambda: 1 << 30)
    monkeypatch.setattr(uvs, "ensure_lightmap_uvs", lambda *a, **k: pytest.fail("made UVs before refusing"))
    with pytest.raises(PatchlightError, match="lightmap 8192x8192"):
        bake(load_scene("cornell"), BakeSettings(resolution=8192))


def test_the_peak_estimate_counts_f_up_to_its_budget_and_bake_json_holds_it_beside_the_peak():
    from patchlight.radiosity.memory import FORM_FACTOR_BYTES_PER_TEXEL, estimate_bake_bytes, estimate_peak_bytes

    rest = estimate_bake_bytes(1024, 1024)
    assert estimate_peak_bytes(1024, 1024, budget=1 << 40) == rest + FORM_FACTOR_BYTES_PER_TEXEL * 1024 * 1024
    assert estimate_peak_bytes(1024, 1024, budget=1000) == rest + 1000
    stats = bake(load_scene("cornell"), BakeSettings(resolution=32)).stats
    memory = stats["memory"]
    assert memory["estimated_peak_bytes"] == estimate_peak_bytes(32, 32, stats["form_factor_matrix"]["budget"])
    assert 50 << 20 < memory["peak_resident_bytes"] < 8 << 30  # the interpreter's own, and more


def test_directional_maps_count_in_the_estimates_and_in_the_refusal():
    from patchlight.errors import PatchlightError
    from patchlight.radiosity.memory import (DIRECTIONAL_BYTES_PER_TEXEL, check_bake_memory, estimate_bake_bytes,
                                             estimate_peak_bytes, estimate_seconds)

    assert (estimate_bake_bytes(1024, 512, directional=True) - estimate_bake_bytes(1024, 512)
            == DIRECTIONAL_BYTES_PER_TEXEL * 1024 * 512)
    plain = estimate_bake_bytes(2048, 2048)
    check_bake_memory(2048, 2048, available=int(plain / 0.89))  # fits without its directional maps
    minutes = estimate_seconds(2048, 2048, directional=True) / 60
    assert minutes > estimate_seconds(2048, 2048) / 60 + 0.5  # they gather every texel again
    with pytest.raises(PatchlightError, match=f"lightmap 2048x2048: .* about {minutes:.0f} minutes"):
        check_bake_memory(2048, 2048, available=int(plain / 0.89), directional=True)
    stats = bake(load_scene("cornell"), BakeSettings(resolution=32, directional="dominant")).stats
    budget = stats["form_factor_matrix"]["budget"]
    assert stats["memory"]["estimated_peak_bytes"] == estimate_peak_bytes(32, 32, budget, directional=True)
    assert stats["estimated_seconds"] == estimate_seconds(32, 32, directional=True)


def test_a_bake_says_when_numba_compiled_its_kernels_and_only_then(tmp_path, monkeypatch):
    """load_first_kernel knows a cold cache (a process with an empty NUMBA_CACHE_DIR compiles
    the kernel; the same process's cache then holds it), and a bake that found it cold says
    so in its warnings, which the CLI prints; a warm one says nothing."""
    import subprocess
    import sys

    import patchlight.bake as bake_module

    probe = "from patchlight.radiosity.gather import load_first_kernel as f; print(f(), f())"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    run = lambda: subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True, check=True)
    assert run().stdout.split() == ["False", "True"]  # compiled by the first call, not by the second
    assert run().stdout.split() == ["True", "True"]   # the next process loads it from the cache
    scene = load_scene("cornell")
    bake(scene, BakeSettings(resolution=32))  # compiles what this process may still lack
    assert bake_module.COMPILED not in bake(scene, BakeSettings(resolution=32)).stats["warnings"]
    monkeypatch.setattr(bake_module, "load_first_kernel", lambda: False)
    assert bake_module.COMPILED in bake(scene, BakeSettings(resolution=32)).stats["warnings"]
