"""The light-volume file: a JSON header `light_volume.json` and its data `light_volume.bin`.

Header fields (every length in metres, +Y up, glTF's frame):

| field      | value                                                                      |
|------------|----------------------------------------------------------------------------|
| format     | "patchlight-light-volume"                                                  |
| version    | 2 (1: no `validity` section; this reader takes both)                       |
| origin     | [x, y, z] of probe (0, 0, 0)                                               |
| spacing    | [sx, sy, sz]: probe (i, j, k) sits at origin + (i sx, j sy, k sz)          |
| dims       | [NX, NY, NZ] probe counts                                                  |
| axes       | ["+X", "+Y", "+Z", "-X", "-Y", "-Z"]: the order of the six directions      |
| units      | incident light I (cosine-weighted mean radiance, W m^-2 sr^-1), linear RGB |
| layout     | "full" (six RGB values per probe) or "compact" (colour + six intensities)  |
| sampling   | "validity-weighted trilinear" (below)                                      |
| data       | file name of the binary data, next to the header                           |
| byte_order | "little"                                                                   |
| sections   | [{name, dtype, shape, offset, bytes}]: the arrays in the data file, C order |

Sections: layout "full": `cube` float32 [6, NZ, NY, NX, 3], i.e. six 3D RGB volumes one
after the other in axis order, x fastest (a WebGL 3D texture of NX x NY x 6 NZ texels).
Layout "compact": `color` float32 [NZ, NY, NX, 3] (luminance 1) and `intensity` float32
[6, NZ, NY, NX]; axis a's RGB is color x intensity[a] (see patchlight.volumes.volume).
Both end with `inside` uint8 [NZ, NY, NX]: 1 where the probe lay inside geometry and its
values were filled in from its neighbours; and `validity` float32 [NZ, NY, NX] in [0, 1]:
the probe's weight in sampling (patchlight writes 0 inside geometry, 1 elsewhere; a
reader must take any value in between as a weight). Version 1 files have no `validity`:
it is 1 - inside.

Sampling (how a point P between probes is lit; patchlight.shading.ambient_cube and
ambient_cube.glsl do exactly this): g = clamp((P - origin) / spacing, 0, dims - 1); the
cell's corners i0 = min(floor(g), max(dims - 2, 0)), i1 = min(i0 + 1, dims - 1), f = g - i0.
Each of the eight corners c has its trilinear weight t_c (the product of f or 1 - f along
each axis) and validity v_c. With s = sum t_c v_c and a = max(1e-3 - s, 0), corner c weighs
t_c (v_c + a) / (s + a), and each axis' value is the weighted sum of the corners' values.
Where s >= 1e-3 (as at any point less than 0.9 of a cell from a valid corner along each
axis) this is t_c v_c / s: the probes inside geometry, whose filled values may come from
the sunlit side of a wall, drop out, and a point beside the wall reads only the probes on
its own side. Where all eight corners are invalid (s = 0) it is plain trilinear
interpolation of the filled values, and in between the two blend continuously.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import PatchlightError
from ..imaging.io import atomic_path, check_finite, read_bytes, write_json
from ..limits import load_json
from .grid import MAX_PROBES, ProbeGrid
from .volume import AXES, LightVolume, compact, expand

HEADER = "light_volume.json"
DATA = "light_volume.bin"
FORMAT = "patchlight-light-volume"
VERSION = 2
READABLE_VERSIONS = (1, 2)
SAMPLING = "validity-weighted trilinear"
UNITS = "incident light I (cosine-weighted mean radiance, W m^-2 sr^-1), linear RGB"
MIN_SPACING = 1e-6    # metres; below it the sampling's (P - origin) / spacing overflows
MAX_COORDINATE = 1e9  # metres
_DTYPES = {"float32": np.dtype("<f4"), "uint8": np.dtype("u1")}


def _sections(volume: LightVolume, layout: str) -> list[tuple[str, np.ndarray]]:
    if layout == "full":
        arrays = [("cube", volume.cube)]
    elif layout == "compact":
        color, intensity = compact(volume.cube)
        arrays = [("color", color), ("intensity", intensity)]
    else:
        raise ValueError(f"unknown volume layout {layout!r}")
    return arrays + [("inside", volume.inside.astype(np.uint8)), ("validity", volume.validity.astype(np.float32))]


def write_volume(out_dir, volume: LightVolume, layout: str = "full") -> dict:
    """Write the header and data into out_dir (which must exist), each atomically, the data
    first so a header never names missing data. Returns the header."""
    out_dir = Path(out_dir)
    sections, blobs, offset = [], [], 0
    for name, array in _sections(volume, layout):
        check_finite(array, f"{out_dir / DATA} section {name}")
        dtype = "uint8" if array.dtype == np.uint8 else "float32"
        blob = np.ascontiguousarray(array, _DTYPES[dtype]).tobytes()
        sections.append({"name": name, "dtype": dtype, "shape": list(array.shape), "offset": offset,
                         "bytes": len(blob)})
        blobs.append(blob)
        offset += len(blob)
    header = {"format": FORMAT, "version": VERSION, **volume.grid.to_json(), "axes": list(AXES),
              "units": UNITS, "layout": layout, "sampling": SAMPLING, "data": DATA, "byte_order": "little", "sections": sections}
    with atomic_path(out_dir / DATA) as tmp:
        tmp.write_bytes(b"".join(blobs))
    write_json(out_dir / HEADER, header)
    return header


def read_volume(path) -> LightVolume:
    """The volume in a directory (or named by its header file), either layout; header and
    data of one set, read again if the folder was swapped for a new volume meanwhile."""
    from ..outputs import read_consistently

    path = Path(path)
    return read_consistently(path if path.is_dir() else path.parent, lambda: _read_volume(path))


def _read_volume(path: Path) -> LightVolume:
    header_path = path / HEADER if path.is_dir() else path
    if path.is_dir() and not header_path.exists():
        raise PatchlightError(f"{path}: no {HEADER} in it (write one with `patchlight volume`)")
    header = load_json(read_bytes(header_path), str(header_path))
    grid = _grid(header, header_path)
    arrays = _read_sections(header, header_path)
    light = ("color", "intensity") if header.get("layout") == "compact" else ("cube",)
    for name in light:
        _check_light(_get(arrays, name, header_path), name, header_path.parent / _data_name(header, header_path))
    if header.get("layout") == "compact":
        cube = expand(_get(arrays, "color", header_path), _get(arrays, "intensity", header_path))
    else:
        cube = _get(arrays, "cube", header_path)
    inside = _get(arrays, "inside", header_path).astype(bool)
    if header["version"] == 1:
        validity = np.where(inside, 0.0, 1.0).astype(np.float32)
    else:
        validity = np.array(_get(arrays, "validity", header_path), np.float32)
        if not np.all((validity >= 0) & (validity <= 1)):  # NaN fails too
            raise PatchlightError(f"{header_path}: validity values must lie in 0..1")
    try:
        return LightVolume(grid, np.ascontiguousarray(cube, np.float32), inside, validity)
    except ValueError:
        raise PatchlightError(f"{header_path}: section shapes do not match dims {list(grid.dims)}") from None


def _grid(header, where: Path) -> ProbeGrid:
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise PatchlightError(f"{where}: not a patchlight light volume (format is not {FORMAT!r})")
    if type(header.get("version")) is not int or header["version"] not in READABLE_VERSIONS:
        raise PatchlightError(f"{where}: volume version {header.get('version')!r}, this patchlight reads "
                              f"{' and '.join(map(str, READABLE_VERSIONS))}")
    if header.get("axes") != list(AXES):
        raise PatchlightError(f"{where}: axes must be {list(AXES)}")
    try:
        origin = [float(v) for v in header["origin"]]
        spacing = [float(v) for v in header["spacing"]]
        dims = header["dims"]
        if not all(type(n) is int for n in dims):
            raise TypeError
    except (KeyError, TypeError, ValueError):
        raise PatchlightError(f"{where}: origin, spacing and dims must be lists of numbers (dims whole)") from None
    if len(origin) != 3 or len(spacing) != 3 or len(dims) != 3 or min(dims) < 1 \
            or not all(abs(o) <= MAX_COORDINATE for o in origin) \
            or not all(MIN_SPACING <= d <= MAX_COORDINATE for d in spacing):
        raise PatchlightError(f"{where}: origin, spacing and dims need three values each: origin within "
                              f"{MAX_COORDINATE:g} m, spacing {MIN_SPACING:g}..{MAX_COORDINATE:g} m, dims >= 1")
    if math.prod(dims) > MAX_PROBES:
        raise PatchlightError(f"{where}: dims {dims} make more than {MAX_PROBES:,} probes")
    return ProbeGrid(tuple(origin), tuple(spacing), tuple(dims))


def _data_name(header: dict, where: Path) -> str:
    """The data file's name: a plain file name beside the header."""
    name = header.get("data", DATA)
    if not isinstance(name, str) or name in ("", ".", "..") or "/" in name or "\\" in name:
        raise PatchlightError(f"{where}: data must name a file beside the header, not {name!r}"[:200])
    return name


def _check_light(values: np.ndarray, name: str, data: Path) -> None:
    """Incident light is finite: say where it is not."""
    bad = ~np.isfinite(values)
    if bad.any():
        first = np.unravel_index(int(np.argmax(bad)), values.shape)
        raise PatchlightError(f"{data}: section {name} holds {int(bad.sum())} values that are not finite "
                              f"(the first at {list(map(int, first))}: {float(values[first])})")


def _read_sections(header: dict, where: Path) -> dict[str, np.ndarray]:
    data = read_bytes(where.parent / _data_name(header, where))
    sections = header.get("sections", [])
    if not isinstance(sections, list):
        raise PatchlightError(f"{where}: sections must be a list")
    arrays = {}
    for section in sections:
        try:
            name, dtype = str(section["name"]), _DTYPES[section["dtype"]]
            shape, offset = list(section["shape"]), section["offset"]
            if not all(type(n) is int and n >= 0 for n in [*shape, offset]):
                raise TypeError
        except (KeyError, TypeError, ValueError):
            raise PatchlightError(f"{where}: a section lacks name, dtype (float32 or uint8), shape or offset "
                                  f"(whole numbers >= 0)") from None
        size = math.prod(shape) * dtype.itemsize
        if offset < 0 or offset + size > len(data):
            raise PatchlightError(f"{where}: section {name} runs past the end of {header.get('data', DATA)} "
                                  f"({offset + size} > {len(data)} bytes)")
        arrays[name] = np.frombuffer(data, dtype, math.prod(shape), offset).reshape(shape)
    return arrays


def _get(arrays: dict, name: str, where: Path) -> np.ndarray:
    if name not in arrays:
        raise PatchlightError(f"{where}: no {name!r} section")
    return arrays[name]
