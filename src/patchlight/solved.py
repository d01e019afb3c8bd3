"""A solved scene: a scene with its lightmap, from a bake directory or baked on the spot.

Everything that reads baked light (light volumes, ground maps, vertex colours, the renderer's
`lightmap` model) starts here, and asks `excident` for the light leaving a surface point.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .config import BakeSettings
from .errors import PatchlightError
from .scene.model import Scene
from .shading.surface import interpolate


@dataclass
class SolvedScene:
    """scene (with uv1 lightmap UVs) and lightmap (H, W, 3) f32 incident light I."""

    scene: Scene
    lightmap: np.ndarray
    source: str

    def incident(self, tri: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(N, 3) incident light I at hit points (triangle, barycentrics u, v), bilinear."""
        from .shading.textures import sample_bilinear

        uv1 = _at_hits(self.scene.uv1, self.scene.indices, tri, u, v)
        return sample_bilinear(self.lightmap, uv1, wrap="clamp")

    def reflectance(self, tri: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(N, 3) linear base colour (factor x texture at uv0 x COLOR_0) at hit points: the
        reflectance the bake gave its patches."""
        rho = self._material_rgb(tri, u, v, "base_color", "base_color_texture")
        if self.scene.colors is not None:
            rho *= _at_hits(self.scene.colors[:, :3], self.scene.indices, tri, u, v)
        return rho

    def emission(self, tri: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(N, 3) emitted radiance at hit points."""
        return self._material_rgb(tri, u, v, "emissive", "emissive_texture")

    def excident(self, tri: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(N, 3) radiance leaving diffuse surfaces at hit points: B = rho I + E."""
        return self.reflectance(tri, u, v) * self.incident(tri, u, v) + self.emission(tri, u, v)

    def _material_rgb(self, tri, u, v, factor: str, texture: str) -> np.ndarray:
        from .shading.textures import sample_bilinear

        s = self.scene
        out = np.zeros((len(tri), 3), np.float32)
        material = s.material_ids[tri]
        uv0 = None
        for m_id in np.unique(material):
            rows = material == m_id
            m = s.materials[m_id]
            out[rows] = np.asarray(getattr(m, factor), np.float32)[:3]
            image = getattr(m, texture)
            if image is not None:
                if uv0 is None:
                    uv0 = _at_hits(s.uv0, s.indices, tri, u, v)
                out[rows] *= sample_bilinear(image, uv0[rows])[:, :3]
        return out


def _at_hits(attribute: np.ndarray, indices: np.ndarray, tri, u, v) -> np.ndarray:
    """(N, C) per-vertex attribute (V, C) interpolated at hits (triangle, barycentrics u, v)."""
    return interpolate(attribute, indices[tri], np.stack([1 - u - v, u, v], axis=1))


def is_bake_dir(path: str | Path) -> bool:
    """A complete bake: scene.glb and lightmap.exr, and bake.json, which is written last."""
    from .scene import is_builtin

    p = Path(path)
    return not is_builtin(path) and p.is_dir() and all((p / name).exists() for name in ("scene.glb", "lightmap.exr", "bake.json"))


def check_lightmap(lightmap: np.ndarray, path: Path) -> np.ndarray:
    """`lightmap` (H, W, 3) of a bake, or PatchlightError naming `path` and the texels that
    are not finite (a damaged or hand-edited file). Small negative values, which
    interpolation and denoising leave, are kept."""
    bad = ~np.isfinite(lightmap).all(axis=2)
    if bad.any():
        row, column = np.argwhere(bad)[0]
        raise PatchlightError(f"{path}: {int(bad.sum())} texels are not finite (the first at row {row}, "
                              f"column {column}: {lightmap[row, column].tolist()})")
    return lightmap


def load_solved(spec: str | Path, settings: BakeSettings | None = None, sky=None, quiet: bool = True) -> SolvedScene:
    """A bake directory as written by `patchlight bake`, or a scene (file or built-in name)
    baked now with `settings`. sky, when given, replaces the scene's."""
    from .imaging.io import read_exr
    from .outputs import read_consistently
    from .scene import is_builtin, load_scene

    def read_bake():
        scene = load_scene(Path(spec) / "scene.glb")
        if sky is not None:
            scene.sky = sky
        lightmap = check_lightmap(read_exr(Path(spec) / "lightmap.exr"), Path(spec) / "lightmap.exr")
        if scene.uv1 is None:
            raise PatchlightError(f"{spec}/scene.glb: no TEXCOORD_1 lightmap UVs")
        return SolvedScene(scene, lightmap, str(spec))

    if is_bake_dir(spec):
        return read_consistently(spec, read_bake)  # never one bake's scene.glb with another's lightmap
    if not is_builtin(spec) and Path(spec).is_dir():
        raise PatchlightError(f"{spec}: not a complete bake (needs scene.glb, lightmap.exr and bake.json)")
    from .bake import bake

    scene = load_scene(spec)
    if sky is not None:
        scene.sky = sky
    result = bake(scene, settings or BakeSettings(), quiet=quiet)
    return SolvedScene(result.scene, result.lightmap, str(spec))

