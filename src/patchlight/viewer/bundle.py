"""The scene as the viewer page reads it: a JSON manifest and one binary of arrays.

Both come from the same Target and ShadingSettings the CPU renderer uses, so the page draws
exactly the arrays (normals, tangents, UVs, linear float textures, lightmap, environment
cube) that the reference shades. Arrays are little-endian float32 (indices uint32), each at a
4-byte-aligned offset into data.bin (the passes float16, the texel status uint8, charts
int32); the manifest names them:

    arrays:    {name: {offset (bytes), shape, dtype}}
    groups:    [{start, count, material}]  index ranges of data.bin's "indices", by material
    materials: [{name, base_color, emissive, shininess, reflectivity, double_sided,
                 color_map, emissive_map, normal_map}]   (map values: array names or null)
    lights, settings, camera, bounds, lightmap, max_lights,
    atlases (how many lightmap atlases the lightmap and texel arrays hold, stacked along v as
                the scene's uv1 addresses them: scene.model.stacked_uv1),
    exposure_rule (the automatic exposure's percentile, target and luminance weights:
                patchlight.imaging.exposure),
    texels (a bake's texels.npz: passes, status, chart, rho, emission, excident, the status
                names and colours; null without one), patch (the texel to view from first, or null),
    compare (a second bake's name and lightmap, for the A/B split, or null),
    scene_glb (whether the server has the bake's scene.glb for the page's three.js view: set
                by viewer.app),
    env (the environment cube), env_note (why env is a black stand-in, or null),
    sky (the cube drawn behind the scene: "env" when the environment is the sky, its own
                cube when the environment was rendered from a point, null without a sky),
    ground_map (the hemisphere-radiosity model's uniforms: patchlight.ground.viewer),
    volume (the ambient-cube model's light volume: patchlight.volumes.viewer),
    directional ({mode, maps}: the lightmap-directional model's maps, or null)
"""
from __future__ import annotations


from pathlib import Path

import numpy as np

from ..ground.viewer import radiosity_bundle
from ..imaging.color import LUMINANCE
from ..imaging.exposure import AUTO_PERCENTILE, AUTO_TARGET
from ..imaging.io import json_text
from ..radiosity.adaptive import STATUS_COLOURS
from ..render.camera import Camera
from ..render.target import Target
from ..shading.lights import MAX_LIGHTS
from ..shading.models import ShadingSettings
from ..bakedir import MARKER, STATUS_NAMES, Texels, read_summary
from ..volumes.viewer import volume_bundle


class _Packer:
    def __init__(self):
        self.parts: list[bytes] = []
        self.offset = 0
        self.arrays: dict[str, dict] = {}

    def add(self, name: str, array: np.ndarray, dtype=np.float32) -> str:
        data = np.ascontiguousarray(array, dtype)
        self.arrays[name] = {"offset": self.offset, "shape": list(data.shape), "dtype": np.dtype(dtype).name}
        raw = data.astype(data.dtype.newbyteorder("<"), copy=False).tobytes()
        self.parts.append(raw + bytes(-len(raw) % 4))
        self.offset += len(self.parts[-1])
        return name

    def add_texture(self, name: str, image: np.ndarray | None, dtype=np.float32) -> str | None:
        """(H, W, C) float image as (H, W, 4) RGBA of dtype (alpha 1 where C < 4)."""
        if image is None:
            return None
        h, w = image.shape[:2]
        rgba = np.ones((h, w, 4), dtype)
        rgba[..., :image.shape[2]] = image[..., :4]
        return self.add(name, rgba, dtype)


def scene_bundle(target: Target, settings: ShadingSettings, camera: Camera, env: np.ndarray,
                 exposure: float, sky: np.ndarray | None = None, env_note: str | None = None,
                 patch: tuple[int, int] | None = None, compare: Target | None = None) -> tuple[dict, bytes]:
    """(manifest, data) for the page: see the module docstring. env: the environment cube
    (6, S, S, 4); sky: the cube of the sky drawn behind the scene (`env` itself when the
    environment is the sky), or None for no sky; env_note: why env is a stand-in, or None;
    patch: the texel (x, y) whose view the page shows first, or None; compare: a second bake
    of the same lightmap UVs, whose lightmap the page can show beside this one's."""
    s = target.surface
    pack = _Packer()
    for name in ("positions", "normals", "tangents", "uv0", "uv1", "colors"):
        pack.add(name, getattr(s, name))
    order = np.argsort(s.material_ids, kind="stable")
    pack.add("indices", s.indices[order], np.uint32)
    sorted_ids = s.material_ids[order]
    groups = []
    for m in np.unique(sorted_ids):
        rows = np.flatnonzero(sorted_ids == m)
        groups.append({"start": int(rows[0]) * 3, "count": len(rows) * 3, "material": int(m)})
    materials = []
    for i, m in enumerate(target.scene.materials):
        materials.append({
            "name": m.name, "base_color": m.base_color, "emissive": m.emissive,
            "shininess": float(m.shininess), "reflectivity": float(m.reflectivity),
            "double_sided": bool(m.double_sided),
            "color_map": pack.add_texture(f"color_map_{i}", m.base_color_texture),
            "emissive_map": pack.add_texture(f"emissive_map_{i}", m.emissive_texture),
            "normal_map": pack.add_texture(f"normal_map_{i}", m.normal_texture),
        })
    lo, hi = target.scene.bounds()
    manifest = {
        "name": target.name,
        "arrays": pack.arrays,
        "groups": groups,
        "materials": materials,
        "lights": [light.to_json() for light in settings.lights[:MAX_LIGHTS]],
        "lights_dropped": max(0, len(settings.lights) - MAX_LIGHTS),
        "settings": {"model": settings.model, "ambient": settings.ambient, "sky": settings.sky,
                     "ground": settings.ground, "per_vertex": settings.per_vertex,
                     "normal_map": settings.normal_map, "lightmap_specular": settings.lightmap_specular,
                     "reflectivity": settings.reflectivity, "exposure": float(exposure),
                     "ambient_cube_naive": settings.ambient_cube_naive},
        "camera": camera.to_json(),
        "bounds": [lo, hi],
        "lightmap": pack.add_texture("lightmap", target.lightmap),
        "atlases": target.scene.atlases,
        "env": pack.add("env", env),
        "env_note": env_note,
        "sky": None if sky is None else "env" if sky is env else pack.add("sky", sky),
        "exposure_rule": {"percentile": AUTO_PERCENTILE, "target": AUTO_TARGET, "luminance": LUMINANCE},
        "texels": texels_bundle(pack, target.texels, target.bake_dir),
        "patch": None if patch is None else list(patch),
        "compare": None if compare is None else {"name": compare.name,
                                                 "lightmap": pack.add_texture("compare_lightmap", compare.lightmap)},
        "max_lights": MAX_LIGHTS,
        "ground_map": radiosity_bundle(pack, settings),
        "volume": volume_bundle(pack, settings),
        "directional": _directional_bundle(pack, settings.directional),
    }
    return manifest, b"".join(pack.parts)


def _directional_bundle(pack: _Packer, directional) -> dict | None:
    if directional is None:
        return None
    return {"mode": directional.mode,
            "maps": [pack.add_texture(f"directional_map{k}", m) for k, m in enumerate(directional.maps)]}


def texels_bundle(pack: _Packer, texels: Texels | None, bake_dir: Path | None = None) -> dict | None:
    """The manifest's `texels`: array names of a bake's texels.npz (passes as float16 RGBA
    textures; the atlases stacked), with the names and debug colours of the texel status, and
    from bake.json each object's texels per metre."""
    if texels is None:
        return None
    height, width = texels.status.shape
    known = bake_dir is not None and (Path(bake_dir) / MARKER).is_file()
    objects = ((read_summary(bake_dir).get("uv") or {}).get("objects") or []) if known else []
    return {
        "width": width, "height": height,
        "objects": [{"name": str(o.get("name")), "texels_per_unit": float(o.get("texels_per_unit"))}
                    for o in objects if isinstance(o, dict) and isinstance(o.get("texels_per_unit"), (int, float))],
        "passes": [pack.add_texture(f"pass_{k}", image, np.float16) for k, image in enumerate(texels.passes, start=1)],
        "status": pack.add("status", texels.status, np.uint8),
        "chart": pack.add("chart", texels.chart, np.int32),
        **{name: pack.add(name, getattr(texels, name)) for name in ("rho", "emission", "excident")},
        "status_names": list(STATUS_NAMES), "status_colours": STATUS_COLOURS.tolist(),
    }


def manifest_bytes(manifest: dict) -> bytes:
    """The manifest as compact JSON; NumPy arrays become lists and NumPy scalars numbers."""
    return json_text(manifest, "viewer manifest", indent=None).encode()
