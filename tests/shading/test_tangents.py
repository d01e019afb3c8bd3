"""Per-vertex tangents from UVs, for files that carry none."""
from __future__ import annotations

import numpy as np

from patchlight.shading.surface import vertex_tangents


def test_quad_tangent_follows_u_and_bitangent_points_up_the_image():
    # x grows with u, z grows with v (v = 0 is the image's top row), normal +Y
    positions = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]], np.float32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    normals = np.tile([0.0, 1.0, 0.0], (4, 1)).astype(np.float32)
    indices = np.array([[0, 2, 1], [0, 3, 2]], np.int32)
    t = vertex_tangents(positions, normals, uv, indices)
    np.testing.assert_allclose(t[:, :3], np.tile([1, 0, 0], (4, 1)), atol=1e-6)
    bitangent = np.cross(normals, t[:, :3]) * t[:, 3:]
    np.testing.assert_allclose(bitangent, np.tile([0, 0, -1], (4, 1)), atol=1e-6)  # towards -v


def test_mirrored_uvs_flip_the_handedness():
    positions = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]], np.float32)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)  # v flipped
    normals = np.tile([0.0, 1.0, 0.0], (4, 1)).astype(np.float32)
    t = vertex_tangents(positions, normals, uv, np.array([[0, 2, 1], [0, 3, 2]], np.int32))
    assert np.all(t[:, 3] == -1.0)
    np.testing.assert_allclose(np.cross(normals, t[:, :3]) * t[:, 3:], np.tile([0, 0, 1], (4, 1)), atol=1e-6)


def test_tangents_are_unit_and_perpendicular_to_the_normals_even_without_uv_gradient():
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    normals = np.tile([0.0, 0.0, 1.0], (3, 1)).astype(np.float32)
    t = vertex_tangents(positions, normals, np.zeros((3, 2), np.float32), np.array([[0, 1, 2]], np.int32))
    np.testing.assert_allclose(np.linalg.norm(t[:, :3], axis=1), 1.0, atol=1e-6)
    np.testing.assert_allclose(np.einsum("ij,ij->i", t[:, :3], normals), 0.0, atol=1e-6)


def test_corners_count_by_their_angle_not_their_size_as_mikktspace_weights_them():
    """Two 45-degree corners at one vertex, one triangle 100 times the other, their u running
    along +x and +z: the tangent is the bisector."""
    positions = np.array([[0, 0, 0], [10, 0, 0], [10, 0, 10], [0, 0, 0.1], [-0.1, 0, 0.1]], np.float32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [1, 0], [1, 1]], np.float32)
    normals = np.tile([0.0, 1.0, 0.0], (5, 1)).astype(np.float32)
    t = vertex_tangents(positions, normals, uv, np.array([[0, 2, 1], [0, 3, 4]], np.int32))
    np.testing.assert_allclose(t[0, :3], np.array([1, 0, 1]) / np.sqrt(2), atol=1e-6)
    assert t[0, 3] == 1.0
