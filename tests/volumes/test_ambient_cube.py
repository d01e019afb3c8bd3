"""The ambient-cube model's NumPy reference: weights, interpolation, and the volume file."""
from __future__ import annotations

import json

import numpy as np
import pytest

from patchlight.errors import PatchlightError
from patchlight.shading.ambient_cube import ambient_cube_light, ambient_cube_weights
from patchlight.volumes import AXIS_VECTORS, LightVolume, ProbeGrid, compact, expand, read_volume, write_volume
from patchlight.volumes.volume import LUMINANCE


def uniform_volume(rgb, dims=(2, 2, 2)) -> LightVolume:
    grid = ProbeGrid((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), dims)
    cube = np.broadcast_to(np.asarray(rgb, np.float32), (6, *grid.shape, 3)).copy()
    return LightVolume(grid, cube, np.zeros(grid.shape, bool))


def random_volume(seed=0, dims=(4, 3, 5)) -> LightVolume:
    grid = ProbeGrid((-1.0, 0.5, 2.0), (0.5, 0.7, 0.3), dims)
    cube = np.random.default_rng(seed).random((6, *grid.shape, 3)).astype(np.float32)
    return LightVolume(grid, cube, np.zeros(grid.shape, bool))


def flat_sphere_normals(stacks=24, slices=48) -> np.ndarray:
    """Face normals of a UV sphere's quads: every direction a flat-shaded sphere shows."""
    theta = (np.arange(stacks) + 0.5) / stacks * np.pi
    phi = (np.arange(slices) + 0.5) / slices * 2 * np.pi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    return np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], -1).reshape(-1, 3).astype(np.float32)


def test_squared_weights_shade_a_sphere_flat_in_a_uniform_volume():
    normals = flat_sphere_normals()
    points = np.full_like(normals, 0.5)
    light = ambient_cube_light(uniform_volume((0.8, 0.8, 0.8)), points, normals)
    np.testing.assert_allclose(light, 0.8, rtol=0.01)


def test_naive_weights_band_the_same_sphere():
    """saturate(n) weights sum to |nx| + |ny| + |nz|: 1 on the axes, sqrt(3) between them."""
    normals = flat_sphere_normals()
    light = ambient_cube_light(uniform_volume((1, 1, 1)), np.full_like(normals, 0.5), normals, naive=True)[:, 0]
    assert light.min() < 1.1
    assert light.max() > 1.65
    np.testing.assert_allclose(light, np.abs(normals).sum(axis=1), rtol=1e-5)


def test_weights_keep_the_sign_and_pick_one_axis_on_the_axes():
    n = np.array([[0.6, -0.8, 0.0]], np.float32)
    np.testing.assert_allclose(ambient_cube_weights(n), [[0.36, -0.64, 0.0]], rtol=1e-6)
    np.testing.assert_allclose(ambient_cube_weights(n, naive=True), n)
    volume = random_volume()
    p = np.array([[0.1, 1.0, 2.5]], np.float32)
    for axis, n in enumerate(AXIS_VECTORS):
        squared = ambient_cube_light(volume, p, n[None])
        naive = ambient_cube_light(volume, p, n[None], naive=True)
        np.testing.assert_allclose(squared, naive)
        others = [ambient_cube_light(volume, p, m[None]) for m in AXIS_VECTORS]
        assert not any(np.allclose(squared, o) for k, o in enumerate(others) if k != axis)


def test_interpolation_hits_every_probe_and_is_linear_inside_a_cell():
    volume = random_volume()
    points = volume.grid.positions()
    for axis, n in enumerate(AXIS_VECTORS):
        got = ambient_cube_light(volume, points, np.tile(n, (len(points), 1)))
        np.testing.assert_allclose(got, volume.cube[axis].reshape(-1, 3), atol=1e-6)
    a, b = points[0], points[0] + np.asarray(volume.grid.spacing, np.float32)  # one cell's diagonal
    n = np.tile(AXIS_VECTORS[1], (3, 1))
    ends = ambient_cube_light(volume, np.stack([a, b, (a + b) / 2]), n)
    # along the diagonal trilinear is cubic, but on an edge it is linear
    e = a + np.array([volume.grid.spacing[0], 0, 0], np.float32)
    edge = ambient_cube_light(volume, np.stack([a, e, (a + e) / 2]), n)
    np.testing.assert_allclose(edge[2], (edge[0] + edge[1]) / 2, rtol=1e-5)
    assert not np.allclose(ends[2], (ends[0] + ends[1]) / 2)


def test_interpolation_is_continuous_across_cell_faces_and_clamped_outside():
    volume = random_volume(seed=3)
    rng = np.random.default_rng(1)
    normals = rng.normal(size=(200, 3)).astype(np.float32)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    origin, spacing = np.array(volume.grid.origin), np.array(volume.grid.spacing)
    for axis in range(3):
        p = origin + rng.random((200, 3)) * spacing * (np.array(volume.grid.dims) - 1)
        p[:, axis] = origin[axis] + spacing[axis] * rng.integers(1, volume.grid.dims[axis] - 1, 200)
        step = np.zeros(3)
        step[axis] = 1e-4 * spacing[axis]
        below = ambient_cube_light(volume, (p - step).astype(np.float32), normals)
        above = ambient_cube_light(volume, (p + step).astype(np.float32), normals)
        np.testing.assert_allclose(below, above, atol=2e-3)
    hi = origin + spacing * (np.array(volume.grid.dims) - 1)
    outside = np.array([origin - 5, hi + 5], np.float32)
    edges = np.array([origin, hi], np.float32)
    np.testing.assert_allclose(ambient_cube_light(volume, outside, normals[:2]),
                               ambient_cube_light(volume, edges, normals[:2]), rtol=1e-6)


def test_a_single_probe_grid_is_constant():
    volume = uniform_volume((0.2, 0.3, 0.4), dims=(1, 1, 1))
    volume.cube[0] = 2.0
    got = ambient_cube_light(volume, np.array([[-3, 0, 9], [4, 4, 4]], np.float32), np.array([[1, 0, 0]] * 2, np.float32))
    np.testing.assert_allclose(got, 2.0)


def test_compact_form_is_exact_for_one_chromaticity():
    rng = np.random.default_rng(2)
    color = np.array([1.0, 0.6, 0.3], np.float32)
    cube = (color * rng.random((6, 2, 3, 4, 1))).astype(np.float32)
    cube[:, 0, 0, 0] = 0.0  # a black probe
    c, intensity = compact(cube)
    np.testing.assert_allclose(expand(c, intensity), cube, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(c @ LUMINANCE, 1.0, rtol=1e-5)
    np.testing.assert_allclose(intensity, cube @ LUMINANCE, rtol=1e-6)


@pytest.mark.parametrize("layout", ["full", "compact"])
def test_volume_file_round_trip(tmp_path, layout):
    volume = random_volume(seed=5)
    if layout == "compact":
        volume.cube[:] = volume.cube[..., :1] * np.array([0.9, 0.5, 0.2], np.float32)
    volume.inside[1, 2, 3] = True
    header = write_volume(tmp_path, volume, layout)
    back = read_volume(tmp_path)
    assert back.grid == volume.grid and header["dims"] == [4, 3, 5]
    np.testing.assert_array_equal(back.inside, volume.inside)
    if layout == "full":
        assert back.cube.tobytes() == volume.cube.tobytes()
        raw = np.fromfile(tmp_path / "light_volume.bin", "<f4", 6 * 60 * 3).reshape(6, 5, 3, 4, 3)
        np.testing.assert_array_equal(raw, volume.cube)  # the documented layout: axis, z, y, x, rgb
    else:
        np.testing.assert_allclose(back.cube, volume.cube, rtol=1e-5)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_bad_volume_files_say_what_is_wrong(tmp_path):
    with pytest.raises(PatchlightError, match="no light_volume.json"):
        read_volume(tmp_path)
    write_volume(tmp_path, random_volume())
    header = json.loads((tmp_path / "light_volume.json").read_text())
    (tmp_path / "light_volume.json").write_text(json.dumps({**header, "format": "other"}))
    with pytest.raises(PatchlightError, match="not a patchlight light volume"):
        read_volume(tmp_path)
    (tmp_path / "light_volume.json").write_text(json.dumps({**header, "dims": [4, 3, 6]}))
    with pytest.raises(PatchlightError, match="runs past the end|do not match"):
        read_volume(tmp_path)
    (tmp_path / "light_volume.json").write_text("{not json")
    with pytest.raises(PatchlightError, match="not JSON"):
        read_volume(tmp_path)
