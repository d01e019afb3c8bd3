"""Texture lookups behave like WebGL2's linear filtering (patchlight.shading.textures)."""
from __future__ import annotations

import numpy as np

from patchlight.shading.textures import cube_directions, cube_face_coords, sample_bilinear, sample_cube


def test_bilinear_hits_texel_centres_and_averages_between_them():
    tex = np.arange(2 * 4 * 1, dtype=np.float32).reshape(2, 4, 1)
    centres = np.array([[(j + 0.5) / 4, (i + 0.5) / 2] for i in range(2) for j in range(4)], np.float32)
    np.testing.assert_allclose(sample_bilinear(tex, centres)[:, 0], np.arange(8))
    np.testing.assert_allclose(sample_bilinear(tex, np.array([[0.25, 0.25]]))[0, 0], 0.5)  # between texels 0 and 1
    np.testing.assert_allclose(sample_bilinear(tex, np.array([[0.5, 0.5]]))[0, 0], (1 + 2 + 5 + 6) / 4)


def test_bilinear_wraps_or_clamps_at_the_edges():
    tex = np.array([[[0.0], [10.0]]], np.float32)  # one row, two texels
    uv = np.array([[0.0, 0.5], [1.25, 0.5]], np.float32)
    np.testing.assert_allclose(sample_bilinear(tex, uv, "repeat")[:, 0], [5.0, 0.0])
    np.testing.assert_allclose(sample_bilinear(tex, uv, "clamp")[:, 0], [0.0, 10.0])


def test_row_zero_is_v_zero():
    tex = np.zeros((4, 1, 1), np.float32)
    tex[0] = 1.0
    assert sample_bilinear(tex, np.array([[0.5, 0.125]]))[0, 0] == 1.0


def test_cube_faces_follow_the_gl_table():
    face, s, t = cube_face_coords(np.array([[2.0, 1.0, -0.5], [0.5, -1.0, 0.25], [-0.2, 0.4, -1.0]]))
    assert list(face) == [0, 3, 5]  # +X, -Y, -Z
    np.testing.assert_allclose(s, [0.5 * (0.25 + 1), 0.5 * (0.5 + 1), 0.5 * (0.2 + 1)])
    np.testing.assert_allclose(t, [0.5 * (-0.5 + 1), 0.5 * (-0.25 + 1), 0.5 * (-0.4 + 1)])


def test_cube_texel_directions_read_back_their_texels():
    size = 8
    faces = np.random.default_rng(3).random((6, size, size, 4)).astype(np.float32)
    dirs = cube_directions(size).reshape(-1, 3)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0, atol=1e-6)
    np.testing.assert_allclose(sample_cube(faces, dirs), faces.reshape(-1, 4), atol=1e-5)


def test_cube_filtering_runs_across_face_edges_and_corners():
    """Seamless filtering (always on in WebGL2): at an edge the two faces' texels average, at a
    corner the three faces', and a smooth picture stays smooth across every edge."""
    values = np.arange(1.0, 7.0, dtype=np.float32)  # face f holds f + 1
    faces = np.broadcast_to(values[:, None, None, None], (6, 4, 4, 1)).copy()
    edge = np.array([[1.0, 0.2, 1.0 - 1e-6]])        # on +X, at its edge with +Z
    np.testing.assert_allclose(sample_cube(faces, edge)[0, 0], (1 + 5) / 2, rtol=1e-4)
    corner = np.array([[1.0, 1.0 - 1e-6, -(1.0 - 1e-6)]])  # on +X, where +Y and -Z meet it
    np.testing.assert_allclose(sample_cube(faces, corner)[0, 0], (1 + 3 + 6) / 3, rtol=1e-4)
    size = 16
    smooth = cube_directions(size) @ np.array([0.3, 0.5, 0.8], np.float32)  # a linear function of direction
    angle = np.linspace(0, 2 * np.pi, 2001)
    for path in (np.stack([np.cos(angle), 0.3 * np.ones_like(angle), np.sin(angle)], 1),
                 np.stack([np.cos(angle), np.sin(angle), 0.45 * np.ones_like(angle)], 1)):
        along = sample_cube(smooth[..., None], path.astype(np.float32))[:, 0]
        assert np.abs(np.diff(along)).max() < 2 * np.abs(np.diff(path @ [0.3, 0.5, 0.8])).max()  # no seams
