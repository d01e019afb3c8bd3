"""What `patchlight render` and `patchlight view` draw: a scene, or a bake's (made by
`patchlight.inputs.Input.target`): its scene with the lightmap, the directional maps and
texels.npz (every pass and the per-texel arrays the viewer lays over the surfaces and probes;
the bake directory's files: `patchlight.bakedir`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import PatchlightError
from ..scene.model import Scene
from ..shading.directional import DirectionalLightmap
from ..shading.surface import SurfaceArrays
from ..bakedir import Texels


@dataclass
class Target:
    """scene; surface: its per-vertex arrays; lightmap (H, W, 3) f32 incident light or None;
    bake_dir: the bake directory or None; directional: the bake's directional lightmap or None;
    texels: its texels.npz, or None."""

    scene: Scene
    surface: SurfaceArrays
    lightmap: np.ndarray | None = None
    bake_dir: Path | None = None
    directional: DirectionalLightmap | None = None
    texels: Texels | None = None

    @classmethod
    def from_scene(cls, scene: Scene, lightmap: np.ndarray | None = None, bake_dir: Path | None = None) -> "Target":
        scene.validate()
        if lightmap is not None and scene.uv1 is None:
            raise PatchlightError(f"{scene.label}: a lightmap needs lightmap UVs (TEXCOORD_1)")
        return cls(scene, SurfaceArrays.from_scene(scene), lightmap, bake_dir)

    @property
    def name(self) -> str:
        return str(self.bake_dir) if self.bake_dir else self.scene.label

