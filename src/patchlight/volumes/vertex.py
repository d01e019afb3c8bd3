"""Baking incident light to vertex colours, for targets that draw no lightmaps.

The vertex colours are taken from the solved patches around each vertex: those whose
interpolation across the triangles (what the GPU does with COLOR_0) comes closest, in least
squares, to the incident light I of every patch (lightmap texel) outside geometry. Each
patch p lies in a triangle at barycentrics b_p, so with c the (V, 3) vertex values,
sum_k b_pk c_(corner k) should equal I_p; the normal equations (A^T A + lambda) c =
A^T I + lambda c0 have a tiny lambda that only decides vertices no valid patch touches,
which keep c0, the lightmap read at their own lightmap UV. So:
- a surface whose light varies linearly gets it exactly, and a uniformly lit one exactly I;
- vertices that lie inside other geometry (a floor running under the walls, common in level
  geometry, where the bake leaves the texels black) take the light the visible part of their
  triangles shows, extrapolated, instead of the black at their corner.
Patches inside geometry are the bake's own (SolvedScene.valid, saved with the lightmap; a
solved scene that has none counts every covered texel). No ray is traced, so the result
carries no extra noise.

COLOR_0 = the file's vertex colour (white if none) x (I / colorScale, 1), linear: a renderer
that multiplies the base colour by COLOR_0 and lights nothing (glTF's unlit shading,
patchlight's `unlit` model) shows albedo x I / colorScale, the lit diffuse surface scaled.
glTF wants COLOR_0 within 0..1, so colorScale is the largest colour x I (at least 1: a scene
whose light stays below 1 is stored as it is); the root extras.patchlight.vertexLight
{"colorScale": s} records it, and a viewer restores the HDR light as COLOR_0.rgb x s (three.js:
multiply the material colour by s; in glTF's unlit model, base colour factor x s). The light is already in COLOR_0, so save_vertex_lit_glb marks every
material KHR_materials_unlit (listed in extensionsUsed, not extensionsRequired): glTF
viewers that support it (three.js, Babylon.js, Blender, the Khronos sample viewer) draw
base colour x COLOR_0 without lighting it a second time, and those that do not fall back
to the material's PBR definition, lit again. Unlit viewers ignore emission, so an emissive
surface shows only its reflected light; the file keeps emissiveFactor for engines that add it.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from ..scene.model import Scene
from ..shading.textures import sample_bilinear
from ..solved import SolvedScene
REGULARIZATION = 1e-3  # lambda, relative to the mean weight a vertex gets from its patches


def vertex_incident(solved: SolvedScene) -> np.ndarray:
    """(V, 3) f32 incident light I at every vertex of the solved scene (module docstring)."""
    from ..atlas.raster import rasterize

    scene = solved.scene
    at_uv1 = sample_bilinear(solved.lightmap, scene.uv1, wrap="clamp")
    height, width = solved.lightmap.shape[:2]
    patches, _ = rasterize(scene, width, height)
    if solved.valid is None:
        rows = np.arange(len(patches))
    else:
        rows = np.flatnonzero(solved.valid[patches.texel_y, patches.texel_x])
    if len(rows) == 0:
        return at_uv1
    triangle = patches.triangle[rows]
    weights = barycentrics(scene.positions, scene.indices, triangle, patches.position[rows])
    A = sp.csr_matrix((weights.ravel(), (np.repeat(np.arange(len(rows)), 3), scene.indices[triangle].ravel())),
                      shape=(len(rows), len(scene.positions)))
    incident = solved.lightmap[patches.texel_y[rows], patches.texel_x[rows]].astype(np.float64)
    normal = (A.T @ A).tocsc()
    diagonal = normal.diagonal()
    lam = REGULARIZATION * float(diagonal[diagonal > 0].mean())
    system = normal + lam * sp.identity(len(scene.positions), format="csc")
    fitted = spsolve(system, A.T @ incident + lam * at_uv1.astype(np.float64))
    return np.maximum(np.asarray(fitted).reshape(-1, 3), 0.0).astype(np.float32)


def barycentrics(positions: np.ndarray, indices: np.ndarray, triangle: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N, 3) barycentric weights of points (N, 3) in their triangles (N,) (points in the plane)."""
    a, b, c = (positions[indices[triangle, k]].astype(np.float64) for k in range(3))
    e1, e2, p = b - a, c - a, points.astype(np.float64) - a
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    dp1, dp2 = (p * e1).sum(1), (p * e2).sum(1)
    det = d11 * d22 - d12 * d12
    det = np.where(det > 0, det, 1.0)
    v = (d22 * dp1 - d12 * dp2) / det
    w = (d11 * dp2 - d12 * dp1) / det
    return np.stack([1 - v - w, v, w], axis=1)


def with_vertex_light(scene: Scene, incident: np.ndarray) -> tuple[Scene, float]:
    """(a copy of `scene` whose colors (V, 4) are its own (or white) times (I / scale, 1), scale):
    scale is the largest value of colour x I, at least 1, so COLOR_0 stays within 0..1."""
    base = scene.colors if scene.colors is not None else np.ones((len(scene.positions), 4), np.float32)
    lit = base[:, :3].astype(np.float64) * incident
    scale = max(1.0, float(lit.max(initial=0.0)))
    colors = np.concatenate([lit / scale, base[:, 3:]], axis=1)
    return replace(scene, colors=np.clip(colors, 0.0, 1.0).astype(np.float32)), scale


def save_vertex_lit_glb(scene: Scene, path, scale: float) -> Path:
    """Write `scene` and `scale` (from with_vertex_light) as one .glb, atomically, every
    material marked KHR_materials_unlit so viewers draw base colour x COLOR_0 unlit, and
    extras.patchlight.vertexLight = {"colorScale": scale} (module docstring)."""
    from ..scene.gltf import save_baked_glb

    return save_baked_glb(scene, path, unlit=True, extras={"vertexLight": {"colorScale": scale}})
