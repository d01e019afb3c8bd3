"""What `patchlight render` and `patchlight view` draw: a scene, or a bake directory.

A bake directory (written by `patchlight bake`, read by `patchlight.solved.load_solved`) holds
scene.glb (world-space soup with the lightmap UVs in TEXCOORD_1), lightmap.exr (float incident
light I, row 0 = v 0), bake.json and texels.npz (every pass and the per-texel arrays the
viewer lays over the surfaces and probes).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..bakedir import read_directional
from ..errors import PatchlightError
from ..scene.model import Scene
from ..shading.directional import DirectionalLightmap
from ..shading.surface import SurfaceArrays
from ..texels import Texels, read_bake_texels


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


def load_target(spec: str) -> Target:
    """A bake directory (`patchlight.solved.load_solved`: scene.glb, lightmap.exr, bake.json)
    or anything `patchlight.scene.load_scene` takes (never baked here)."""
    from ..scene import is_builtin, load_scene
    from ..solved import load_solved

    if not is_builtin(spec) and Path(spec).is_dir():
        solved = load_solved(spec)  # a complete bake, else its one-line error
        target = Target.from_scene(solved.scene, solved.lightmap, Path(spec).resolve())
        target.directional = read_directional(target.bake_dir)
        target.texels = read_bake_texels(spec)
        if target.texels is not None and target.texels.status.shape != solved.lightmap.shape[:2]:
            raise PatchlightError(f"{spec}: texels.npz and lightmap.exr differ in size (a mixture of two bakes)")
        return target
    return Target.from_scene(load_scene(spec))
