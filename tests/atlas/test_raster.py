"""Texel rasterisation: conservative coverage, owner choice, positions, normals, reflectance."""
from __future__ import annotations

import numpy as np
import pytest
from atlas_meshes import cube_scene, make_scene, needle_scene, quad_scene

from patchlight.atlas.raster import rasterize
from patchlight.atlas.uvs import ensure_lightmap_uvs
from patchlight.errors import PatchlightError
from patchlight.scene.model import Material


def clip(triangle, x, y):
    """Polygon (K, 2) of triangle (3, 2) inside the square [x, x+1] x [y, y+1], clipping the
    triangle against the square's four sides (the kernel does the reverse)."""
    polygon = [tuple(p) for p in triangle]
    for axis, bound, keep_below in ((0, x, False), (0, x + 1, True), (1, y, False), (1, y + 1, True)):
        def inside(p):
            return p[axis] <= bound if keep_below else p[axis] >= bound
        out = []
        for i, p in enumerate(polygon):
            q = polygon[(i + 1) % len(polygon)]
            if inside(p):
                out.append(p)
            if inside(p) != inside(q):
                s = (bound - p[axis]) / (q[axis] - p[axis])
                out.append((p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1])))
        polygon = out
        if len(polygon) < 3:
            return np.zeros((0, 2))
    return np.array(polygon)


def clip_area(triangle, x, y):
    xs, ys = clip(triangle, x, y).T
    return 0.5 * abs(np.dot(xs, np.roll(ys, -1)) - np.dot(ys, np.roll(xs, -1))) if len(xs) else 0.0


def clip_centroid(triangle, x, y):
    xs, ys = clip(triangle, x, y).T
    cross = xs * np.roll(ys, -1) - np.roll(xs, -1) * ys
    return np.array([((xs + np.roll(xs, -1)) * cross).sum(), ((ys + np.roll(ys, -1)) * cross).sum()]) / (
        3 * cross.sum())


def covers_centre(triangle, x, y):
    p = np.array([x + 0.5, y + 0.5])
    edges = [(triangle[(k + 1) % 3] - triangle[k], p - triangle[k]) for k in range(3)]
    signs = [e[0] * q[1] - e[1] * q[0] for e, q in edges]
    return min(signs) >= 0 or max(signs) <= 0


def test_needles_are_rasterised_conservatively():
    size = 16
    scene = needle_scene(count=200, resolution=size)
    patches, _ = rasterize(scene, size, size)
    tex = scene.uv1[scene.indices].astype(np.float64) * size
    overlap = np.array([[[clip_area(t, x, y) for x in range(size)] for y in range(size)] for t in tex])
    assert (overlap.reshape(len(tex), -1).max(axis=1) > 0).all()  # every needle overlaps a texel
    touched = (overlap > 0).any(axis=0)
    np.testing.assert_array_equal(patches.index >= 0, touched)
    # every needle owns a texel or touches one that is covered
    assert ((overlap > 0) & (patches.index >= 0)).reshape(len(tex), -1).any(axis=1).all()
    # the owner covers the centre, or (when no toucher does) overlaps the texel most
    for y, x, owner in zip(patches.texel_y, patches.texel_x, patches.triangle):
        centred = [t for t in np.nonzero(overlap[:, y, x] > 0)[0] if covers_centre(tex[t], x, y)]
        if centred:
            assert owner == centred[0]
        else:
            assert overlap[owner, y, x] == pytest.approx(overlap[:, y, x].max(), abs=1e-12)


def test_texels_sharing_only_a_boundary_are_not_covered():
    # uv1 triangle exactly on texel lines: covers texels (0,0), (0,1), (1,1) of a 4x4 map partly,
    # and nothing on the other side of its edges x = 2 or y = 0
    scene = make_scene([[0, 0, 0], [1, 0, 0], [1, 0, 1]], [[0, 1, 2]], uv1=[[0, 0], [0.5, 0], [0.5, 0.5]])
    patches, _ = rasterize(scene, 4, 4)
    assert set(zip(patches.texel_y.tolist(), patches.texel_x.tolist())) == {(0, 0), (0, 1), (1, 1)}


def test_quad_texel_centres_follow_the_affine_map():
    scene = quad_scene(size=2.0)
    patches, charts = rasterize(scene, 2, 2)
    assert len(patches) == 4
    np.testing.assert_array_equal(patches.texel_y, [0, 0, 1, 1])  # rows ordered (y, x)
    np.testing.assert_array_equal(patches.texel_x, [0, 1, 0, 1])
    # u along +x, v along +z, row 0 is v = 0: texel (y, x) centre -> (2 (x + .5) / 2, 0, 2 (y + .5) / 2)
    np.testing.assert_allclose(patches.position, [[0.5, 0, 0.5], [1.5, 0, 0.5], [0.5, 0, 1.5], [1.5, 0, 1.5]],
                               atol=1e-6)
    np.testing.assert_allclose(patches.normal, np.tile([0, 1, 0], (4, 1)), atol=1e-6)
    np.testing.assert_allclose(patches.size, 1.0, rtol=1e-6)
    np.testing.assert_array_equal(patches.index, [[0, 1], [2, 3]])
    assert charts.tolist() == [0, 0] and patches.chart.tolist() == [0, 0, 0, 0]


def test_rim_texels_sample_the_middle_of_their_covered_part():
    scene = make_scene([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 2]], uv1=[[0.1, 0.1], [0.9, 0.1], [0.1, 0.9]])
    patches, _ = rasterize(scene, 4, 4)
    assert len(patches) == 10  # texels whose square meets the triangle's interior
    world_uv = (scene.uv1[0] + patches.position[:, [0, 2]].astype(np.float64) * 0.8) * 4  # texel units
    tex = scene.uv1[scene.indices[0]].astype(np.float64) * 4
    for (x, y), p in zip(zip(patches.texel_x, patches.texel_y), world_uv):
        whole = clip_area(tex, x, y) == pytest.approx(1.0)  # texel inside the triangle: its centre
        np.testing.assert_allclose(p, [x + 0.5, y + 0.5] if whole else clip_centroid(tex, x, y), atol=1e-5)


def test_no_patch_samples_a_box_edge():
    # an inward unit box: a rim texel sampled on an edge would sit on the adjacent wall's plane
    scene, width, height, _ = ensure_lightmap_uvs(cube_scene(), texels_per_unit=8)
    patches, _ = rasterize(scene, width, height)
    on_a_wall = (np.abs(patches.position - 0.5) > 0.5 - 1e-3).sum(axis=1)
    np.testing.assert_array_equal(on_a_wall, 1)
    # xatlas runs chart rims through texel centres; the sample sits at the centroid of the
    # covered part: >= a sixth of a texel (0.125 m / 6) off the rim, where a corner texel's
    # part is a right triangle with half-texel legs
    assert (np.sort(np.abs(patches.position - 0.5), axis=1)[:, 1] < 0.5 - 0.02).all()


def test_normal_is_interpolated_and_flipped_to_the_face_when_facing_away():
    tilted = np.array([[0.6, 0.8, 0], [0.6, 0.8, 0], [0.6, 0.8, 0], [0.6, 0.8, 0]], np.float32)
    patches, _ = rasterize(quad_scene(normals=tilted * 3), 2, 2)  # unnormalised on purpose
    np.testing.assert_allclose(patches.normal, np.tile([0.6, 0.8, 0], (4, 1)), atol=1e-6)
    patches, _ = rasterize(quad_scene(normals=-tilted), 2, 2)  # faces away from +Y
    np.testing.assert_allclose(patches.normal, np.tile([0, 1, 0], (4, 1)), atol=1e-6)


def checker(n, a, b):
    """(n, n, 4) texture alternating colours a and b pixel by pixel."""
    y, x = np.mgrid[:n, :n]
    image = np.where(((x + y) % 2 == 0)[..., None], np.array(a, np.float32), np.array(b, np.float32))
    return np.concatenate([image, np.ones((n, n, 1), np.float32)], axis=2)


def test_reflectance_is_the_texture_mean_over_the_texel():
    red, blue = [0.8, 0.1, 0.0], [0.0, 0.3, 0.6]
    material = Material(base_color=np.array([0.5, 1.0, 1.0, 1.0], np.float32),
                        base_color_texture=checker(8, red, blue))
    patches, _ = rasterize(quad_scene(materials=[material]), 2, 2)
    mean = (np.array(red) + np.array(blue)) / 2 * [0.5, 1.0, 1.0]
    np.testing.assert_allclose(patches.rho, np.tile(mean, (4, 1)), atol=1e-6)


def test_texture_rows_follow_v_down_and_emission_is_sampled_the_same_way():
    top, bottom = [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]
    image = np.zeros((8, 8, 3), np.float32)
    image[:4], image[4:] = top, bottom  # footprint samples hit pixel centres: no bilinear blur
    material = Material(emissive=np.array([2.0, 2.0, 2.0], np.float32), emissive_texture=image)
    colors = np.tile([0.5, 0.25, 1.0, 1.0], (4, 1)).astype(np.float32)
    patches, _ = rasterize(quad_scene(materials=[material], colors=colors), 2, 2)
    np.testing.assert_allclose(patches.emission, 2 * np.array([top, top, bottom, bottom]), atol=1e-6)
    np.testing.assert_allclose(patches.rho, np.tile([0.5, 0.25, 1.0], (4, 1)), atol=1e-6)  # COLOR_0 tints


def test_charts_are_uv_connected_components():
    positions = [[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]] * 2
    uv = [[0, 0], [0.4, 0], [0.4, 0.4], [0, 0.4], [0.6, 0.6], [1, 0.6], [1, 1], [0.6, 1]]
    scene = make_scene(positions, [[0, 2, 1], [0, 3, 2], [4, 6, 5], [4, 7, 6]], uv1=uv)
    patches, charts = rasterize(scene, 10, 10)
    assert charts.tolist() == [0, 0, 1, 1]
    np.testing.assert_array_equal(patches.chart, charts[patches.triangle])


def test_zero_area_triangles_are_skipped_and_bad_input_refused():
    scene = make_scene([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], uv1=[[0, 0], [1, 0], [0, 1]])
    assert len(rasterize(scene, 4, 4)[0]) == 0
    scene.uv1 = None
    with pytest.raises(PatchlightError, match="no lightmap UVs"):
        rasterize(scene, 4, 4)
    with pytest.raises(PatchlightError, match="material id"):
        rasterize(quad_scene(material_ids=np.array([0, 3], np.int32)), 4, 4)


def test_a_texel_has_its_own_position_as_its_one_point_and_its_grid_on_its_triangle():
    """TexelPoints (and the next-event kernel, which makes the same points texel by texel): one
    point a texel is the patch's position, exactly (the rule lamps, sun and emitters share);
    a 3 x 3 grid lies on the plane of the texel's triangle."""
    from patchlight.atlas.raster import TexelPoints
    from patchlight.scene import load_scene

    scene, width, height, _ = ensure_lightmap_uvs(load_scene("cornell"), resolution=64)
    patches, _ = rasterize(scene, width, height)
    points = TexelPoints(scene, patches)
    assert np.array_equal(points(1)[:, 0], patches.position.astype(np.float64))
    grid = points(3)
    corners = scene.positions[scene.indices[patches.triangle]].astype(np.float64)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    off_plane = np.einsum("rkc,rc->rk", grid - corners[:, None, 0], normal)
    assert np.abs(off_plane).max() < 1e-4
