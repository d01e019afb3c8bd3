"""What `patchlight render` and `patchlight view` draw: a scene, or a bake directory.

A bake directory (written by `patchlight bake`) holds scene.glb (world-space soup with the
lightmap UVs in TEXCOORD_1), lightmap.exr (float incident light I, row 0 = v 0) and the
pictures lightmap.png, pass_NN.png and adaptive.png, which the viewer lays over the surfaces.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import PatchlightError
from ..scene.model import Scene
from ..shading.surface import SurfaceArrays

_BAKE_PICTURE = re.compile(r"^(lightmap|adaptive|pass_\d{2,})\.png$")


@dataclass
class Target:
    """scene; surface: its per-vertex arrays; lightmap (H, W, 3) f32 incident light or None;
    bake_dir: the bake directory or None."""

    scene: Scene
    surface: SurfaceArrays
    lightmap: np.ndarray | None = None
    bake_dir: Path | None = None

    @classmethod
    def from_scene(cls, scene: Scene, lightmap: np.ndarray | None = None, bake_dir: Path | None = None) -> "Target":
        scene.validate()
        if lightmap is not None and scene.uv1 is None:
            raise PatchlightError(f"{scene.label}: a lightmap needs lightmap UVs (TEXCOORD_1)")
        return cls(scene, SurfaceArrays.from_scene(scene), lightmap, bake_dir)

    @property
    def name(self) -> str:
        return str(self.bake_dir) if self.bake_dir else self.scene.label

    def bake_pictures(self) -> list[str]:
        """File names of the bake's lightmap-space pictures, lightmap first, then passes, adaptive."""
        if self.bake_dir is None:
            return []
        names = [p.name for p in self.bake_dir.iterdir() if p.is_file() and _BAKE_PICTURE.match(p.name)]
        order = {"lightmap.png": 0, "adaptive.png": 2}
        return sorted(names, key=lambda n: (order.get(n, 1), n))


def load_target(spec: str) -> Target:
    """A bake directory (has scene.glb) or anything `patchlight.scene.load_scene` takes."""
    from ..imaging.io import read_exr
    from ..scene import load_scene

    path = Path(spec)
    if path.is_dir():
        if not (path / "scene.glb").is_file():
            raise PatchlightError(f"{spec}: a directory, but not a bake (no scene.glb in it)")
        lightmap_file = path / "lightmap.exr"
        lightmap = read_exr(lightmap_file) if lightmap_file.is_file() else None
        return Target.from_scene(load_scene(path / "scene.glb"), lightmap, path.resolve())
    return Target.from_scene(load_scene(spec))
