"""Ground map files: 8-bit PNG, block-compressed DDS, and groundmap.json.

Texels are stored linear (no sRGB curve), row 0 the map's top row (v = 0, z = z0).
Block compression goes through Pillow's DDS encoder (the maintained one the project
already depends on): BC1 (DXT1, 4 bits per texel) for RGB maps, BC3 (DXT5, 8 bits) for
the alpha encoding; the separate encoding's shadow map is a grey BC1 image. Sizes that are
not a multiple of 4 are padded by the encoder's edge blocks. Pillow's header gets the top
level's linear size afterwards (`fix_dds_header`), as strict loaders expect.

| file                 | what                                                              |
|----------------------|-------------------------------------------------------------------|
| groundmap.png        | the map: RGB (separate: the colour map; hsv) or RGBA (alpha)      |
| groundmap.dds        | the same, BC1 or BC3                                              |
| shadow.png/dds       | separate only: the shadow amount, grey                            |
| variant_<enc>.png    | the same map in the two other encodings (variant_separate_shadow  |
|                      | .png the separate one's shadow), for the viewer's live switch     |
| groundmap.json       | mapping (U, V rows), area, encoding, map_scale, sky_scale, offset |
|                      | distance and mode, the variants' files and constants, the cars'   |
|                      | path, the bake it lies over; written last                         |

The variants are stored as PNG only: their block-compressed texels are the (deterministic)
encoder's output for those PNG texels, so a reader makes them exactly as groundmap.dds was made.
"""
from __future__ import annotations

import io
import struct
from pathlib import Path

import numpy as np
from PIL import Image

from ..errors import PatchlightError
from ..imaging.io import decode_image, read_bytes, write_bytes, write_json, write_png
from ..limits import check_image_size, load_json
from ..shading.hemisphere_radiosity import ENCODINGS, OFFSET_MODES, GroundMapInputs

MANIFEST = "groundmap.json"
FORMAT = "patchlight-groundmap"
VERSION = 2


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
    block = {"DXT1": "BC1", "DXT5": "BC3"}[fourcc]
    return fix_dds_header(buffer.getvalue(), block), block


# DDS_HEADER (after the 4-byte magic "DDS "): dwSize, dwFlags, dwHeight, dwWidth, dwPitchOrLinearSize
# at byte offsets 4, 8, 12, 16, 20 (Microsoft's "DDS_HEADER structure").
DDSD_PITCH = 0x8
DDSD_LINEARSIZE = 0x80000
BLOCK_BYTES = {"BC1": 8, "BC3": 16}  # bytes per 4 x 4 block


def dds_linear_size(width: int, height: int, block: str) -> int:
    """Bytes of the top level of a block-compressed image: max(1, ceil(w / 4)) x max(1, ceil(h / 4))
    blocks (the DDS header's dwPitchOrLinearSize for compressed formats)."""
    return max(1, (width + 3) // 4) * max(1, (height + 3) // 4) * BLOCK_BYTES[block]


def fix_dds_header(data: bytes, block: str) -> bytes:
    """`data` with DDSD_LINEARSIZE set, DDSD_PITCH cleared and dwPitchOrLinearSize the top
    level's size. Pillow (13.0 at least) writes (width + 3) x 4 there, a row pitch of 8-bit RGBA,
    which strict loaders reject for a compressed image."""
    header = bytearray(data[:128])
    flags, height, width = struct.unpack_from("<3I", header, 8)
    flags = (flags | DDSD_LINEARSIZE) & ~DDSD_PITCH
    struct.pack_into("<I", header, 8, flags)
    struct.pack_into("<I", header, 20, dds_linear_size(width, height, block))
    return bytes(header) + data[128:]


def decode_dds(path) -> np.ndarray:
    """(H, W, 4) uint8 texels of a BC1/BC3 DDS file (for checks and the CPU reference)."""
    return decode_dds_bytes(read_bytes(path), str(path))


def decode_dds_bytes(data: bytes, where: str = "DDS data") -> np.ndarray:
    """(H, W, 4) uint8 texels of BC1/BC3 DDS bytes, decoded by Pillow."""
    try:
        with Image.open(io.BytesIO(data)) as img:
            check_image_size(*img.size, 4, where)
            return np.asarray(img.convert("RGBA"))
    except (OSError, SyntaxError, ValueError, NotImplementedError, Image.DecompressionBombError) as exc:
        raise PatchlightError(f"{where}: not a readable DDS file ({exc})") from exc


def block_compressed(pixels: np.ndarray) -> np.ndarray:
    """(H, W, 4) uint8: uint8 (H, W, 3|4) pixels through the DDS encoder and back, the texels
    a GPU samples from the DDS file written of them."""
    return decode_dds_bytes(encode_dds(pixels)[0])


def write_map_files(out_dir: Path, stem: str, pixels: np.ndarray) -> dict:
    """Write stem.png and stem.dds from uint8 (H, W, 3|4); {png, dds, dds_format} names."""
    data, block = encode_dds(pixels)
    write_png(out_dir / f"{stem}.png", pixels)
    write_bytes(out_dir / f"{stem}.dds", data)
    return {"png": f"{stem}.png", "dds": f"{stem}.dds", "dds_format": block}


def write_manifest(out_dir: Path, manifest: dict) -> Path:
    path = out_dir / MANIFEST
    write_json(path, manifest)
    return path


def is_groundmap_dir(path) -> bool:
    return (Path(path) / MANIFEST).is_file()


def read_manifest(path) -> dict:
    """groundmap.json of a directory (or the file itself), checked for format, version and
    every field a reader uses (check_manifest)."""
    path = Path(path)
    file = path / MANIFEST if path.is_dir() else path
    manifest = load_json(read_bytes(file), str(file))
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise PatchlightError(f"{file}: not a patchlight ground map manifest")
    if manifest.get("version") != VERSION:
        raise PatchlightError(f"{file}: ground map version {manifest.get('version')} (this patchlight reads {VERSION}; "
                              f"write it again with `patchlight groundmap`)")
    check_manifest(manifest, file)
    return manifest


def _numbers(value, count: int | None = None) -> bool:
    """value is a list of finite numbers (of `count` of them when given)."""
    return (isinstance(value, list) and (count is None or len(value) == count)
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in value))


def _positive(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value) and value > 0


def check_manifest(manifest: dict, where) -> None:
    """PatchlightError naming the first missing or malformed field a reader of `manifest` uses."""
    def bad(field: str, what: str):
        raise PatchlightError(f"{where}: {field} {what}")

    mapping = manifest.get("mapping")
    if not isinstance(mapping, dict) or not (_numbers(mapping.get("U"), 4) and _numbers(mapping.get("V"), 4)):
        bad("mapping", "needs U and V, four numbers each")
    area = manifest.get("area")
    if not _numbers(area, 4) or not (area[2] > area[0] and area[3] > area[1]):
        bad("area", "needs four numbers x0, z0, x1, z1 with x1 > x0 and z1 > z0")
    if manifest.get("encoding") not in ENCODINGS:
        bad("encoding", f"must be one of {', '.join(ENCODINGS)}")
    variants = manifest.get("variants") or {}
    if not isinstance(variants, dict):
        bad("variants", "must be an object of the two encodings other than the map's own")
    encodings = [(manifest["encoding"], manifest)] + sorted(variants.items())
    if set(name for name, _ in encodings) != set(ENCODINGS):
        bad("variants", "must hold the two encodings other than the map's own")
    for name, entry in encodings:
        field = "" if entry is manifest else f"variants.{name}."
        if not isinstance(entry, dict):
            bad(field.rstrip("."), "must be an object")
        if not _positive(entry.get("map_scale")):
            bad(f"{field}map_scale", "must be a positive number")
        if not _numbers(entry.get("sky_scale"), 3):
            bad(f"{field}sky_scale", "needs three numbers")
        files = entry.get("files")
        kinds = ("png", "dds") if entry is manifest else ("png",)
        needed = ("color", "shadow") if name == "separate" else ("color",)
        if not isinstance(files, dict) or not all(
                isinstance(files.get(f), dict) and all(_file_name(files[f].get(k)) for k in kinds) for f in needed):
            bad(f"{field}files", f"must name the {' and '.join(needed)} map's {' and '.join(kinds)} "
                                 f"files in the directory")
    if not _numbers(manifest.get("sky_light"), 3):
        bad("sky_light", "needs three numbers")
    offset = manifest.get("offset", 1.0)
    if not (_numbers([offset]) and offset >= 0):
        bad("offset", "must be a non-negative number of metres")
    if manifest.get("offset_mode", "normal") not in OFFSET_MODES:
        bad("offset_mode", f"must be one of {', '.join(OFFSET_MODES)}")
    if not isinstance(manifest.get("size"), int) or not manifest["size"] > 0:
        bad("size", "must be a positive whole number")
    path = manifest.get("path")
    if path is not None and not (isinstance(path, list) and len(path) >= 2 and all(_numbers(p, 3) for p in path)):
        bad("path", "must be null or a list of at least two [x, y, z] points")
    if not (manifest.get("bake") is None or isinstance(manifest["bake"], str)):
        bad("bake", "must be null or a directory name")


def _file_name(name) -> bool:
    """A plain file name (no directory part), as groundmap writes them."""
    return isinstance(name, str) and name not in ("", ".", "..") and "/" not in name and "\\" not in name


def read_texels(directory, name: str) -> np.ndarray:
    """(H, W, 4) uint8 texels of a map file in `directory`: a PNG as stored (alpha 255 when it
    has none), a DDS as its blocks decode."""
    path = Path(directory) / name
    if path.suffix.lower() == ".dds":
        return decode_dds(path)
    return np.ascontiguousarray(_rgba(np.round(read_map_pixels(directory, name) * 255.0).astype(np.uint8)))


def read_map_pixels(directory, name: str) -> np.ndarray:
    """float32 (H, W, C) texels in [0, 1] of a map PNG in `directory`."""
    path = Path(directory) / name
    return decode_image(read_bytes(path), str(path))


def load_ground_map(directory, block_compressed: bool = False, manifest: dict | None = None):
    """The hemisphere-radiosity model's inputs (shading.hemisphere_radiosity.GroundMapInputs)
    from a ground map directory: its PNG texels, or with block_compressed its DDS texels as
    a GPU decodes them. The offset distance and mode are the manifest's (mode "normal" when it
    names none). manifest: the directory's, when already read (the caller then reads the set
    consistently); else manifest and maps are read again if the folder is swapped meanwhile."""
    if manifest is None:
        from ..outputs import read_consistently
        return read_consistently(directory, lambda: _load_ground_map(directory, block_compressed,
                                                                      read_manifest(directory)))
    return _load_ground_map(directory, block_compressed, manifest)


def _load_ground_map(directory, block_compressed: bool, manifest: dict):
    kind = "dds" if block_compressed else "png"
    files = manifest["files"]

    def texels(name: str) -> np.ndarray:
        """A map's texels in [0, 1], checked to be the manifest's size."""
        values = read_texels(directory, name)
        if values.shape[:2] != (manifest["size"],) * 2:
            raise PatchlightError(f"{Path(directory) / name}: {values.shape[1]} x {values.shape[0]} texels, but "
                                  f"{MANIFEST} says {manifest['size']} x {manifest['size']}")
        return values / np.float32(255.0)

    inputs = GroundMapInputs(texture=texels(files["color"][kind]),
                             U=np.asarray(manifest["mapping"]["U"], np.float32),
                             V=np.asarray(manifest["mapping"]["V"], np.float32), encoding=manifest["encoding"],
                             map_scale=float(manifest["map_scale"]),
                             sky_scale=np.asarray(manifest["sky_scale"], np.float32),
                             offset=float(manifest.get("offset", 1.0)),
                             offset_mode=manifest.get("offset_mode", "normal"))
    if "shadow" in files:
        inputs.shadow = texels(files["shadow"][kind])
    inputs.validate()
    return inputs


def _rgba(pixels: np.ndarray) -> np.ndarray:
    """(H, W, C) pixels as (H, W, 4), alpha at full scale (1.0, or 255 for uint8) where the image has none."""
    if pixels.shape[-1] == 4:
        return pixels
    full = 255 if pixels.dtype == np.uint8 else 1.0
    rgba = np.full(pixels.shape[:2] + (4,), full, pixels.dtype)
    rgba[..., :3] = pixels[..., :3] if pixels.shape[-1] >= 3 else pixels[..., :1]
    return rgba
