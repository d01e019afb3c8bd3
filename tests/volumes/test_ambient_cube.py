"""The ambient-cube model's NumPy reference: weights, interpolation, and the volume file."""
from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from patchlight.errors import PatchlightError
from patchlight.shading.ambient_cube import MIN_VALID_WEIGHT, ambient_cube_light, ambient_cube_weights, volume_texture
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
    volume.validity[1, 2, 3], volume.validity[0, 0, 0] = 0.0, 0.25
    header = write_volume(tmp_path, volume, layout)
    back = read_volume(tmp_path)
    assert back.grid == volume.grid and header["dims"] == [4, 3, 5] and header["version"] == 2
    np.testing.assert_array_equal(back.inside, volume.inside)
    assert back.validity.dtype == np.float32 and back.validity.tobytes() == volume.validity.tobytes()
    assert [s["name"] for s in header["sections"]][-2:] == ["inside", "validity"]
    if layout == "full":
        assert back.cube.tobytes() == volume.cube.tobytes()
        raw = np.fromfile(tmp_path / "light_volume.bin", "<f4", 6 * 60 * 3).reshape(6, 5, 3, 4, 3)
        np.testing.assert_array_equal(raw, volume.cube)  # the documented layout: axis, z, y, x, rgb
    else:
        np.testing.assert_allclose(back.cube, volume.cube, rtol=1e-5)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_a_version_1_file_without_validity_reads_it_from_the_inside_flags(tmp_path):
    volume = random_volume(seed=6)
    volume.inside[2, 1, 0] = True
    header = write_volume(tmp_path, volume)
    header["version"] = 1
    header["sections"] = [s for s in header["sections"] if s["name"] != "validity"]
    (tmp_path / "light_volume.json").write_text(json.dumps(header))
    back = read_volume(tmp_path)
    np.testing.assert_array_equal(back.validity, np.where(volume.inside, 0.0, 1.0))
    assert back.validity[2, 1, 0] == 0 and back.validity.sum() == volume.grid.count - 1


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
    (tmp_path / "light_volume.json").write_text(json.dumps({**header, "version": 3}))
    with pytest.raises(PatchlightError, match="volume version 3, this patchlight reads 1 and 2"):
        read_volume(tmp_path)
    (tmp_path / "light_volume.json").write_text(json.dumps(
        {**header, "sections": [s for s in header["sections"] if s["name"] != "validity"]}))
    with pytest.raises(PatchlightError, match="no 'validity' section"):
        read_volume(tmp_path)
    volume = random_volume()
    volume.validity[0, 0, 0] = 1.5
    write_volume(tmp_path, volume)
    with pytest.raises(PatchlightError, match="validity values must lie in 0..1"):
        read_volume(tmp_path)
    (tmp_path / "light_volume.json").write_text("{not json")
    with pytest.raises(PatchlightError, match="not JSON"):
        read_volume(tmp_path)


def sampled_by_the_file_format(volume, p: np.ndarray, axis: int) -> np.ndarray:
    """Axis `axis`'s light (3,) at point p (3,), written out from light_volume's documented
    "Sampling" rule (patchlight.volumes.io), corner by corner in float64 after finding the
    cell in float32, as the shader does (on a probe beside invalid ones the result follows
    the last bit of f, by design 1 / MIN_VALID_WEIGHT times as fast as elsewhere)."""
    dims = np.array(volume.grid.dims)
    g = np.clip((p.astype(np.float32) - np.array(volume.grid.origin, np.float32)) / np.array(volume.grid.spacing, np.float32),
                0, dims - 1).astype(np.float64)
    i0 = np.minimum(np.floor(g).astype(int), np.maximum(dims - 2, 0))
    i1, f = np.minimum(i0 + 1, dims - 1), g - i0
    corners = []
    for c in itertools.product((0, 1), repeat=3):
        x, y, z = np.where(c, i1, i0)
        t = np.prod(np.where(c, f, 1 - f))
        corners.append((t, float(volume.validity[z, y, x]), volume.cube[axis, z, y, x].astype(np.float64)))
    s = sum(t * v for t, v, _ in corners)
    a = max(MIN_VALID_WEIGHT - s, 0.0)
    return sum(t * (v + a) * value for t, v, value in corners) / (s + a)


def test_interpolation_weights_probes_by_their_validity_as_the_file_format_says():
    volume = random_volume(seed=7)
    rng = np.random.default_rng(8)
    volume.validity[:] = rng.choice([0.0, 0.3, 1.0], size=volume.validity.shape)
    volume.validity[1:3, 1:3, 1:3] = 0.0  # some cells inside geometry all round
    origin, extent = np.array(volume.grid.origin), np.array(volume.grid.spacing) * (np.array(volume.grid.dims) - 1)
    points = (origin - 0.2 * extent + 1.4 * extent * rng.random((300, 3))).astype(np.float32)
    points[:20] = volume.grid.positions()[rng.choice(volume.grid.count, 20)]  # on probes, invalid ones too
    for axis, n in enumerate(AXIS_VECTORS):
        got = ambient_cube_light(volume, points, np.tile(n, (len(points), 1)))
        expected = [sampled_by_the_file_format(volume, p, axis) for p in points]
        np.testing.assert_allclose(got, expected, rtol=2e-5, atol=1e-6)


def test_probes_inside_geometry_drop_out_beside_valid_ones():
    """A cell whose x = 0 side lies inside a wall filled with sunlight (100) and whose x = 1
    side is a room (1): every point reads the room, up to where the room's weight f_x falls
    below MIN_VALID_WEIGHT; there the filled values blend in, continuously, and on the wall's
    probes (f_x = 0) it is plain trilinear."""
    volume = uniform_volume((1.0, 1.0, 1.0))
    volume.cube[:, :, :, 0] = 100.0
    volume.inside[:, :, 0] = True
    volume.validity[:, :, 0] = 0.0
    fx = np.array([1.0, 0.5, 0.01, 2 * MIN_VALID_WEIGHT, MIN_VALID_WEIGHT, 0.5 * MIN_VALID_WEIGHT, 1e-7, 0.0])
    yz = np.random.default_rng(4).random((len(fx), 2))
    points = np.column_stack([fx, yz]).astype(np.float32)
    normals = flat_sphere_normals(6, 12)
    light = np.stack([ambient_cube_light(volume, np.repeat(p[None], len(normals), 0), normals)[:, 0] for p in points])
    np.testing.assert_allclose(light[:5], 1.0, rtol=1e-5)  # plain trilinear reads 100 (1 - fx) + fx: up to 99
    np.testing.assert_allclose(light[5], 1 + 99 * 0.5, rtol=1e-3)  # half the weight is the blend's
    np.testing.assert_allclose(light[6], 100 - 99 * 1e-4, rtol=1e-5)  # f_x = 1e-7: GPU rounding moves this little
    np.testing.assert_allclose(light[7], 100.0, rtol=1e-6)
    plain = volume.validity.copy()
    volume.validity[:] = 1.0
    np.testing.assert_allclose(ambient_cube_light(volume, points[-1:], normals[:1]), 100.0, rtol=1e-6)
    volume.validity[:] = plain


def test_cells_all_inside_geometry_interpolate_plainly_and_uniform_validity_changes_nothing():
    volume = random_volume(seed=9)
    rng = np.random.default_rng(10)
    points = volume.grid.positions()[:1] + rng.random((200, 3)).astype(np.float32) * 2
    normals = rng.normal(size=(200, 3)).astype(np.float32)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    plain = ambient_cube_light(volume, points, normals)
    for validity in (0.0, 0.4):
        volume.validity[:] = validity
        np.testing.assert_allclose(ambient_cube_light(volume, points, normals), plain, rtol=1e-5)


def test_the_volume_texture_carries_the_validity_in_alpha():
    volume = random_volume(seed=11)
    volume.validity[0, 1, 2] = 0.0
    rgba = volume_texture(volume)
    nz = volume.grid.dims[2]
    for axis in range(6):
        np.testing.assert_array_equal(rgba[axis * nz:(axis + 1) * nz, ..., 3], volume.validity)
        np.testing.assert_array_equal(rgba[axis * nz:(axis + 1) * nz, ..., :3], volume.cube[axis])
