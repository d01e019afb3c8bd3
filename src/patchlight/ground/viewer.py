"""The ground map in the web viewer: the hemisphere-radiosity model's uniforms and textures
for the page's bundle, and a ground map directory opened with `patchlight view`.

The page draws the level with any model and, when a baked ground map came with it, cars
driving a loop lit by hemisphere-radiosity (static/groundmap.js). For live switching the
bundle carries the map in all three encodings, each as its PNG texels and as its
block-compressed (BC1/BC3) texels decoded, re-encoded here from the same bake and settings.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..shading.hemisphere_radiosity import ENCODINGS, OFFSET_MODES, GroundMapInputs
from .files import decode_dds_bytes, encode_dds, is_groundmap_dir, read_manifest, to_bytes

FOG_START, FOG_END = 0.6, 1.6  # the demo's fog, in units of the map's width


@dataclass
class ViewerGroundMap(GroundMapInputs):
    """GroundMapInputs plus what only the viewer needs: variants {"<encoding>-<png|dds>":
    (map uint8 (H, W, 4), shadow uint8 (H, W, 4) or None, map_scale, sky_scale (3,))}, and
    path (K, 3) the closed loop the cars drive, metres."""

    variants: dict = field(default_factory=dict)
    path: np.ndarray | None = None


def radiosity_bundle(pack, settings) -> dict:
    """Pack the model's textures into the bundle (`pack`: viewer.bundle's packer) and return
    its manifest entry: uniform values, texture names, and for a baked map the variants and path."""
    m = settings.radiosity_inputs()
    entry = {"map": pack.add_texture("radiosity_map", m.texture),
             "shadow_map": pack.add_texture("radiosity_shadow_map", m.shadow),
             "U": _floats(m.U), "V": _floats(m.V), "encoding": ENCODINGS.index(m.encoding),
             "encodings": list(ENCODINGS), "offset_modes": list(OFFSET_MODES),
             "offset_mode": OFFSET_MODES.index(m.offset_mode), "offset": float(m.offset), "side": _floats(m.side),
             "sky_scale": _floats(m.sky_scale), "neutral": m.neutral, "fog_color": _floats(m.fog_color),
             "fog_range": _floats(m.fog_range), "baked": settings.ground_map is not None, "variants": {}, "path": None}
    if isinstance(m, ViewerGroundMap):
        for name, (texels, shadow, scale, sky_scale) in m.variants.items():
            entry["variants"][name] = {"map": pack.add(f"ground_{name}", texels, np.uint8),
                                       "shadow_map": None if shadow is None else pack.add(f"shadow_{name}", shadow, np.uint8),
                                       "neutral": 0.5 * scale, "sky_scale": _floats(sky_scale)}
        entry["path"] = None if m.path is None else np.asarray(m.path, np.float64).tolist()
    return entry


def _floats(v) -> list[float]:
    return [float(x) for x in np.asarray(v).reshape(-1)]


def open_ground_map_dir(directory) -> tuple[str, ViewerGroundMap]:
    """(the bake directory to show, the ground map with its variants and the cars' path) for
    a ground map directory; the map is re-made from the bake with the manifest's settings."""
    from ..solved import load_solved
    from .groundmap import GroundMapSettings, make_groundmap
    from .mapping import GroundArea

    manifest = read_manifest(directory)
    bake = (Path(directory) / (manifest.get("bake") or ".")).resolve()
    solved = load_solved(bake)
    settings = GroundMapSettings(size=int(manifest["size"]), area=GroundArea(*manifest["area"]),
                                 max_height=float(manifest["max_height"]), noise=float(manifest["noise"]),
                                 shadows=manifest["encoding"], seed=int(manifest["seed"]),
                                 offset=float(manifest["offset"]))
    ground_map = make_groundmap(solved, settings)
    variants = {}
    for encoding in ENCODINGS:
        encoded = ground_map.encode(encoding)
        for source in ("png", "dds"):
            texels = stored_texels(encoded.color, source)
            shadow = None if encoded.shadow is None else stored_texels(np.repeat(encoded.shadow[..., None], 3, -1), source)
            variants[f"{encoding}-{source}"] = (texels, shadow, encoded.map_scale, encoded.sky_scale)
    texels, shadow, scale, sky_scale = variants[f"{manifest['encoding']}-png"]
    area = settings.area
    width = max(area.x1 - area.x0, area.z1 - area.z0)
    fog_color = solved.scene.sky.radiance(np.array([[1.0, 0.0, 0.0]], np.float32))[0] if solved.scene.sky else np.zeros(3)
    inputs = ViewerGroundMap(texture=texels / np.float32(255), U=area.U.astype(np.float32), V=area.V.astype(np.float32),
                             encoding=manifest["encoding"], map_scale=scale, sky_scale=sky_scale,
                             offset=settings.offset, fog_color=np.asarray(fog_color, np.float32),
                             fog_range=(FOG_START * width, FOG_END * width), variants=variants,
                             path=_path(manifest, solved.scene, area))
    if shadow is not None:
        inputs.shadow = shadow / np.float32(255)
    inputs.validate()
    return str(bake), inputs


def stored_texels(color: np.ndarray, source: str) -> np.ndarray:
    """(H, W, 4) uint8 texels as the PNG stores them, or as the DDS's blocks decode."""
    pixels = to_bytes(color)
    if source == "dds":
        pixels = decode_dds_bytes(encode_dds(pixels)[0])
    if pixels.shape[-1] == 3:
        pixels = np.concatenate([pixels, np.full(pixels.shape[:2] + (1,), 255, np.uint8)], axis=-1)
    return np.ascontiguousarray(pixels)


def _path(manifest: dict, scene, area) -> np.ndarray:
    """The cars' loop: the manifest's path (the scene's extras["path"] when it was made), else
    an ellipse over the middle of the map at the height of the ground beneath."""
    from ..scene.model import face_normals
    from .prepare import VERTICAL_NY, MapGeometry, ground_below

    if manifest.get("path"):
        return np.asarray(manifest["path"], np.float64)
    t = np.linspace(0, 2 * np.pi, 96, endpoint=False)
    cx, cz = (area.x0 + area.x1) / 2, (area.z0 + area.z1) / 2
    rx, rz = 0.3 * (area.x1 - area.x0), 0.3 * (area.z1 - area.z0)
    points = np.stack([cx + rx * np.cos(t), np.zeros_like(t), cz + rz * np.sin(t)], axis=1)
    normal, _ = face_normals(scene.positions, scene.indices)
    up = scene.triangle_vertices()[normal[:, 1] >= VERTICAL_NY].reshape(-1, 3)
    heights = ground_below(MapGeometry.tracer(up), points, float(scene.bounds()[0][1]) - 1.0)
    points[:, 1] = np.nan_to_num(heights, nan=0.0)
    return points


def view_target(spec: str) -> tuple[str, ViewerGroundMap | None]:
    """For `patchlight view`: a ground map directory becomes its bake plus the map; anything
    else passes through unchanged."""
    if Path(spec).is_dir() and is_groundmap_dir(spec):
        return open_ground_map_dir(spec)
    return spec, None

