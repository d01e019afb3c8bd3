"""The volume bake against known answers: uniform surroundings, colour bleeding, a sun patch,
probes inside walls and on their faces, and the floor's excident light seen from just above."""
from __future__ import annotations

import numpy as np
import pytest
from volume_scenes import constant_solved, floor, speck_under_sky, sun

from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.errors import PatchlightError
from patchlight.scene import SceneBuilder, Sky
from patchlight.shading.ambient_cube import ambient_cube_light
from patchlight.solved import SolvedScene, load_solved
from patchlight.volumes import AXIS_VECTORS, ProbeGrid, VolumeSettings, bake_volume, grid_over
from patchlight.volumes.fill import fill_invalid

FAST = VolumeSettings(rays=64)


def probe(volume, i=0, j=0, k=0) -> np.ndarray:
    """(6, 3) values of probe (i, j, k) in axis order +X, +Y, +Z, -X, -Y, -Z."""
    return volume.cube[:, k, j, i]


def test_uniform_sky_gives_six_equal_values():
    L = np.array([0.3, 0.5, 0.7], np.float32)
    volume, stats = bake_volume(speck_under_sky(L), grid_over((0, 0, 0), (1, 1, 1), dims=(2, 2, 2)), FAST)
    np.testing.assert_allclose(volume.cube.reshape(-1, 3), np.tile(L, (48, 1)), rtol=1e-5)
    assert stats["inside_geometry_probes"] == 0 and stats["filled_values"] == 0


def test_furnace_box_gives_its_walls_excident_on_every_axis():
    """Inside a closed box every ray meets a wall leaving B = rho I + E, whatever its direction."""
    b = SceneBuilder()
    b.box((-1, -1, -1), (1, 1, 1), b.material("wall", (0.6, 0.4, 0.2), emissive=(0.1, 0.2, 0.3)), inward=True)
    solved = constant_solved(b.scene("furnace"), (2.0, 1.0, 0.5))
    volume, _ = bake_volume(solved, grid_over((-0.5, -0.5, -0.5), (0.5, 0.5, 0.5), dims=(3, 3, 3)), FAST)
    expected = np.array([0.6 * 2.0 + 0.1, 0.4 * 1.0 + 0.2, 0.2 * 0.5 + 0.3], np.float32)
    np.testing.assert_allclose(volume.cube.reshape(-1, 3), np.tile(expected, (6 * 27, 1)), rtol=1e-5)


@pytest.fixture(scope="module")
def cornell() -> SolvedScene:
    return load_solved("cornell", BakeSettings(resolution=32, rays=64))


def test_probe_beside_the_red_wall_is_red_on_the_axis_facing_it(cornell):
    """Red wall at x = 0.55 m, green wall at x = 0: colour bleeds onto the axis facing each."""
    grid = ProbeGrid((0.05, 0.3, 0.28), (0.45, 1.0, 1.0), (2, 1, 1))
    volume, _ = bake_volume(cornell, grid, VolumeSettings(rays=256))
    by_green, by_red = probe(volume, 0), probe(volume, 1)
    plus_x, minus_x = 0, 3
    assert by_red[plus_x, 0] > 5 * by_red[plus_x, 1]           # facing the red wall: red
    assert by_green[minus_x, 1] > 1.5 * by_green[minus_x, 0]   # facing the green wall: green
    assert by_red[minus_x, 0] < 2 * by_red[minus_x, 1]         # facing away: no longer red


def test_probe_in_a_sun_patch_is_bright_on_the_axes_facing_the_sun():
    """A dark roof over x < 0 and a hard sun towards (0.6, 0.8, 0): the probe in the sun gets
    I = Es cos / pi on +Y (cos 0.8) and +X (cos 0.6), nothing on the others; the probe under
    the roof gets nothing."""
    b = SceneBuilder()
    b.quad([[-6, 2, -3], [0, 2, -3], [0, 2, 3], [-6, 2, 3]], b.material("roof", (0.5, 0.5, 0.5)), (0, -1, 0))
    Es = 2 * np.pi
    solved = constant_solved(b.scene("roof", lights=[sun((0.6, 0.8, 0.0), Es)]), (0, 0, 0))
    volume, _ = bake_volume(solved, ProbeGrid((-2.0, 1.0, 0.0), (4.0, 1.0, 1.0), (2, 1, 1)), FAST)
    shaded, lit = probe(volume, 0), probe(volume, 1)
    expected = np.zeros((6, 3), np.float32)
    expected[1], expected[0] = 2 * 0.8, 2 * 0.6
    np.testing.assert_allclose(lit, expected, atol=1e-5)
    np.testing.assert_allclose(shaded, 0, atol=1e-6)


def thick_wall_under_sky():
    """A solid wall 1 m thick across x in [-0.5, 0.5] under a uniform sky of 1; walls leave 0.5."""
    b = SceneBuilder()
    b.box((-0.5, -3, -3), (0.5, 3, 3), b.material("wall", (0.5, 0.5, 0.5)))
    return constant_solved(b.scene("wall", sky=Sky.uniform((1, 1, 1))), (1, 1, 1))


def test_probes_inside_a_wall_are_marked_and_filled_from_both_sides():
    grid = grid_over((-1.2, 0, 0), (1.2, 0, 0), dims=(5, 1, 1))  # x = -1.2, -0.6, 0, 0.6, 1.2
    volume, stats = bake_volume(thick_wall_under_sky(), grid, FAST)
    assert volume.inside[0, 0].tolist() == [False, False, True, False, False]
    assert stats["inside_geometry_probes"] == 1
    sides = np.stack([probe(volume, 1), probe(volume, 3)])  # alike but for the gather's noise
    assert np.all(probe(volume, 2) >= sides.min(axis=0) - 1e-6) and np.all(probe(volume, 2) <= sides.max(axis=0) + 1e-6)
    np.testing.assert_allclose(probe(volume, 2), sides.mean(axis=0), rtol=0.01)
    assert probe(volume, 2).min() > 0.4  # not darkened: the sky and the wall's 0.5 all round


def hut() -> SolvedScene:
    """A closed hut of 0.2 m solid walls, floor and roof around a 2 m room (0..2 on each axis),
    dim inside (every surface leaves 0.05) under a bright sky of 10."""
    b = SceneBuilder()
    m = b.material("wall", (0.5, 0.5, 0.5))
    t = 0.2
    b.box((-t, -t, -t), (2 + t, 0, 2 + t), m)
    b.box((-t, 2, -t), (2 + t, 2 + t, 2 + t), m)
    b.box((-t, 0, -t), (0, 2, 2 + t), m)
    b.box((2, 0, -t), (2 + t, 2, 2 + t), m)
    b.box((0, 0, -t), (2, 2, 0), m)
    b.box((0, 0, 2), (2, 2, 2 + t), m)
    return constant_solved(b.scene("hut", sky=Sky.uniform((10, 10, 10))), (0.1, 0.1, 0.1))


def test_probes_on_a_huts_inner_wall_faces_take_the_rooms_light_not_the_skys():
    """The grid puts probes exactly on the hut's inner faces (x, z = 0 and 2), and outside
    (x, z = -0.5 and 2.5, in the sky): those on the faces must look like the room."""
    grid = ProbeGrid((-0.5, 1.0, -0.5), (0.5, 1.0, 0.5), (7, 1, 7))
    volume, _ = bake_volume(hut(), grid, FAST)
    values = volume.cube[:, :, 0, :, 0]  # (6, NZ, NX) red
    room = values[:, 2:5, 2:5]
    np.testing.assert_allclose(room, 0.05, rtol=1e-4)
    faces = values[:, 1:6, 1:6].copy()
    faces[:, 1:4, 1:4] = np.nan
    assert np.nanmax(faces) < 0.06 and np.nanmin(faces) > 0.04
    assert values[:, 0, :].max() > 5 and values[:, :, 0].max() > 5  # the probes outside see the sky


def test_fill_follows_the_open_side():
    """Three probes along X: sky-lit 100, one on a wall's face whose +-X axes look into the
    wall, room-lit 1. Open towards +X, its +-X axes take the room's value; with no open side,
    the mean of both."""
    cube = np.zeros((6, 1, 1, 3, 3), np.float32)
    cube[:, 0, 0, 0], cube[:, 0, 0, 2] = 100.0, 1.0
    cube[:, 0, 0, 1] = 7.0
    invalid = np.zeros((6, 1, 1, 3), bool)
    invalid[[0, 3], 0, 0, 1] = True
    side = np.zeros((1, 1, 3, 3), np.float32)
    side[0, 0, 1] = (1, 0, 0)
    filled = fill_invalid(cube, invalid, side)[:, 0, 0, 1]
    np.testing.assert_allclose(filled[[0, 3]], 1.0)
    np.testing.assert_allclose(filled[[1, 2, 4, 5]], 7.0)  # valid values stay
    np.testing.assert_allclose(fill_invalid(cube, invalid, np.zeros_like(side))[[0, 3], 0, 0, 1], 50.5)


def test_fill_inside_geometry_leans_to_the_dim_side():
    """A probe inside a wall between the sunlit outside (100) and a room (1) takes nearly the
    room's light (weights 1 / luminance^2: (100 / 100^2 + 1) / (1 / 100^2 + 1)), whatever its
    open side says; between equal neighbours it takes their value."""
    cube = np.zeros((6, 1, 1, 3, 3), np.float32)
    cube[:, 0, 0, 0], cube[:, 0, 0, 2] = 100.0, 1.0
    invalid = np.zeros((6, 1, 1, 3), bool)
    invalid[:, 0, 0, 1] = True
    towards_sky = np.zeros((1, 1, 3, 3), np.float32)
    towards_sky[0, 0, 1] = (-1, 0, 0)  # rays leaking through coincident faces
    for side in (np.zeros_like(towards_sky), towards_sky):
        np.testing.assert_allclose(fill_invalid(cube, invalid, side)[:, 0, 0, 1], 1.01 / 1.0001, rtol=1e-5)
    cube[:, 0, 0, 0] = 1.0
    np.testing.assert_allclose(fill_invalid(cube, invalid, towards_sky)[:, 0, 0, 1], 1.0, rtol=1e-6)


def test_no_sky_leaks_into_a_hut_through_probes_inside_its_walls():
    """The audit's light leak: a grid whose probes at -0.1 and 2.1 lie inside the hut's walls,
    floor and roof, with the sky 200 times brighter than the room outside them. Points inside
    the room 2 to 5 cm from the walls, in the corners too, must read the room's light on every
    normal (before: the wall probes, filled from the sunlit side too, lit them 140 times too bright)."""
    grid = ProbeGrid((-0.65, -0.65, -0.65), (0.55, 0.55, 0.55), (7, 7, 7))  # -0.65, -0.1, 0.45, .., 2.1, 2.65
    volume, _ = bake_volume(hut(), grid, FAST)
    assert volume.inside[3, 3].tolist() == [False, True, False, False, False, True, False]
    assert volume.validity[3, 3, 1] == 0 and volume.validity[3, 3, 2] == 1
    points = np.array([[0.05, 1.0, 1.0], [0.02, 0.7, 1.3], [1.0, 0.05, 1.0], [1.0, 1.95, 1.0], [1.95, 1.0, 0.7],
                       [1.0, 1.2, 0.05], [1.3, 0.9, 1.98], [0.05, 0.05, 0.05], [1.98, 1.98, 1.98]], np.float32)
    normals = np.random.default_rng(0).normal(size=(24, 3)).astype(np.float32)
    normals = np.concatenate([AXIS_VECTORS, normals / np.linalg.norm(normals, axis=1, keepdims=True)])
    P, N = np.repeat(points, len(normals), axis=0), np.tile(normals, (len(points), 1))
    np.testing.assert_allclose(ambient_cube_light(volume, P, N), 0.05, rtol=0.02)
    outside = ambient_cube_light(volume, np.array([[-0.65, 1.0, 1.0]], np.float32), AXIS_VECTORS[3:4])
    assert outside.min() > 5  # the sky is there to leak


def test_probe_above_a_lit_floor_sees_its_excident_light_below():
    """Just above a 40 m floor under a sun and a uniform sky, -Y sees the floor leaving
    rho x (the lightmap's I there), and +Y sees the sky and the sun: L + Es cos / pi."""
    rho, L, Es = 0.5, 0.4, 3.0
    to_sun = np.array([0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2])
    scene = floor(20.0, (rho, rho, rho), lights=[sun(to_sun, Es)], sky=Sky.uniform((L, L, L)))
    result = bake(scene, BakeSettings(resolution=16, rays=64))
    solved = SolvedScene(result.scene, result.lightmap, "floor")
    volume, _ = bake_volume(solved, ProbeGrid((0.0, 0.05, 0.0), (1.0, 1.0, 1.0), (1, 1, 1)), VolumeSettings(rays=1024))
    tri = np.flatnonzero(np.abs(result.scene.positions[result.scene.indices].mean(axis=1)).max(axis=1) < 20.0)[:1]
    floor_I = solved.incident(tri, np.array([1 / 3], np.float32), np.array([1 / 3], np.float32))[0]
    sky_and_sun = L + Es * to_sun[1] / np.pi
    np.testing.assert_allclose(floor_I, sky_and_sun, rtol=0.01)  # the bake itself
    np.testing.assert_allclose(probe(volume)[4], rho * floor_I, rtol=0.01)
    np.testing.assert_allclose(probe(volume)[1], sky_and_sun, rtol=1e-4)


def test_the_room_floor_reads_the_same_light_at_its_surface_and_a_hair_above():
    """With probes on the floor's own plane (a grid reaching the box's faces at 0.5 m spacing),
    half their rays meet the floor from behind, their validity flips between neighbours, and the
    floor's light jumped from cell to cell with float rounding of y. Probes at cell centres lie
    a quarter spacing off the floor."""
    solved = load_solved("room", BakeSettings(resolution=64))
    lo, hi = solved.scene.bounds()
    grid = grid_over(lo, hi, spacing=0.5)
    layers = grid.origin[1] + grid.spacing[1] * np.arange(grid.dims[1])
    assert np.min(np.abs(layers)) == pytest.approx(0.25, abs=1e-3)
    volume, _ = bake_volume(solved, grid, FAST)
    x = np.linspace(0.3, 7.7, 75)
    up = np.tile([0.0, 1.0, 0.0], (len(x), 1))
    on, above = (ambient_cube_light(volume, np.stack([x, np.full_like(x, y), np.full_like(x, 3.0)], 1), up)
                 for y in (0.0, 1e-3))
    np.testing.assert_allclose(on, above, rtol=0.02)


def test_fill_ends_when_an_axis_has_no_valid_value_anywhere():
    """+X invalid at every probe: no ring can reach it; it takes the mean of the known values
    after at most the grid's longest side in rings, rather than looping for ever."""
    cube = np.ones((6, 2, 2, 3, 3), np.float32)
    cube[1:] *= 3.0
    invalid = np.zeros((6, 2, 2, 3), bool)
    invalid[0] = True
    filled = fill_invalid(cube, invalid, np.zeros((2, 2, 3, 3), np.float32))
    np.testing.assert_allclose(filled[0], 3.0)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_fill_refuses_values_that_are_not_finite(bad):
    cube = np.ones((6, 1, 1, 3, 3), np.float32)
    cube[2, 0, 0, 0, 1] = bad
    invalid = np.zeros((6, 1, 1, 3), bool)
    invalid[:, 0, 0, 1] = True
    with pytest.raises(PatchlightError, match="not finite"):
        fill_invalid(cube, invalid, np.zeros((1, 1, 3, 3), np.float32))
