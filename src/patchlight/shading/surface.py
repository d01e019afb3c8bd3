"""Per-vertex surface arrays shared by the CPU renderer and the viewer, and the
interpolation that turns them into per-pixel values (the shaders' varyings).

Both sides read the same arrays: unit normals, tangents (the file's, or made here from the
UVs), UVs, vertex colours. The viewer uploads them as they are; the CPU renderer
interpolates them with the barycentrics of its camera rays, which is what the GPU's
perspective-correct interpolation computes for a pinhole camera.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class SurfaceArrays:
    """positions, normals (V, 3) f32 (unit normals); tangents (V, 4) f32 (unit xyz, w = +-1);
    uv0, uv1 (V, 2) f32 (uv1 zeros when the scene has no lightmap UVs); colors (V, 4) f32 (ones
    when the scene has none); indices (T, 3) i32; material_ids (T,) i32."""

    positions: np.ndarray
    normals: np.ndarray
    tangents: np.ndarray
    uv0: np.ndarray
    uv1: np.ndarray
    colors: np.ndarray
    indices: np.ndarray
    material_ids: np.ndarray

    @classmethod
    def from_scene(cls, scene) -> "SurfaceArrays":
        """The arrays of a patchlight.scene.Scene (any object with its vertex and index arrays)."""
        n = len(scene.positions)
        normals = _unit_rows(np.asarray(scene.normals, np.float32), fallback=(0.0, 1.0, 0.0))
        tangents = (np.asarray(scene.tangents, np.float32) if scene.tangents is not None
                    else vertex_tangents(scene.positions, normals, scene.uv0, scene.indices))
        uv1 = scene.uv1 if scene.uv1 is not None else np.zeros((n, 2), np.float32)
        colors = scene.colors if scene.colors is not None else np.ones((n, 4), np.float32)
        if colors.shape[1] == 3:
            colors = np.concatenate([colors, np.ones((n, 1), np.float32)], axis=1)
        return cls(np.ascontiguousarray(scene.positions, np.float32), normals, tangents,
                   np.ascontiguousarray(scene.uv0, np.float32), np.ascontiguousarray(uv1, np.float32),
                   np.ascontiguousarray(colors, np.float32), np.ascontiguousarray(scene.indices, np.int32),
                   np.ascontiguousarray(scene.material_ids, np.int32))


def _unit_rows(v: np.ndarray, fallback) -> np.ndarray:
    length = np.linalg.norm(v, axis=1, keepdims=True)
    out = np.where(length > 0, v / np.where(length > 0, length, 1), np.asarray(fallback, np.float32))
    return out.astype(np.float32)


def vertex_tangents(positions: np.ndarray, normals: np.ndarray, uv: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """(V, 4) tangents from the UVs, for files that carry none, weighted as MikkTSpace (glTF's
    tangent convention) weights them.

    Each triangle's dP/du and dP/dv, made unit and projected into the plane of each corner's
    normal, are summed at its corners weighted by the corner's angle; the sum of dP/du is made
    orthogonal to the normal (Gram-Schmidt), and w = +-1 records whether cross(N, T) points up
    the image (towards -v, glTF's bitangent) or down. MikkTSpace also splits a vertex whose
    triangles disagree on w; the vertices here are fixed, so the summed bitangent decides.
    Vertices without UV gradient get any tangent perpendicular to their normal."""
    p = np.asarray(positions, np.float64)[indices]
    t = np.asarray(uv, np.float64)[indices]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    r = np.divide(1.0, det, out=np.zeros_like(det), where=np.abs(det) > 1e-20)[:, None]
    dp_du = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r
    dp_dv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r
    n = np.asarray(normals, np.float64)
    tan_sum = np.zeros((len(positions), 3))
    bit_sum = np.zeros((len(positions), 3))
    for corner in range(3):
        vertex = indices[:, corner]
        angle = _corner_angle(p, corner)[:, None]
        np.add.at(tan_sum, vertex, angle * _in_plane(dp_du, n[vertex]))
        np.add.at(bit_sum, vertex, angle * _in_plane(dp_dv, n[vertex]))
    tangent = tan_sum - n * np.einsum("ij,ij->i", n, tan_sum)[:, None]
    length = np.linalg.norm(tangent, axis=1)
    missing = length < 1e-12
    tangent[missing] = _any_perpendicular(n[missing])
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    up_image = -bit_sum
    w = np.where(np.einsum("ij,ij->i", np.cross(n, tangent), up_image) < 0, -1.0, 1.0)
    return np.concatenate([tangent, w[:, None]], axis=1).astype(np.float32)


def _corner_angle(p: np.ndarray, corner: int) -> np.ndarray:
    """(T,) the angle (radians) of each triangle (T, 3, 3) at `corner`."""
    a = p[:, (corner + 1) % 3] - p[:, corner]
    b = p[:, (corner + 2) % 3] - p[:, corner]
    cos = np.einsum("ij,ij->i", a, b) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-30)
    return np.arccos(np.clip(cos, -1.0, 1.0))


def _in_plane(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    """v (N, 3) projected into the plane of unit normals n (N, 3) and made unit (zero stays zero)."""
    v = v - n * np.einsum("ij,ij->i", n, v)[:, None]
    length = np.linalg.norm(v, axis=1, keepdims=True)
    return np.divide(v, length, out=np.zeros_like(v), where=length > 1e-20)


def _any_perpendicular(n: np.ndarray) -> np.ndarray:
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    return np.cross(n, helper)


def interpolate(values: np.ndarray, corners: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """Barycentric interpolation: values (V, C) at corners (N, 3) with weights bary (N, 3). (N, C) f32."""
    from ._kernels import interpolate_rows

    out = np.empty((len(corners), values.shape[1]), np.float32)
    interpolate_rows(np.ascontiguousarray(values, np.float32), np.ascontiguousarray(corners),
                     np.ascontiguousarray(bary, np.float32), out)
    return out
