"""Image files in and out: OpenEXR, PNG/JPEG (Pillow) and Radiance .hdr.

Conventions: arrays are (H, W, C) with row 0 the top row of the picture, which is v = 0 in
glTF's UV convention.  Float images are linear float32; 8-bit images are uint8.
Every writer is atomic (a temporary file in the target directory, then `os.replace`), and
every reader turns a missing, unreadable or corrupt file into `PatchlightError("<path>: <what>")`.

| function            | reads / writes                         | array                          |
|---------------------|----------------------------------------|--------------------------------|
| write_exr, read_exr | OpenEXR, float32 R, G, B channels      | (H, W, 3) float32              |
| encode_exr          | the bytes of an EXR, float32 or half   | (H, W, 3) float32              |
| read_exr_alpha      | OpenEXR, its A channel if it has one   | (H, W) float32, or None        |
| write_png           | PNG through Pillow                     | (H, W), (H, W, 3|4) uint8      |
| read_image          | PNG, JPEG (anything Pillow decodes)    | (H, W, C) float32 in [0, 1]    |
| write_hdr, read_hdr | Radiance RGBE, RLE or flat scanlines   | (H, W, 3) float32              |
| encode_hdr          | the bytes write_hdr writes             | (H, W, 3) float32              |
| read_environment    | .exr or .hdr, by suffix                | (H, W, 3) float32, >= 0        |
"""
from __future__ import annotations

import io
import json
import os
import secrets
import stat
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import numpy as np
import OpenEXR
from PIL import Image, UnidentifiedImageError

from ..errors import PatchlightError
from ..limits import check_image_size
from . import _kernels
from .bands import banded

ORIENTATION_KEY = "patchlight.orientation"
ORIENTATION = "row 0 is v=0 (glTF UV convention)"

Image.MAX_IMAGE_PIXELS = None  # limits.check_image_size decides, and says how to raise it


# --------------------------------------------------------------------------- files

@contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Yield a temporary path next to `path` (same suffix); on success move it onto `path`.

    If the body raises anything (KeyboardInterrupt included), the temporary file is removed
    and `path` is left as it was.  OSErrors from the body become PatchlightError.
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise PatchlightError(f"{path}: directory {path.parent} does not exist")
    tmp = path.with_name(f".{path.stem}.{os.getpid()}-{secrets.token_hex(4)}.tmp{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise PatchlightError(f"{path}: cannot write ({exc.strerror or exc})") from exc
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def check_output_dir(path) -> Path:
    """`path` as an output directory that can be made: PatchlightError, before any work, when
    a file stands in its way or its nearest existing ancestor is not writable."""
    path = Path(path)
    ancestor = path
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise PatchlightError(f"{path}: {ancestor} is a file, not a directory")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise PatchlightError(f"{path}: cannot write in {ancestor}")
    return path


def write_bytes(path, data: bytes) -> None:
    """Write `data` to `path` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def check_finite(values: np.ndarray, where: str) -> None:
    """PatchlightError naming `where` when an array about to be written holds NaN or infinity."""
    bad = np.count_nonzero(~np.isfinite(values))
    if bad:
        raise PatchlightError(f"{where}: {bad} values to write are NaN or infinite; nothing was written")


def json_text(value, where: str, indent: int | None = 2) -> str:
    """Strict JSON (NumPy numbers and arrays as plain ones, paths as strings): PatchlightError
    naming `where` for a NaN or infinity, which JSON has no token for (parsers refuse Infinity)."""
    try:
        return json.dumps(value, indent=indent, allow_nan=False, default=_plain,
                          separators=None if indent else (",", ":"))
    except ValueError:
        raise PatchlightError(f"{where}: a value to write is NaN or infinite; nothing was written") from None


def write_json(path, value) -> None:
    """Write `value` as strict JSON (`json_text`) to `path` atomically."""
    write_bytes(path, (json_text(value, str(path)) + "\n").encode())


def _plain(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"cannot write {type(value).__name__} as JSON")


def require_file(path) -> Path:
    """`path` as a Path, or PatchlightError when it is missing, not a regular file (a directory,
    FIFO or device, which could block or never end) or unreadable."""
    path = Path(path)
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise PatchlightError(f"{path}: file not found") from None
    except OSError as exc:
        raise PatchlightError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(mode):
        raise PatchlightError(f"{path}: is a directory, not a file")
    if not stat.S_ISREG(mode):
        raise PatchlightError(f"{path}: not a regular file (a FIFO, socket or device)")
    if not os.access(path, os.R_OK):
        raise PatchlightError(f"{path}: cannot read (permission denied)")
    return path


def read_bytes(path) -> bytes:
    """The whole file, or PatchlightError when it is missing or unreadable."""
    path = require_file(path)
    try:
        return path.read_bytes()
    except OSError as exc:
        raise PatchlightError(f"{path}: cannot read ({exc.strerror or exc})") from exc


# --------------------------------------------------------------------------- OpenEXR

def write_exr(path, rgb: np.ndarray, metadata: dict[str, str] | None = None, alpha: np.ndarray | None = None) -> None:
    """Write (H, W, 3) linear RGB (and an (H, W) alpha channel A, if given) as a float32,
    ZIP-compressed EXR; row 0 is the top row.

    The header records the orientation under `patchlight.orientation`; `metadata` adds
    more string attributes.
    """
    write_exr_layers(path, {"": rgb}, metadata, alpha)


def write_exr_layers(path, layers: dict[str, np.ndarray], metadata: dict[str, str] | None = None,
                     alpha: np.ndarray | None = None) -> None:
    """Write (H, W, 3) linear RGB layers as one float32 EXR: layer "" as R, G, B, layer "L0" as
    L0.R, L0.G, L0.B (OpenEXR's layer naming); otherwise as `write_exr`."""
    exr = _exr_file(layers, metadata, alpha, np.float32, str(path))
    with atomic_path(path) as tmp:
        try:
            exr.write(str(tmp))
        except RuntimeError as exc:
            raise PatchlightError(f"{path}: cannot write EXR ({exc})") from exc


def encode_exr(rgb: np.ndarray, half: bool = False) -> bytes:
    """The bytes of a ZIP-compressed EXR of (H, W, 3) linear RGB (row 0 the top row), float32
    or, with `half`, half floats (11-bit mantissa: 2^-11 relative precision, up to 65504)."""
    exr = _exr_file({"": rgb}, None, None, np.float16 if half else np.float32, "encode_exr")
    buffer = io.BytesIO()
    exr.write(buffer)
    return buffer.getvalue()


def _exr_file(layers: dict[str, np.ndarray], metadata: dict[str, str] | None, alpha: np.ndarray | None,
              dtype, where: str) -> OpenEXR.File:
    """An OpenEXR.File of the layers (see write_exr_layers), its channels of `dtype`; ValueError
    for images of the wrong shape, values that are not finite or do not fit the type."""
    channels = {}
    for name, rgb in layers.items():
        pixels = np.asarray(rgb, np.float32)
        if pixels.ndim != 3 or pixels.shape[2] != 3 or 0 in pixels.shape:
            raise ValueError(f"write_exr wants (H, W, 3) images, got shape {pixels.shape}")
        check_finite(pixels.astype(dtype), f"{where} layer {name or 'RGB'}")
        for c, letter in enumerate("RGB"):
            channels[f"{name}.{letter}" if name else letter] = np.ascontiguousarray(pixels[..., c], dtype)
    if alpha is not None:
        if np.shape(alpha) != pixels.shape[:2]:
            raise ValueError(f"write_exr: alpha {np.shape(alpha)} does not match the image's {pixels.shape[:2]}")
        channels["A"] = np.ascontiguousarray(alpha, dtype)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
              ORIENTATION_KEY: ORIENTATION}
    header.update({str(k): str(v) for k, v in (metadata or {}).items()})
    return OpenEXR.File(header, channels)


def read_exr(path) -> np.ndarray:
    """(H, W, 3) float32 from an EXR's R, G, B channels (a Y-only image is repeated in RGB)."""
    path, channels = _exr_channels(path)
    if {"R", "G", "B"} <= channels.keys():
        names = ["R", "G", "B"]
    elif "Y" in channels:
        names = ["Y"] * 3
    else:
        raise PatchlightError(f"{path}: EXR has no R, G, B or Y channels (has {sorted(channels)})")
    return np.stack([channels[n].pixels.astype(np.float32) for n in names], axis=-1)


def _exr_channels(path) -> tuple[Path, dict]:
    """The channels of an EXR file, its size checked against the limits before they are read.
    A damaged file is one PatchlightError: OpenEXR prints what it finds wrong (on stderr and
    stdout, whether or not the read then fails), so that is caught and said."""
    path = require_file(path)
    with _printing_caught() as printed:
        try:  # the binding raises whatever a damaged file provokes (RuntimeError, ValueError, ...)
            (x0, y0), (x1, y1) = OpenEXR.File(str(path), header_only=True).header()["dataWindow"]
            check_image_size(int(x1) - int(x0) + 1, int(y1) - int(y0) + 1, 4, str(path))
            channels, error = OpenEXR.File(str(path), separate_channels=True).channels(), None
        except PatchlightError:
            raise
        except Exception as exc:
            channels, error = None, f"{type(exc).__name__}: {exc}"
    if printed or error:
        what = printed[0].removeprefix(f"{path}: ") if printed else error
        raise PatchlightError(f"{path}: not a readable OpenEXR file ({what})"[:300])
    return path, channels


@contextmanager
def _printing_caught() -> Iterator[list[str]]:
    """Collect what C libraries write to file descriptors 1 and 2 meanwhile, as lines, into the list."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved, lines = {fd: os.dup(fd) for fd in (1, 2)}, []
    with tempfile.TemporaryFile() as sink:
        for fd in saved:
            os.dup2(sink.fileno(), fd)
        try:
            yield lines
        finally:
            for fd, copy in saved.items():
                os.dup2(copy, fd)
                os.close(copy)
            sink.seek(0)
            lines.extend(line for line in sink.read().decode(errors="replace").splitlines() if line.strip())


def read_exr_layers(path, names) -> list[np.ndarray]:
    """(H, W, 3) float32 of each named layer of an EXR (`write_exr_layers`; "" = R, G, B)."""
    path, channels = _exr_channels(path)
    layers = []
    for name in names:
        keys = [f"{name}.{c}" if name else c for c in "RGB"]
        missing = [k for k in keys if k not in channels]
        if missing:
            raise PatchlightError(f"{path}: EXR lacks the channels {', '.join(missing)}")
        layers.append(np.stack([channels[k].pixels.astype(np.float32) for k in keys], axis=-1))
    return layers


def read_exr_alpha(path) -> np.ndarray | None:
    """(H, W) float32 of an EXR's A channel, or None when it has none."""
    _, channels = _exr_channels(path)
    return channels["A"].pixels.astype(np.float32) if "A" in channels else None


# --------------------------------------------------------------------------- PNG / JPEG

def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of a uint8 image: (H, W) grey, (H, W, 3) RGB or (H, W, 4) RGBA."""
    pixels = np.ascontiguousarray(image)
    if pixels.dtype != np.uint8:
        raise ValueError(f"encode_png wants uint8 pixels, got {pixels.dtype}")
    if pixels.ndim == 3 and pixels.shape[2] == 1:
        pixels = pixels[..., 0]
    if not (pixels.ndim == 2 or (pixels.ndim == 3 and pixels.shape[2] in (3, 4))):
        raise ValueError(f"encode_png wants (H, W), (H, W, 3) or (H, W, 4), got {pixels.shape}")
    buffer = io.BytesIO()
    Image.fromarray(pixels).save(buffer, format="PNG")
    return buffer.getvalue()


def write_png(path, image: np.ndarray) -> None:
    """Write a uint8 grey, RGB or RGBA image as PNG, atomically."""
    write_bytes(path, encode_png(image))


def decode_image(data: bytes, where: str) -> np.ndarray:
    """Decode PNG/JPEG bytes to float32 (H, W, C) in [0, 1], C = 1, 2, 3 or 4 (values as stored,
    no colour conversion).  `where` names the source in error messages."""
    try:
        with Image.open(io.BytesIO(data)) as img:
            check_image_size(*img.size, len(img.getbands()), where)
            img.load()
            return _pixels(img)
    except UnidentifiedImageError:
        raise PatchlightError(f"{where}: not a readable PNG/JPEG image (unrecognised format)") from None
    except (OSError, SyntaxError, ValueError, Image.DecompressionBombError) as exc:
        raise PatchlightError(f"{where}: not a readable PNG/JPEG image ({exc})") from exc


def _pixels(img: Image.Image) -> np.ndarray:
    if img.mode in ("I;16", "I;16B", "I;16L", "I"):
        return (np.asarray(img, np.float64) / 65535.0).astype(np.float32)[..., None]
    if img.mode == "F":
        return np.asarray(img, np.float32)[..., None]
    if img.mode == "P":
        img = img.convert("RGBA" if "transparency" in img.info else "RGB")
    elif img.mode not in ("L", "LA", "RGB", "RGBA"):
        img = img.convert({"1": "L", "La": "LA", "PA": "RGBA"}.get(img.mode, "RGBA" if "A" in img.mode else "RGB"))
    arr = np.asarray(img, np.float32) / 255.0
    return arr[..., None] if arr.ndim == 2 else arr


def read_image(path) -> np.ndarray:
    """PNG or JPEG file -> float32 (H, W, C) in [0, 1] (stored values, no sRGB decoding)."""
    return decode_image(read_bytes(path), str(path))


# --------------------------------------------------------------------------- Radiance .hdr

def _float_to_rgbe(rgb: np.ndarray) -> np.ndarray:
    """(H, W, 3) float -> (H, W, 4) uint8 RGBE, mantissas floored as Radiance does (in bands
    of rows)."""
    return banded(_rgbe_rows, rgb, np.uint8, rgb.shape[:2] + (4,))


def _rgbe_rows(rgb: np.ndarray) -> np.ndarray:
    rgb = np.maximum(np.asarray(rgb, np.float64), 0.0)
    peak = rgb.max(axis=-1)
    mantissa, exponent = np.frexp(peak)
    scale = np.divide(mantissa * 256.0, peak, out=np.zeros_like(peak), where=peak > 1e-32)
    rgbe = np.empty(rgb.shape[:2] + (4,), np.uint8)
    rgbe[..., :3] = np.clip(np.floor(rgb * scale[..., None]), 0, 255)
    rgbe[..., 3] = np.where(peak > 1e-32, np.clip(exponent + 128, 0, 255), 0)
    return rgbe


def _rgbe_to_float(rgbe: np.ndarray) -> np.ndarray:
    """(H, W, 4) uint8 RGBE -> (H, W, 3) float32: (m + 0.5) * 2^(e - 136), 0 where e = 0."""
    exponent = rgbe[..., 3].astype(np.int32)
    scale = np.where(exponent > 0, np.ldexp(1.0, exponent - 136), 0.0)
    return ((rgbe[..., :3] + 0.5) * scale[..., None]).astype(np.float32)


def write_hdr(path, rgb: np.ndarray, rle: bool = True) -> None:
    """Write (H, W, 3) linear RGB as Radiance RGBE ("-Y H +X W"), atomically.

    Scanlines are run-length coded when `rle` and 8 <= W <= 32767, flat otherwise.
    Negative values are stored as 0; the relative error is below 1/256 of a pixel's peak channel.
    """
    write_bytes(path, encode_hdr(rgb, rle))


def encode_hdr(rgb: np.ndarray, rle: bool = True) -> bytes:
    """The bytes of a Radiance .hdr file of (H, W, 3) linear RGB (see write_hdr)."""
    pixels = np.asarray(rgb)
    if pixels.ndim != 3 or pixels.shape[2] != 3 or 0 in pixels.shape:
        raise ValueError(f"encode_hdr wants an (H, W, 3) image, got shape {pixels.shape}")
    if not np.all(np.isfinite(pixels)):
        raise ValueError("encode_hdr cannot store NaN or infinite values")
    height, width = pixels.shape[:2]
    rgbe = _float_to_rgbe(pixels)
    header = (f"#?RADIANCE\n# written by patchlight\nFORMAT=32-bit_rle_rgbe\n\n"
              f"-Y {height} +X {width}\n").encode("ascii")
    body = _kernels.encode_scanlines(rgbe).tobytes() if rle and 8 <= width <= 0x7FFF else rgbe.tobytes()
    return header + body


def _hdr_header(data: bytes, path: Path) -> tuple[int, int, bool, int]:
    """Parse the text header: (height, width, flip_rows, offset of the first scanline)."""
    if not data.startswith(b"#?"):
        raise PatchlightError(f"{path}: not a Radiance .hdr file (no '#?' signature)")
    pos = 0
    while True:
        end = data.find(b"\n", pos)
        if end < 0:
            raise PatchlightError(f"{path}: truncated .hdr header")
        line = data[pos:end].strip()
        pos = end + 1
        if not line:
            break
        if line.startswith(b"FORMAT=") and line[7:] != b"32-bit_rle_rgbe":
            raise PatchlightError(f"{path}: unsupported .hdr format {line[7:].decode('latin-1')!r}"
                                  " (only 32-bit_rle_rgbe)")
    end = data.find(b"\n", pos)
    tokens = data[pos:end].split() if end >= 0 else []
    if len(tokens) != 4 or tokens[2] != b"+X" or tokens[0] not in (b"-Y", b"+Y") \
            or not tokens[1].isdigit() or not tokens[3].isdigit():
        shown = data[pos:end if end >= 0 else pos + 40].decode("latin-1")
        raise PatchlightError(f"{path}: unsupported .hdr resolution line {shown!r} (want '-Y H +X W')")
    if len(tokens[1]) > 9 or len(tokens[3]) > 9 or int(tokens[1]) == 0 or int(tokens[3]) == 0:
        raise PatchlightError(f"{path}: bad .hdr size {tokens[3].decode()} x {tokens[1].decode()}")
    height, width = int(tokens[1]), int(tokens[3])
    check_image_size(width, height, 4, str(path))
    return height, width, tokens[0] == b"+Y", end + 1


def read_hdr(path) -> np.ndarray:
    """Radiance .hdr (RGBE; RLE or flat scanlines; "-Y H +X W" or "+Y H +X W") -> (H, W, 3)
    float32 with row 0 the top.  The EXPOSURE header is ignored, as most readers do."""
    path = Path(path)
    data = read_bytes(path)
    height, width, flip, offset = _hdr_header(data, path)
    rgbe = np.zeros((height, width, 4), np.uint8)
    status = _kernels.decode_scanlines(np.frombuffer(data, np.uint8), offset, rgbe)
    if status < 0:
        what = {_kernels.TRUNCATED: "truncated pixel data", _kernels.BAD_LENGTH: "scanline length mismatch",
                _kernels.BAD_RUN: "corrupt run-length data"}[status]
        raise PatchlightError(f"{path}: {what}")
    rgb = _rgbe_to_float(rgbe)
    return rgb[::-1].copy() if flip else rgb


# --------------------------------------------------------------------------- environments

def read_environment(path) -> np.ndarray:
    """An equirectangular environment (.exr or .hdr by suffix) -> (H, W, 3) float32 radiance.

    Refuses NaN or infinite pixels; clamps negative ones (filtering ringing) to 0.
    """
    path = require_file(path)
    suffix = path.suffix.lower()
    if suffix == ".exr":
        rgb = read_exr(path)
    elif suffix in (".hdr", ".pic"):
        rgb = read_hdr(path)
    else:
        raise PatchlightError(f"{path}: environment maps must be .exr or .hdr, not '{suffix or path.name}'")
    if not np.all(np.isfinite(rgb)):
        raise PatchlightError(f"{path}: environment map contains NaN or infinite pixels")
    return np.maximum(rgb, 0.0)
