"""The scene as the viewer page reads it: a JSON manifest and one binary of arrays.

Both come from the same Target and ShadingSettings the CPU renderer uses, so the page draws
exactly the arrays (normals, tangents, UVs, linear float textures, lightmap, environment
cube) that the reference shades. Arrays are little-endian float32 (indices uint32), each at a
4-byte-aligned offset into data.bin; the manifest names them:

    arrays:    {name: {offset (bytes), shape, dtype}}
    groups:    [{start, count, material}]  index ranges of data.bin's "indices", by material
    materials: [{name, base_color, emissive, shininess, reflectivity, double_sided,
                 color_map, emissive_map, normal_map}]   (map values: array names or null)
    lights, settings, camera, bounds, lightmap, pictures, max_lights,
    env (the environment cube), env_note (why env is a black stand-in, or null),
    sky (the cube drawn behind the scene: "env" when the environment is the sky, its own
                cube when the environment was rendered from a point, null without a sky),
    ground_map (the hemisphere-radiosity model's uniforms: patchlight.ground.viewer),
    volume (the ambient-cube model's light volume: patchlight.volumes.viewer),
    directional ({mode, maps}: the lightmap-directional model's maps, or null)
"""
from __future__ import annotations


import numpy as np

from ..ground.viewer import radiosity_bundle
from ..imaging.io import json_text
from ..render.camera import Camera
from ..render.target import Target
from ..shading.lights import MAX_LIGHTS
from ..shading.models import ShadingSettings
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
        self.parts.append(raw)
        self.offset += len(raw)
        return name

    def add_texture(self, name: str, image: np.ndarray | None) -> str | None:
        """(H, W, C) float image as (H, W, 4) RGBA float32 (alpha 1 where C < 4)."""
        if image is None:
            return None
        h, w = image.shape[:2]
        rgba = np.ones((h, w, 4), np.float32)
        rgba[..., :image.shape[2]] = image[..., :4]
        return self.add(name, rgba)


def scene_bundle(target: Target, settings: ShadingSettings, camera: Camera, env: np.ndarray,
                 exposure: float, sky: np.ndarray | None = None, env_note: str | None = None) -> tuple[dict, bytes]:
    """(manifest, data) for the page: see the module docstring. env: the environment cube
    (6, S, S, 4); sky: the cube of the sky drawn behind the scene (`env` itself when the
    environment is the sky), or None for no sky; env_note: why env is a stand-in, or None."""
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
        "env": pack.add("env", env),
        "env_note": env_note,
        "sky": None if sky is None else "env" if sky is env else pack.add("sky", sky),
        "pictures": target.bake_pictures(),
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


def manifest_bytes(manifest: dict) -> bytes:
    """The manifest as compact JSON; NumPy arrays become lists and NumPy scalars numbers."""
    return json_text(manifest, "viewer manifest", indent=None).encode()
