"""Baking incident light to vertex colours, for targets that draw no lightmaps.

Each vertex takes the solved lightmap at its own lightmap UV: the bilinear mean of the
patches (texels) around it. That is the radiosity solution itself, converged and with the
texels inside geometry already filled from their neighbours by the bake, so vertices where
boxes meet (common in level geometry) are not darkened, and no new rays add noise. A new
gather at the vertex would see the same light, but at such joints its rays start inside the
neighbouring box.

COLOR_0 = the file's vertex colour (white if none) x (I, 1): a renderer that multiplies the
base colour by COLOR_0 and lights nothing (glTF's unlit shading, patchlight's `unlit`
model) then shows albedo x I, the lit diffuse surface. Values are linear and exceed 1 where
the light is bright.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..scene.model import Scene
from ..shading.textures import sample_bilinear
from ..solved import SolvedScene


def vertex_incident(solved: SolvedScene) -> np.ndarray:
    """(V, 3) f32 incident light I at every vertex of the solved scene."""
    return sample_bilinear(solved.lightmap, solved.scene.uv1, wrap="clamp")


def with_vertex_light(scene: Scene, incident: np.ndarray) -> Scene:
    """A copy of `scene` whose colors (V, 4) are its own (or white) times (I, 1)."""
    base = scene.colors if scene.colors is not None else np.ones((len(scene.positions), 4), np.float32)
    light = np.concatenate([incident, np.ones((len(incident), 1), np.float32)], axis=1)
    return replace(scene, colors=(base * light).astype(np.float32))
