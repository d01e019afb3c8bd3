"""The ground map in the web viewer: the hemisphere-radiosity model's uniforms and textures
for the page's bundle, and a ground map directory opened with `patchlight view`.

The page draws the level with any model and, when a baked ground map came with it, cars
driving a loop lit by hemisphere-radiosity (static/groundmap.js). For live switching the
bundle carries the map in all three encodings, each as its PNG texels and its
block-compressed texels: all read from the directory that `patchlight groundmap` wrote (the
map's own PNG and DDS; the other encodings' PNGs, whose DDS texels the same deterministic
encoder makes), never baked again, so the viewer shows exactly what was written.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from ..errors import PatchlightError
from ..shading.hemisphere_radiosity import ENCODINGS, OFFSET_MODES, GroundMapInputs
from ..bakedir import is_bake_dir
from .files import MANIFEST, block_compressed, load_ground_map, read_manifest, read_texels

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
    its manifest entry (NumPy values as they are: viewer.bundle.manifest_bytes writes them):
    uniform values, texture names, and for a baked map the variants and path."""
    m = settings.radiosity_inputs()
    entry = {"map": pack.add_texture("radiosity_map", m.texture),
             "shadow_map": pack.add_texture("radiosity_shadow_map", m.shadow),
             "U": m.U, "V": m.V, "encoding": ENCODINGS.index(m.encoding),
             "encodings": list(ENCODINGS), "offset_modes": list(OFFSET_MODES),
             "offset_mode": OFFSET_MODES.index(m.offset_mode), "offset": float(m.offset), "side": m.side,
             "sky_scale": m.sky_scale, "neutral": m.neutral, "fog_color": m.fog_color,
             "fog_range": m.fog_range, "baked": settings.ground_map is not None, "variants": {}, "path": None}
    if isinstance(m, ViewerGroundMap):
        for name, (texels, shadow, scale, sky_scale) in m.variants.items():
            entry["variants"][name] = {"map": pack.add(f"ground_{name}", texels, np.uint8),
                                       "shadow_map": None if shadow is None else pack.add(f"shadow_{name}", shadow, np.uint8),
                                       "neutral": 0.5 * scale, "sky_scale": sky_scale}
        entry["path"] = m.path
    return entry


def stored_variants(directory, manifest: dict) -> dict:
    """{"<encoding>-<png|dds>": (map, shadow or None, map_scale, sky_scale)} of a ground map
    directory (ViewerGroundMap.variants): every texel read from its files."""
    variants = {}
    for encoding in ENCODINGS:
        entry = manifest if encoding == manifest["encoding"] else manifest["variants"][encoding]
        files = entry["files"]
        pictures = {"png": {name: read_texels(directory, f["png"]) for name, f in files.items()}}
        if entry is manifest:
            pictures["dds"] = {name: read_texels(directory, f["dds"]) for name, f in files.items()}
        else:
            pictures["dds"] = {name: block_compressed(_stored_channels(texels, name, encoding))
                               for name, texels in pictures["png"].items()}
        for source, texels in pictures.items():
            variants[f"{encoding}-{source}"] = (texels["color"], texels.get("shadow"), float(entry["map_scale"]),
                                                np.asarray(entry["sky_scale"], np.float32))
    return variants


def _stored_channels(texels: np.ndarray, name: str, encoding: str) -> np.ndarray:
    """The uint8 pixels as groundmap wrote them (RGBA for the alpha encoding's map, else RGB),
    from (H, W, 4) texels: the DDS encoder picks BC3 or BC1 by the channel count."""
    return texels if (name == "color" and encoding == "alpha") else np.ascontiguousarray(texels[..., :3])


def bake_of(directory, manifest: dict) -> str | None:
    """The absolute bake directory a ground map directory's manifest names (the directory
    itself when it names none but is a bake), or None."""
    named = manifest.get("bake")
    if named is None and is_bake_dir(directory):  # written into its bake's own directory
        named = "."
    return None if named is None else str((Path(directory) / named).resolve())


def open_ground_map_dir(directory, manifest: dict | None = None) -> tuple[str | None, ViewerGroundMap]:
    """(the bake directory to show (bake_of), the ground map with its variants and the cars'
    path) of a ground map directory, all read from its files (module docstring). Fog: the sky's
    light on the ground (the manifest's sky_light), from 0.6 to 1.6 map widths away. manifest:
    the directory's, when already read."""
    manifest = manifest or read_manifest(directory)
    bake = bake_of(directory, manifest)
    stored = load_ground_map(directory, manifest=manifest)
    x0, z0, x1, z1 = manifest["area"]
    width = max(x1 - x0, z1 - z0)
    inputs = ViewerGroundMap(**{f.name: getattr(stored, f.name) for f in fields(GroundMapInputs)},
                             variants=stored_variants(directory, manifest),
                             path=None if manifest.get("path") is None else np.asarray(manifest["path"], np.float64))
    inputs.fog_color = np.asarray(manifest.get("sky_light", np.zeros(3)), np.float32)
    inputs.fog_range = (FOG_START * width, FOG_END * width)
    inputs.validate()
    return bake, inputs


def ground_map_target(directory, offset_mode: str | None = None) -> tuple[str, ViewerGroundMap]:
    """For `patchlight render` and `view` (patchlight.inputs): a ground map directory's bake
    (absolute) and its map; offset_mode, when given, replaces the map's recorded one."""
    from ..outputs import read_consistently
    manifest, (_, ground_map) = read_consistently(directory, lambda: _manifest_and_map(directory))
    shown = bake_of(directory, manifest)
    where = Path(directory) / MANIFEST
    if shown is None:
        raise PatchlightError(f"{where}: names no bake to show the map over (written from Python without "
                              f"one); write it with write_groundmap(..., bake_dir=BAKE_DIR) or bake=(result, "
                              f"settings), or run `patchlight groundmap SCENE_OR_BAKE_DIR -o {directory}`")
    if not is_bake_dir(shown):
        raise PatchlightError(f"{where}: its bake {shown} is not a complete bake (moved or deleted?); "
                              f"make the map again with `patchlight groundmap`")
    if offset_mode is not None:
        ground_map.offset_mode = offset_mode
        ground_map.validate()
    return shown, ground_map


def _manifest_and_map(directory):
    """The manifest and the map it describes (open_ground_map_dir), read as one set."""
    manifest = read_manifest(directory)
    return manifest, open_ground_map_dir(directory, manifest)
