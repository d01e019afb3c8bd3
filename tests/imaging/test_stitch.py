"""Seam stitching: lookups across UV chart seams agree after the least-squares fit, texels off
the seams keep their values, and texels without light of their own give way first."""
from __future__ import annotations

import numpy as np
import pytest
from render_scenes import scene_from_parts, uv_sphere

from patchlight.atlas.seams import seam_edges
from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.imaging.stitch import bilinear_weights, seam_differences, seam_points, stitch
from patchlight.scene.model import Light, Material
from patchlight.scene.sky import Sky


def _two_islands():
    """A unit square of two triangles whose diagonal is cut: each triangle its own UV island."""
    positions = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 0], [1, 0, 1], [0, 0, 1]], np.float32)
    uv = np.array([[0.05, 0.05], [0.45, 0.05], [0.45, 0.45], [0.55, 0.55], [0.95, 0.95], [0.55, 0.95]], np.float32)
    return positions, np.array([[0, 1, 2], [3, 4, 5]]), uv


def test_the_cut_diagonal_is_one_seam_with_matching_ends():
    positions, indices, uv = _two_islands()
    uv_a, uv_b = seam_edges(positions, np.tile([0.0, 1.0, 0.0], (6, 1)), indices, uv)
    assert uv_a.shape == (1, 2, 2)
    ends = {tuple(np.round(p, 2)) for p in uv_a[0]}, {tuple(np.round(p, 2)) for p in uv_b[0]}
    assert ends[0] | ends[1] == {(0.05, 0.05), (0.45, 0.45), (0.55, 0.55), (0.95, 0.95)}
    # (0, 0, 0) is (0.05, 0.05) on one side and (0.55, 0.55) on the other: the same end first
    first = {tuple(np.round(uv_a[0, 0], 2)), tuple(np.round(uv_b[0, 0], 2))}
    assert first in ({(0.05, 0.05), (0.55, 0.55)}, {(0.45, 0.45), (0.95, 0.95)})


def test_a_hard_edge_is_no_seam():
    """Where the two sides' normals differ (a fold), the light differs rightly: not stitched."""
    positions, indices, uv = _two_islands()
    positions[5] = [0, 1, 1]  # the second triangle folded up about the diagonal
    normals = np.array([[0, 1, 0]] * 3 + [[-0.7071, 0.7071, 0]] * 3)
    assert len(seam_edges(positions, normals, indices, uv)[0]) == 0
    assert len(seam_edges(positions, np.tile([0.0, 1.0, 0.0], (6, 1)), indices, uv)[0]) == 1


def test_stitching_makes_the_two_sides_agree_and_invalid_texels_give_way():
    positions, indices, uv = _two_islands()
    uv_a, uv_b = seam_edges(positions, np.tile([0.0, 1.0, 0.0], (6, 1)), indices, uv)
    rng = np.random.default_rng(0)
    image = np.concatenate([np.full((32, 16, 1), 1.0), np.full((32, 16, 1), 2.0)], axis=1) + rng.uniform(0, 0.1, (32, 32, 1))
    image = np.repeat(image, 3, axis=2).astype(np.float32)
    image[..., 2] *= 0.5
    valid = np.zeros((32, 32), bool)
    valid[:, :16] = True  # the right island holds no light of its own: it should follow the left
    assert seam_differences(image, uv_a, uv_b).max() > 0.3
    out = stitch(image, uv_a, uv_b, valid)
    assert seam_differences(out, uv_a, uv_b).max() < 1e-3
    moved = np.abs(out - image).max(axis=2)
    assert moved[valid].max() < 0.01 < moved[~valid].max()
    assert np.array_equal(out[20:, 2:10], image[20:, 2:10])  # far from the seam: untouched


def test_a_baked_sphere_agrees_across_its_seams_within_one_percent():
    sun = Light("directional", np.ones(3, np.float32), 3.0,
                direction=np.array([-0.3, -0.8, -0.5], np.float32) / np.linalg.norm([-0.3, -0.8, -0.5]))
    scene = scene_from_parts([uv_sphere(16, 32)], [Material(base_color=np.array([0.7, 0.7, 0.7, 1], np.float32))],
                             [0], [sun], Sky.gradient([0.2, 0.3, 0.6], [0.4, 0.4, 0.45], [0.1, 0.08, 0.06]))
    plain = bake(scene, BakeSettings(resolution=48, rays=64, stitch=False, directional="sh"))
    stitched = bake(scene, BakeSettings(resolution=48, rays=64, directional="sh"))
    seams = stitched.stats["seams"]
    assert seams["edges"] > 20
    assert seams["before"]["median"] > 0.01 and seams["before"]["max"] > 0.05  # xatlas' seams do jump
    assert seams["after"]["max"] < 0.01
    changed = np.any(stitched.lightmap != plain.lightmap, axis=2)
    uv_a, uv_b = seam_edges(stitched.scene.positions, stitched.scene.normals, stitched.scene.indices,
                              stitched.scene.uv1)
    assert seam_differences(plain.lightmap, uv_a, uv_b).max() == pytest.approx(seams["before"]["max"])
    assert 0 < changed.sum() < (plain.patches.index >= 0).sum()  # only seam texels move
    # the directional maps are stitched too: L0 relative to itself (noisier than the lightmap,
    # measured max 1.05 %), L1 (signed) relative to L0 there
    before = seam_differences(plain.directional.maps[0], uv_a, uv_b)
    after = seam_differences(stitched.directional.maps[0], uv_a, uv_b)
    assert np.median(before) > 0.01 and np.median(after) < 0.001 and after.max() < 0.02
    pa, pb = seam_points(uv_a, uv_b, 48, 48)
    scale = (bilinear_weights(pa, 48, 48) @ stitched.directional.maps[0].reshape(48 * 48, 3)).mean()  # L0 there
    for layer in (1, 2, 3):
        flat = stitched.directional.maps[layer].reshape(48 * 48, 3)
        jump = (bilinear_weights(pa, 48, 48) - bilinear_weights(pb, 48, 48)) @ flat
        assert np.abs(jump).max() < 0.02 * scale  # measured 1.2 %
