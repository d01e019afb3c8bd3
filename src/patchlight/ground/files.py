"""Ground map files: 8-bit PNG, block-compressed DDS, and groundmap.json.

Texels are stored linear (no sRGB curve), row 0 the map's top row (v = 0, z = z0).
Block compression goes through Pillow's DDS encoder (the maintained one the project
already depends on): BC1 (DXT1, 4 bits per texel) for RGB maps, BC3 (DXT5, 8 bits) for
the alpha encoding; the separate encoding's shadow map is a grey BC1 image. Sizes that are
not a multiple of 4 are padded by the encoder's edge blocks.

| file           | what                                                                |
|----------------|---------------------------------------------------------------------|
| groundmap.png  | the map: RGB (separate: the colour map; hsv) or RGBA (alpha)        |
| groundmap.dds  | the same, BC1 or BC3                                                |
| shadow.png/dds | separate only: the shadow amount, grey                              |
| groundmap.json | mapping (U, V rows), area, encoding, map_scale, sky_scale, offsets  |
"""
from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
from PIL import Image

from ..errors import PatchlightError
from ..imaging.io import decode_image, read_bytes, write_bytes, write_png

MANIFEST = "groundmap.json"
FORMAT = "patchlight-groundmap"
VERSION = 1


def to_bytes(values: np.ndarray) -> np.ndarray:
    """uint8 of values in [0, 1] (rounded)."""
    return np.round(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)


def encode_dds(pixels: np.ndarray) -> tuple[bytes, str]:
    """DDS bytes and block format ('BC1' or 'BC3') of uint8 (H, W, 3) or (H, W, 4) pixels."""
    fourcc = "DXT1" if pixels.shape[-1] == 3 else "DXT5"
    buffer = io.BytesIO()
    try:
        Image.fromarray(np.ascontiguousarray(pixels)).save(buffer, format="DDS", pixel_format=fourcc)
    except (ValueError, OSError) as exc:  # Pillow < 11.2 cannot write block-compressed DDS
        raise PatchlightError(f"cannot block-compress the ground map ({exc}); Pillow >= 11.2 is needed") from exc
    return buffer.getvalue(), {"DXT1": "BC1", "DXT5": "BC3"}[fourcc]


def decode_dds(path) -> np.ndarray:
    """(H, W, 4) uint8 texels of a BC1/BC3 DDS file (for checks and the CPU reference)."""
    return decode_dds_bytes(read_bytes(path), str(path))


def decode_dds_bytes(data: bytes, where: str = "DDS data") -> np.ndarray:
    """(H, W, 4) uint8 texels of BC1/BC3 DDS bytes, decoded by Pillow."""
    try:
        with Image.open(io.BytesIO(data)) as img:
            return np.asarray(img.convert("RGBA"))
    except (OSError, ValueError) as exc:
        raise PatchlightError(f"{where}: not a readable DDS file ({exc})") from exc


def write_map_files(out_dir: Path, stem: str, pixels: np.ndarray) -> dict:
    """Write stem.png and stem.dds from uint8 (H, W, 3|4); {png, dds, dds_format} names."""
    data, block = encode_dds(pixels)
    write_png(out_dir / f"{stem}.png", pixels)
    write_bytes(out_dir / f"{stem}.dds", data)
    return {"png": f"{stem}.png", "dds": f"{stem}.dds", "dds_format": block}


def write_manifest(out_dir: Path, manifest: dict) -> Path:
    path = out_dir / MANIFEST
    write_bytes(path, (json.dumps(manifest, indent=2, default=_plain) + "\n").encode())
    return path


def _plain(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"cannot store {type(value).__name__} in {MANIFEST}")


def is_groundmap_dir(path) -> bool:
    return (Path(path) / MANIFEST).is_file()


def read_manifest(path) -> dict:
    """groundmap.json of a directory (or the file itself), checked for format and version."""
    path = Path(path)
    file = path / MANIFEST if path.is_dir() else path
    try:
        manifest = json.loads(read_bytes(file))
    except json.JSONDecodeError as exc:
        raise PatchlightError(f"{file}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise PatchlightError(f"{file}: not a patchlight ground map manifest")
    if manifest.get("version") != VERSION:
        raise PatchlightError(f"{file}: ground map version {manifest.get('version')} (this patchlight reads {VERSION})")
    return manifest


def read_map_pixels(directory, name: str) -> np.ndarray:
    """float32 (H, W, C) texels in [0, 1] of a map PNG in `directory`."""
    path = Path(directory) / name
    return decode_image(read_bytes(path), str(path))


def load_ground_map(directory, block_compressed: bool = False):
    """The hemisphere-radiosity model's inputs (shading.hemisphere_radiosity.GroundMapInputs)
    from a ground map directory: its PNG texels, or with block_compressed its DDS texels as
    a GPU decodes them. The offset is the manifest's, in mode "normal"."""
    from ..shading.hemisphere_radiosity import GroundMapInputs

    manifest = read_manifest(directory)
    kind = "dds" if block_compressed else "png"

    def texels(entry: dict) -> np.ndarray:
        path = Path(directory) / entry[kind]
        pixels = decode_dds(path) if block_compressed else _rgba(read_map_pixels(directory, entry["png"]))
        return (pixels / np.float32(255.0)).astype(np.float32) if pixels.dtype == np.uint8 else pixels

    files = manifest["files"]
    inputs = GroundMapInputs(texture=texels(files["color"]), U=np.asarray(manifest["mapping"]["U"], np.float32),
                             V=np.asarray(manifest["mapping"]["V"], np.float32), encoding=manifest["encoding"],
                             map_scale=float(manifest["map_scale"]),
                             sky_scale=np.asarray(manifest["sky_scale"], np.float32),
                             offset=float(manifest.get("offset", 1.0)))
    if "shadow" in files:
        inputs.shadow = texels(files["shadow"])
    inputs.validate()
    return inputs


def _rgba(pixels: np.ndarray) -> np.ndarray:
    """(H, W, C) float32 in [0, 1] as (H, W, 4), alpha 1 where the image has none."""
    if pixels.shape[-1] == 4:
        return pixels
    rgba = np.ones(pixels.shape[:2] + (4,), np.float32)
    rgba[..., :3] = pixels[..., :3] if pixels.shape[-1] >= 3 else pixels[..., :1]
    return rgba
