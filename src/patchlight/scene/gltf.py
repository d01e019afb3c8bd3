"""glTF 2.0 in (`load_gltf`) and the baked, lightmapped .glb out (`save_baked_glb`).

Import
------
`.glb` and `.gltf` (external `.bin` and image files, `data:` URIs) are flattened into one
world-space `Scene`: the default scene's node tree (else scene 0, else every root node) with
TRS or matrix transforms composed; positions by the world matrix, normals by its inverse
transpose, winding flipped where the determinant is negative.  Primitive modes 4, 5, 6
(triangles, strips, fans), indexed or not; points and lines are skipped and counted.
Accessors may be strided, normalized integers (KHR_mesh_quantization) or sparse.

Files behind buffer and image uris are read only inside the glTF's own folder: an absolute
path, a '..' that climbs out, a symbolic link leading out or a file with other hard links
(one may be anywhere) is refused with one line, unless `outside_files_allowed()` is in force
(`--allow-outside-files`). Only images a texture uses are read, and embedded in the export.

* TEXCOORD_0 -> `uv0` (zeros when absent); TEXCOORD_1 -> `uv1`, float32 values kept bit for bit.
  `uv1` is None unless every triangle primitive has TEXCOORD_1 (mixed files get a warning).
* NORMAL kept (else smooth `vertex_normals`), TANGENT kept when every primitive has it,
  COLOR_0 -> RGBA `colors` (white where a primitive has none).
* Degenerate triangles (a repeated index, or an area below float32 precision) are dropped.
* Materials: baseColorFactor/Texture (sRGB decoded, alpha linear), emissiveFactor x
  KHR_materials_emissive_strength, emissiveTexture (sRGB decoded), normalTexture (raw),
  doubleSided; material `extras` {"shininess": float, "reflectivity": float}.
* KHR_lights_punctual -> `Light` in radiometric units: lux / 683 -> W/m^2, cd / 683 -> W/sr.
  Position is the node's world translation, direction its world -Z.  The light definition's
  `extras` may hold {"falloff": "inverse-square" | "range", "angle": sun diameter in radians,
  "baked": false (a dynamic light: left out of the bake; default true)}.

`Scene.extras` gets "skipped_primitives" (points/lines), "degenerate_triangles" and
"warnings" (a list of one-line strings).  `Scene.provenance` (see `model.Provenance`) records,
per triangle, its node, mesh and primitive and, per vertex, its node, primitive and element in
the primitive's accessors, plus the file's size and mtime: what the writer maps back with.

Sky: the default scene's `extras` (else `asset.extras`) may hold one of

    {"patchlight": {"sky": {"uniform": [r, g, b]}}}
    {"patchlight": {"sky": {"gradient": {"zenith": [r, g, b], "horizon": [r, g, b], "ground": [r, g, b]}}}}
    {"patchlight": {"sky": {"image": "relative/path.exr"}}}     (.exr or .hdr, equirectangular)

in linear radiance (W/(m^2 sr)); see `patchlight.scene.sky` for the models.

Export
------
`save_baked_glb` writes one .glb.  For a scene loaded from a glTF file (`_SourceWriter`) it is
that file's document as it was (JSON objects copied, not re-encoded): node hierarchy, names,
transforms, materials with every field and extension, textures, samplers, images (their bytes;
files beside a .gltf that a texture uses are embedded), cameras, lights, skins, animations, extras.  Each mesh
instance's triangle primitives are rewritten in the primitive's local space with the vertices
the lightmap UVs split (every attribute and morph target copied through the vertex mapping in
its stored component type) plus TEXCOORD_1 (= `uv1` exactly); a mesh drawn by several nodes
gets one copy per further node, "<mesh> (lightmap 2)", ... (each instance has its own lightmap
region).  Where the file's own TEXCOORD_1 was used, the primitives keep their accessors and
indices untouched.  Accessors and bufferViews nothing refers to any more are dropped (unless
the file uses an extension this writer does not know).  When the file has changed since it
was loaded, or the provenance no longer describes the scene, the flattened copy below is
written instead, with a warning.

For a built-in scene: the world-space triangle soup (identity nodes), one mesh per material,
every mesh sharing the POSITION, NORMAL, TEXCOORD_0, TEXCOORD_1 (= `uv1` exactly), COLOR_0
and TANGENT accessors; materials (metallicFactor 0 and KHR_materials_specular's
specularFactor 0: patchlight surfaces are Lambertian, so engines add no specular layer),
lights in photometric units and the camera.

Both: the bake's sky in `extras.patchlight.sky` of the scene the loader reads (an image sky
as a path relative to the .glb, when its file is known: `Sky.to_extras`); every light
definition's `extras.baked` (true: its light is in the lightmap, runtimes must not add it
again; false: a dynamic light); and the lightmap (`imaging.lightmap.EncodedLightmap`: linear
incident light I / scale) as the texture "patchlight_lightmap" (re-baking a scene.glb
replaces its images), referenced by every material of the lightmapped primitives as

    "extensions": {"MOZ_lightmap": {"index": <texture>, "texCoord": 1, "intensity": pi x scale}}

(three.js: material.lightMap, channel 1, lightMapIntensity; its lightMap is irradiance, which
a diffuse surface turns into albedo / pi x irradiance = albedo x I).  The texture's source is
the 8-bit PNG any viewer can read; its MOZ_texture_rgbe extension names the HDR Radiance .hdr
image (mimeType image/vnd.radiance) that three.js's HDRLoader decodes
(`viewer/static/patchlight_gltf.js`, the GLTFLoader plugin, does it).  The texture is linear
data, no sRGB, no mipmaps, v = 0 at the top.  The root `extras` describe it:

    {"patchlight": {"lightmap": {"texture": <texture index>, "texCoord": 1, "scale": <float>,
                                 "intensity": pi x scale, ...the caller's metadata}}}

save_baked_glb's `extras` go into the root extras.patchlight too (vertexbake's colorScale).
"""
from __future__ import annotations

import base64
import binascii
import json
import math
import struct
import warnings
from collections import Counter
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Iterator
from urllib.parse import unquote, unquote_to_bytes

import numpy as np
import pygltflib as gl

from ..errors import PatchlightError
from ..imaging.color import linear_to_srgb, srgb_to_linear
from ..imaging.io import atomic_path, check_finite, decode_image, encode_png, json_text, read_bytes, read_environment
from ..imaging.lightmap import EncodedLightmap
from ..limits import load_json
from .model import Light, Material, Objects, Provenance, Scene, vertex_normals
from .sky import Sky

# Photometric -> radiometric: 683 lm/W at 555 nm (KHR_lights_punctual intensities are lux / candela).
LUMENS_PER_WATT = 683.0
UNLIT = "KHR_materials_unlit"  # vertex-baked light: viewers show base colour x COLOR_0 as it is
MOZ_LIGHTMAP, MOZ_RGBE = "MOZ_lightmap", "MOZ_texture_rgbe"  # the lightmap, and its HDR image
HDR_MIME = "image/vnd.radiance"

SUPPORTED_REQUIRED_EXTENSIONS = {"KHR_lights_punctual", "KHR_materials_emissive_strength",
                                 "KHR_mesh_quantization"}

_COMPONENT_DTYPES = {5120: np.dtype("<i1"), 5121: np.dtype("<u1"), 5122: np.dtype("<i2"),
                     5123: np.dtype("<u2"), 5125: np.dtype("<u4"), 5126: np.dtype("<f4")}
_NORMALIZED_MAX = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}
_INDEX_TYPES = (5121, 5123, 5125)
_TYPE_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
_TOP_LEVEL_LISTS = ("accessors", "animations", "buffers", "bufferViews", "cameras", "images", "materials",
                    "meshes", "nodes", "samplers", "scenes", "skins", "textures")
_WHOLE_NUMBER_FIELDS = {"accessors": ("bufferView", "byteOffset", "componentType", "count"),
                        "bufferViews": ("buffer", "byteOffset", "byteLength", "byteStride", "target"),
                        "buffers": ("byteLength",), "images": ("bufferView",), "textures": ("sampler", "source"),
                        "nodes": ("camera", "mesh", "skin")}
_GLB_MAGIC, _CHUNK_JSON, _CHUNK_BIN = b"glTF", 0x4E4F534A, 0x004E4942
_POINTS_AND_LINES = (0, 1, 2, 3)
_TRIANGLES, _STRIP, _FAN = 4, 5, 6
_FLOAT, _UINT = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_LINEAR_FILTER, _CLAMP_TO_EDGE = 9729, 33071
_DEGENERATE_SINE = 1e-7  # |e1 x e2| below this times the longest edge squared: zero area in float32


# =========================================================================== import

def _asked_density(extras, where: str, fail) -> float | None:
    """extras.patchlight.texelsPerUnit of a node or mesh: a positive number, or None."""
    value = ((extras or {}).get("patchlight") or {}).get("texelsPerUnit") if isinstance(extras, dict) else None
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (0 < value < math.inf):
        raise fail(f"{where}: extras.patchlight.texelsPerUnit must be a positive number, not {value!r}")
    return float(value)


def load_gltf(path) -> Scene:
    """Read a .gltf or .glb file into one world-space `Scene` (see the module docstring)."""
    path = Path(path)
    stamp = _file_stamp(path)  # before reading: a file changed meanwhile never matches it later
    doc, blob = _read_document(path)
    try:
        scene = _Importer(path, doc, blob).scene()
    except (TypeError, ValueError, AttributeError, KeyError) as exc:
        # JSON values of the wrong type (a string where a list belongs, ...) surface as these.
        raise PatchlightError(f"{path}: malformed glTF ({type(exc).__name__}: {exc})") from exc
    scene.validate()
    scene.provenance.path, scene.provenance.stamp = str(path), stamp
    return scene


def _file_stamp(path: Path) -> tuple[int, int] | None:
    """(size, mtime in ns) of a file: how save_baked_glb knows the source has not changed."""
    try:
        status = path.stat()
    except OSError:
        return None
    return status.st_size, status.st_mtime_ns


def _read_document(path: Path) -> tuple[gl.GLTF2, bytes | None]:
    """Parse the JSON (from a .gltf or a GLB container) into pygltflib objects + the BIN chunk."""
    data = read_bytes(path)
    if data[:4] == _GLB_MAGIC:
        text, blob = _split_glb(data, path)
    else:
        text, blob = _json_text(data, path), None
    raw = load_json(text, str(path))
    if not isinstance(raw, dict) or not isinstance(raw.get("asset"), dict):
        raise PatchlightError(f"{path}: not a glTF file (JSON without an 'asset' object)")
    version = str(raw["asset"].get("version", ""))
    if not version.startswith("2."):
        raise PatchlightError(f"{path}: glTF version {version!r} is not supported (only 2.x)")
    _check_structure(raw, path)
    try:
        doc = gl.GLTF2.from_json(text, infer_missing=True)
    except Exception as exc:  # pygltflib's decoder raises whatever the bad value provokes
        raise PatchlightError(f"{path}: malformed glTF ({type(exc).__name__}: {exc})") from exc
    return doc, blob


def _check_structure(raw: dict, path: Path) -> None:
    """The document's shape, before anything trusts it: top-level arrays are lists of objects,
    indices, counts, offsets and lengths are whole numbers, extension lists hold names."""
    def bad(what: str) -> PatchlightError:
        return PatchlightError(f"{path}: malformed glTF ({what})"[:300])

    if "scene" in raw and not _whole(raw["scene"]):
        raise bad(f"'scene' must be an index, got {raw['scene']!r}")
    for key in _TOP_LEVEL_LISTS:
        items = raw.get(key, [])
        if not isinstance(items, list) or not all(isinstance(item, dict) for item in items):
            raise bad(f"'{key}' must be a list of objects")
        for n, item in enumerate(items):
            for name in _WHOLE_NUMBER_FIELDS.get(key, ()):
                if name in item and not _whole(item[name]):
                    raise bad(f"{key}[{n}]: {name} {item[name]!r} is not a whole number >= 0")
    for key in ("extensionsUsed", "extensionsRequired"):
        names = raw.get(key, [])
        if not isinstance(names, list) or not all(isinstance(name, str) for name in names):
            raise bad(f"'{key}' must be a list of extension names")
    if not isinstance(raw.get("extensions", {}), dict):
        raise bad("'extensions' must be an object")


def _whole(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 2**53


def _json_text(data: bytes, path: Path) -> str:
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise PatchlightError(f"{path}: not a glTF file (neither a GLB container nor UTF-8 JSON)") from None


def _split_glb(data: bytes, path: Path) -> tuple[str, bytes | None]:
    """The JSON chunk's text and the first BIN chunk of a GLB container."""
    if len(data) < 12:
        raise PatchlightError(f"{path}: truncated .glb ({len(data)} bytes, no complete header)")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise PatchlightError(f"{path}: GLB container version {version} is not supported (only 2)")
    if length > len(data):
        raise PatchlightError(f"{path}: truncated .glb (header says {length} bytes, file has {len(data)})")
    chunks, pos = [], 12
    while pos < length:
        if pos + 8 > length:
            raise PatchlightError(f"{path}: truncated .glb (chunk header cut off at byte {pos})")
        size, kind = struct.unpack_from("<II", data, pos)
        if pos + 8 + size > length:
            raise PatchlightError(f"{path}: truncated .glb (chunk {len(chunks)} runs past the end)")
        chunks.append((kind, data[pos + 8:pos + 8 + size]))
        pos += 8 + size
    if not chunks or chunks[0][0] != _CHUNK_JSON:
        raise PatchlightError(f"{path}: malformed .glb (the first chunk is not JSON)")
    blob = next((chunk for kind, chunk in chunks[1:] if kind == _CHUNK_BIN), None)
    try:
        return chunks[0][1].decode("utf-8"), blob
    except UnicodeDecodeError:
        raise PatchlightError(f"{path}: malformed .glb (JSON chunk is not UTF-8)") from None


_outside_allowed = ContextVar("patchlight_outside_files_allowed", default=False)


@contextmanager
def outside_files_allowed(allowed: bool = True) -> Iterator[None]:
    """Within it, glTF uris may name files outside the glTF's folder (`--allow-outside-files`)."""
    token = _outside_allowed.set(allowed)
    try:
        yield
    finally:
        _outside_allowed.reset(token)


def outside_reason(folder: Path, name: str) -> str | None:
    """Why the file `name` (a decoded uri) is not safely inside `folder`, or None when it is."""
    if PurePosixPath(name).is_absolute() or PureWindowsPath(name).anchor:
        return "is an absolute path"
    root = folder.resolve()
    try:
        target = (folder / name).resolve()
        if not target.is_relative_to(root):
            if ".." in PurePosixPath(name).parts:
                return "climbs out of the folder with '..'"
            return "is a symbolic link leading out of the folder"
        if target.is_file() and target.stat().st_nlink > 1:
            return "has other hard links (one may lie outside the folder)"
    except (OSError, RuntimeError):  # a name too long, a loop of links: not found below
        return None
    return None


def _data_uri(uri: str) -> bytes:
    """The payload of a data: URI (base64 or percent-encoded)."""
    header, _, payload = uri.partition(",")
    if header.endswith(";base64"):
        return base64.b64decode(payload, validate=True)
    return unquote_to_bytes(payload)


@dataclass
class _Block:
    """The world-space vertices of one set of attribute accessors under one world matrix,
    shared by every primitive that uses exactly those accessors there."""

    positions: np.ndarray
    normals: np.ndarray | None
    uv0: np.ndarray
    uv1: np.ndarray | None
    tangents: np.ndarray | None
    colors: np.ndarray | None
    mirrored: bool
    node: int = -1       # provenance: the node, and the first primitive of its mesh with these accessors
    primitive: int = -1
    triangles: list[np.ndarray] = field(default_factory=list)
    material_ids: list[np.ndarray] = field(default_factory=list)
    sources: list[tuple[int, int, int, int]] = field(default_factory=list)  # (node, mesh, primitive, count)


class _Importer:
    """One glTF document being flattened; holds the decoded buffers and images."""

    def __init__(self, path: Path, doc: gl.GLTF2, blob: bytes | None):
        self.path, self.doc, self.blob = path, doc, blob
        self.warnings: list[str] = []
        self.skipped = 0
        self.uses_default_material = False
        self._buffers: dict[int, bytes] = {}
        self._images: dict[int, np.ndarray] = {}
        self._input_bytes: int | None = None

    def fail(self, what: str) -> PatchlightError:
        return PatchlightError(f"{self.path}: {what}")

    def vector(self, value, default, n: int, what: str, lo: float = -math.inf, hi: float = math.inf) -> np.ndarray:
        """A list of n finite numbers in [lo, hi] as float32 (`default` when absent, if there is one)."""
        if value is None and default is not None:
            value = default
        try:
            array = np.asarray(value, np.float64).reshape(n)
        except (TypeError, ValueError):
            array = np.full(n, np.nan)
        if not np.all(np.isfinite(array)):
            raise self.fail(f"{what}: want {n} finite numbers, got {value!r}"[:200])
        if not np.all((array >= lo) & (array <= hi)):
            raise self.fail(f"{what}: want {n} numbers in [{lo:g}, {hi:g}], got {value!r}"[:200])
        return array.astype(np.float32)

    def item(self, items: list | None, index, what: str):
        """items[index], or a clear error for a missing or out-of-range index."""
        items = items or []
        if not isinstance(index, int) or isinstance(index, bool) or not 0 <= index < len(items):
            raise self.fail(f"{what} {index!r} does not exist (the file defines {len(items)})")
        return items[index]

    # ------------------------------------------------------------------ the whole scene

    def scene(self) -> Scene:
        self._check_required_extensions()
        instances = self._instances()
        materials = [self._material(i) for i in range(len(self.doc.materials or []))]
        blocks = self._blocks(instances, len(materials))
        if self.uses_default_material:
            materials.append(Material())
        scene = self._assemble(blocks, materials)
        scene.lights = self._lights(instances)
        scene.sky = self._sky()
        camera = self._camera(instances)
        if camera is not None:
            scene.extras["camera"] = camera
        scene.name, scene.source = self.path.stem, str(self.path)
        return scene

    def _check_required_extensions(self) -> None:
        unsupported = sorted(set(self.doc.extensionsRequired or []) - SUPPORTED_REQUIRED_EXTENSIONS)
        if unsupported:
            raise self.fail(f"requires unsupported glTF extension(s) {', '.join(unsupported)}")

    def _instances(self) -> list[tuple[int, np.ndarray]]:
        """(node index, (4, 4) float64 world matrix) for every node under the chosen roots, depth first."""
        out, seen = [], set()
        stack = [(root, np.eye(4)) for root in reversed(self._root_nodes())]
        while stack:
            index, parent = stack.pop()
            if index in seen:
                raise self.fail(f"node {index} appears twice in the node hierarchy (a cycle or a shared child)")
            seen.add(index)
            node = self.item(self.doc.nodes, index, "node")
            world = parent @ self._local_matrix(node, index)
            out.append((index, world))
            stack.extend((child, world) for child in reversed(node.children or []))
        return out

    def _root_nodes(self) -> list[int]:
        if self.doc.scenes:
            chosen = self.doc.scene if self.doc.scene is not None else 0
            return list(self.item(self.doc.scenes, chosen, "scene").nodes or [])
        children = {c for node in self.doc.nodes or [] for c in node.children or []}
        return [i for i in range(len(self.doc.nodes or [])) if i not in children]

    def _local_matrix(self, node: gl.Node, index: int) -> np.ndarray:
        if node.matrix is not None:
            if len(node.matrix) != 16:
                raise self.fail(f"node {index}: matrix has {len(node.matrix)} numbers, not 16")
            return np.asarray(node.matrix, np.float64).reshape(4, 4).T  # glTF stores columns
        matrix = np.eye(4)
        if node.scale is not None:
            matrix = np.diag([*self.vector(node.scale, None, 3, f"node {index} scale").astype(np.float64), 1.0])
        if node.rotation is not None:
            rotation = self.vector(node.rotation, None, 4, f"node {index} rotation")
            if not np.any(rotation):
                raise self.fail(f"node {index}: rotation quaternion is zero")
            matrix = _quaternion_matrix(rotation) @ matrix
        if node.translation is not None:
            matrix[:3, 3] = self.vector(node.translation, None, 3, f"node {index} translation")
        return matrix

    # ------------------------------------------------------------------ buffers and accessors

    def buffer(self, index) -> bytes:
        if index not in self._buffers:
            buf = self.item(self.doc.buffers, index, "buffer")
            data = self._resource(buf.uri, f"buffer {index}") if buf.uri is not None else self.blob
            if data is None:
                raise self.fail(f"buffer {index} has no uri and the file has no GLB binary chunk")
            if buf.byteLength is not None and len(data) < buf.byteLength:
                raise self.fail(f"buffer {index} holds {len(data)} bytes, less than its byteLength {buf.byteLength}")
            self._buffers[index] = data
        return self._buffers[index]

    def _resource(self, uri: str, what: str) -> bytes:
        """Bytes behind a buffer or image uri: a data: URI or a file in the glTF's folder
        (`outside_reason`)."""
        if uri.startswith("data:"):
            try:
                return _data_uri(uri)
            except (binascii.Error, ValueError) as exc:
                raise self.fail(f"{what}: bad data: URI ({exc})") from exc
        if "://" in uri:
            raise self.fail(f"{what}: remote uri {uri[:60]!r}; patchlight reads local files only")
        target = self.path.parent / unquote(uri)
        reason = None if _outside_allowed.get() else outside_reason(self.path.parent, unquote(uri))
        if reason is not None:
            raise self.fail(f"{what}: uri {uri[:60]!r} {reason}; only files inside the glTF's folder "
                            f"are read (--allow-outside-files reads it)")
        if not target.is_file():
            raise self.fail(f"{what}: file {uri!r} not found next to the glTF")
        return read_bytes(target)

    def view_bytes(self, index) -> memoryview:
        view = self.item(self.doc.bufferViews, index, "bufferView")
        data = self.buffer(view.buffer)
        start = view.byteOffset or 0
        if view.byteLength is None or start + view.byteLength > len(data):
            raise self.fail(f"bufferView {index} (bytes {start}..{start + (view.byteLength or 0)}) "
                            f"runs past the end of buffer {view.buffer} ({len(data)} bytes)")
        return memoryview(data)[start:start + view.byteLength]

    def _strided(self, view_index, offset: int, count: int, width: int, dtype: np.dtype, what: str) -> np.ndarray:
        """(count, width) elements read from a bufferView at `offset`, honouring byteStride."""
        data = self.view_bytes(view_index)
        if not isinstance(count, int) or count < 0 or not isinstance(offset, int) or offset < 0:
            raise self.fail(f"{what}: count {count!r} and byteOffset {offset!r} must be whole numbers >= 0")
        element = width * dtype.itemsize
        stride = self.doc.bufferViews[view_index].byteStride or element
        if stride < element:
            raise self.fail(f"{what}: byteStride {stride} is smaller than an element ({element} bytes)")
        end = offset + stride * (count - 1) + element if count else offset
        if end > len(data):
            raise self.fail(f"{what} reads bytes up to {end} but bufferView {view_index} holds {len(data)}")
        if count == 0:
            return np.zeros((0, width), dtype)
        return np.ndarray((count, width), dtype, buffer=data, offset=offset, strides=(stride, dtype.itemsize)).copy()

    def accessor(self, index) -> np.ndarray:
        """(count, width) values of an accessor in its stored component type."""
        acc = self.item(self.doc.accessors, index, "accessor")
        what = f"accessor {index}"
        dtype = _COMPONENT_DTYPES.get(acc.componentType)
        width = _TYPE_WIDTHS.get(acc.type)
        if dtype is None or width is None:
            raise self.fail(f"{what}: unsupported componentType {acc.componentType} / type {acc.type!r}")
        count = acc.count or 0
        if acc.bufferView is None:
            self._check_unbacked(count * width * dtype.itemsize, what)
            values = np.zeros((count, width), dtype)
        else:
            values = self._strided(acc.bufferView, acc.byteOffset or 0, count, width, dtype, what)
        if acc.sparse is not None:
            values = self._apply_sparse(acc.sparse, values, what)
        return values

    def _check_unbacked(self, nbytes: int, what: str) -> None:
        """An accessor without a bufferView is zeros (plus sparse substitutes), standing for data
        as large as real attributes: it may not be larger than the file and its buffers, so a few
        bytes cannot ask for gigabytes."""
        if self._input_bytes is None:
            self._input_bytes = self.path.stat().st_size
            for index, buf in enumerate(self.doc.buffers or []):
                if buf.uri is not None:
                    try:
                        self._input_bytes += len(self.buffer(index))
                    except PatchlightError:
                        pass
        if nbytes > self._input_bytes:
            raise self.fail(f"{what}: {nbytes:,} bytes without a bufferView, more than the "
                            f"{self._input_bytes:,} bytes of the file and its buffers")

    def _apply_sparse(self, sparse: gl.Sparse, values: np.ndarray, what: str) -> np.ndarray:
        """Overwrite the listed elements with the sparse substitutes."""
        index_type = _COMPONENT_DTYPES.get(sparse.indices.componentType)
        if sparse.indices.componentType not in _INDEX_TYPES:
            raise self.fail(f"{what}: sparse indices must be unsigned integers")
        where = self._strided(sparse.indices.bufferView, sparse.indices.byteOffset or 0, sparse.count,
                              1, index_type, f"{what} sparse indices")[:, 0].astype(np.int64)
        substitutes = self._strided(sparse.values.bufferView, sparse.values.byteOffset or 0, sparse.count,
                                    values.shape[1], values.dtype, f"{what} sparse values")
        if where.size and where.max() >= len(values):
            raise self.fail(f"{what}: sparse index {int(where.max())} is past its {len(values)} elements")
        values = values.copy()
        values[where] = substitutes
        return values

    def floats(self, index, widths: tuple[int, ...], what: str) -> np.ndarray:
        """A float32 attribute; normalized integers mapped to [0, 1] / [-1, 1] as glTF says."""
        values = self.accessor(index)
        if values.shape[1] not in widths:
            raise self.fail(f"{what}: accessor {index} has {values.shape[1]} components, expected {widths}")
        acc = self.doc.accessors[index]
        if acc.componentType == _FLOAT:
            return values
        if acc.normalized:
            return np.maximum(values / _NORMALIZED_MAX[acc.componentType], -1.0).astype(np.float32)
        return values.astype(np.float32)

    # ------------------------------------------------------------------ meshes

    def _blocks(self, instances, default_material: int) -> list[_Block]:
        """Gather every triangle primitive of every mesh instance into vertex blocks."""
        blocks: dict[tuple, _Block] = {}
        uses = Counter()
        for node_index, world in instances:
            node = self.doc.nodes[node_index]
            if node.mesh is None:
                continue
            mesh = self.item(self.doc.meshes, node.mesh, "mesh")
            label = repr(mesh.name) if mesh.name else str(node.mesh)
            uses[node.mesh] += 1
            if node.skin is not None or any(p.targets for p in mesh.primitives or []):
                self.warnings.append(f"mesh {label}: skinning and morph targets ignored (rest pose used)")
            for number, primitive in enumerate(mesh.primitives or []):
                self._add_primitive(blocks, primitive, world, f"mesh {label} primitive {number}", label,
                                    default_material, (node_index, node.mesh, number))
        self._warn_about_instances(uses, blocks.values())
        return list(blocks.values())

    def _add_primitive(self, blocks: dict[tuple, _Block], primitive: gl.Primitive, world: np.ndarray,
                       where: str, label: str, default_material: int, source: tuple[int, int, int]) -> None:
        """Append one primitive's triangles to the block of its accessors under `world` (made on
        first use); source = (node, mesh, primitive number), kept as the Scene's provenance."""
        mode = _TRIANGLES if primitive.mode is None else primitive.mode
        if mode in _POINTS_AND_LINES:
            self.skipped += 1
            return
        if mode not in (_TRIANGLES, _STRIP, _FAN):
            raise self.fail(f"{where}: unknown mode {mode}")
        attributes = _attribute_map(primitive)
        key = (world.tobytes(), tuple(sorted(attributes.items())))
        if key not in blocks:
            blocks[key] = self._block(attributes, world, where, label)
            blocks[key].node, blocks[key].primitive = source[0], source[2]
        block = blocks[key]
        triangles = self._triangles(primitive, mode, len(block.positions), where)
        material = primitive.material
        if material is None:
            material, self.uses_default_material = default_material, True
        else:
            self.item(self.doc.materials, material, "material")
        block.triangles.append(triangles)
        block.material_ids.append(np.full(len(triangles), material, np.int32))
        block.sources.append((*source, len(triangles)))

    def _block(self, attributes: dict[str, int], world: np.ndarray, where: str, label: str) -> _Block:
        if "POSITION" not in attributes:
            raise self.fail(f"{where} has no POSITION attribute")
        local = self.floats(attributes["POSITION"], (3,), where)
        if not np.all(np.isfinite(local)):
            bad = int(np.count_nonzero(~np.isfinite(local).all(axis=1)))
            raise self.fail(f"mesh {label}: {bad} vertex positions are NaN or infinite")
        count = len(local)

        def attribute(name: str, widths: tuple[int, ...]) -> np.ndarray | None:
            if name not in attributes:
                return None
            values = self.floats(attributes[name], widths, f"{where} {name}")
            if len(values) != count:
                raise self.fail(f"{where}: {name} has {len(values)} elements but POSITION has {count}")
            return values

        linear = world[:3, :3]
        det = float(np.linalg.det(linear))
        identity = np.array_equal(world, np.eye(4))
        positions = local if identity else (local @ linear.T + world[:3, 3]).astype(np.float32)
        normals = attribute("NORMAL", (3,))
        if normals is not None and not identity:
            normals = _unit_rows(normals @ np.linalg.pinv(linear))  # rows times inverse = inverse transpose
        tangents = attribute("TANGENT", (4,))
        if tangents is not None and not identity:
            tangents = np.concatenate([_unit_rows(tangents[:, :3] @ linear.T),
                                       tangents[:, 3:] * np.float32(np.sign(det) or 1.0)], axis=1)
        colors = attribute("COLOR_0", (3, 4))
        if colors is not None and colors.shape[1] == 3:
            colors = np.concatenate([colors, np.ones((count, 1), np.float32)], axis=1)
        uv0 = attribute("TEXCOORD_0", (2,))
        return _Block(positions=positions, normals=normals,
                      uv0=np.zeros((count, 2), np.float32) if uv0 is None else uv0,
                      uv1=attribute("TEXCOORD_1", (2,)), tangents=tangents, colors=colors, mirrored=det < 0)

    def _triangles(self, primitive: gl.Primitive, mode: int, vertex_count: int, where: str) -> np.ndarray:
        """(T, 3) int64 vertex indices of a triangle list, strip or fan, in glTF winding."""
        if primitive.indices is None:
            index = np.arange(vertex_count, dtype=np.int64)
        else:
            accessor = self.item(self.doc.accessors, primitive.indices, "accessor")
            if accessor.componentType not in _INDEX_TYPES or accessor.type != "SCALAR":
                raise self.fail(f"{where}: indices must be SCALAR unsigned integers")
            index = self.accessor(primitive.indices)[:, 0].astype(np.int64)
            if index.size and index.max() >= vertex_count:
                raise self.fail(f"{where}: index {int(index.max())} is past its {vertex_count} vertices")
        if mode == _TRIANGLES:
            if len(index) % 3:
                raise self.fail(f"{where}: {len(index)} triangle indices is not a multiple of 3")
            return index.reshape(-1, 3)
        k = np.arange(max(len(index) - 2, 0))
        if mode == _STRIP:  # every odd triangle swaps its last two corners to keep the winding
            return np.stack([index[k], index[k + 1 + k % 2], index[k + 2 - k % 2]], axis=1)
        return np.stack([index[k + 1], index[k + 2], np.full(len(k), index[0] if len(index) else 0)], axis=1)

    def _warn_about_instances(self, uses: Counter, blocks) -> None:
        if all(b.uv1 is not None for b in blocks):
            for mesh, n in sorted(uses.items()):
                if n > 1:
                    self.warnings.append(f"mesh {mesh} is instanced {n} times: its TEXCOORD_1 lightmap charts overlap")

    def _assemble(self, blocks: list[_Block], materials: list[Material]) -> Scene:
        """Concatenate the blocks into the scene arrays, dropping degenerate triangles."""
        if not blocks:
            raise self.fail(f"no triangles ({self.skipped} point/line primitives skipped)")
        degenerate, offset, indices, material_ids, sources = 0, 0, [], [], []
        for block in blocks:
            triangles = np.concatenate(block.triangles)
            keep = ~_degenerate(block.positions, triangles)
            degenerate += int(np.count_nonzero(~keep))
            triangles = triangles[keep][:, [0, 2, 1]] if block.mirrored else triangles[keep]
            if block.normals is None:
                block.normals = vertex_normals(block.positions, triangles)
            indices.append(triangles + offset)
            material_ids.append(np.concatenate(block.material_ids)[keep])
            sources.append(np.repeat(np.array([s[:3] for s in block.sources], np.int32).reshape(-1, 3),
                                     [s[3] for s in block.sources], axis=0)[keep])
            offset += len(block.positions)
        indices = np.concatenate(indices).astype(np.int32)
        if len(indices) == 0:
            raise self.fail(f"no triangles left ({degenerate} degenerate dropped, "
                            f"{self.skipped} point/line primitives skipped)")
        scene = Scene(positions=np.concatenate([b.positions for b in blocks]),
                      normals=np.concatenate([b.normals for b in blocks]),
                      uv0=np.concatenate([b.uv0 for b in blocks]),
                      indices=indices,
                      material_ids=np.concatenate(material_ids).astype(np.int32),
                      materials=materials,
                      uv1=self._all_or_none(blocks, "uv1", "TEXCOORD_1"),
                      tangents=self._all_or_none(blocks, "tangents", "TANGENT"),
                      colors=_fill_colors(blocks))
        scene.extras.update(skipped_primitives=self.skipped, degenerate_triangles=degenerate,
                            warnings=self.warnings)
        sources = np.concatenate(sources)
        count = [len(b.positions) for b in blocks]
        scene.provenance = Provenance(
            path=str(self.path), stamp=(0, 0), triangle_node=sources[:, 0].copy(),
            triangle_mesh=sources[:, 1].copy(), triangle_primitive=sources[:, 2].copy(),
            vertex_node=np.repeat(np.array([b.node for b in blocks], np.int32), count),
            vertex_primitive=np.repeat(np.array([b.primitive for b in blocks], np.int32), count),
            vertex_source=np.concatenate([np.arange(n, dtype=np.int32) for n in count]))
        scene.objects = self._objects(scene.provenance.triangle_node)
        return scene

    def _objects(self, triangle_node: np.ndarray) -> Objects:
        """One object per mesh instance (node), with the density its extras ask for."""
        nodes, triangle = np.unique(triangle_node, return_inverse=True)
        names, density = [], []
        for index in nodes:
            node = self.doc.nodes[index]
            mesh = self.doc.meshes[node.mesh]
            names.append(node.name or mesh.name or f"node {index}")
            asked = [_asked_density(holder.extras, f"node {index}" if holder is node else f"mesh {node.mesh}",
                                    self.fail) for holder in (node, mesh)]
            density.append(next((d for d in asked if d is not None), math.nan))
        return Objects(names, triangle.astype(np.int32), np.array(density, np.float64))

    def _all_or_none(self, blocks: list[_Block], name: str, attribute: str) -> np.ndarray | None:
        arrays = [getattr(b, name) for b in blocks]
        present = sum(a is not None for a in arrays)
        if present == len(arrays):
            return np.concatenate(arrays)
        if present:
            self.warnings.append(f"{attribute} is on only some primitives ({present} of {len(arrays)} "
                                 f"vertex sets): ignored for the whole scene")
        return None

    # ------------------------------------------------------------------ materials and images

    def _material(self, index: int) -> Material:
        source = self.doc.materials[index]
        name = source.name or f"material_{index}"
        where = f"material {name!r}"
        pbr = source.pbrMetallicRoughness or gl.PbrMetallicRoughness()
        material = Material(name=name, double_sided=bool(source.doubleSided))
        material.base_color = self.vector(pbr.baseColorFactor, [1.0, 1.0, 1.0, 1.0], 4, f"{where} baseColorFactor",
                                          0.0, 1.0)  # a reflectance above 1 would make light
        base = self._texture(pbr.baseColorTexture, f"{where} baseColorTexture")
        if base is not None:
            rgba = _rgba(base)
            rgba[..., :3] = srgb_to_linear(rgba[..., :3])
            material.base_color_texture = rgba
        strength = ((source.extensions or {}).get("KHR_materials_emissive_strength") or {}).get("emissiveStrength", 1.0)
        if not isinstance(strength, (int, float)) or isinstance(strength, bool) or not 0 <= strength < math.inf:
            raise self.fail(f"{where}: emissiveStrength must be a number >= 0, not {strength!r}"[:200])
        emissive = self.vector(source.emissiveFactor, [0.0, 0.0, 0.0], 3, f"{where} emissiveFactor", 0.0)
        material.emissive = (emissive * np.float32(strength)).astype(np.float32)
        emission = self._texture(source.emissiveTexture, f"{where} emissiveTexture")
        if emission is not None:
            material.emissive_texture = srgb_to_linear(_rgba(emission)[..., :3])
        normal = self._texture(source.normalTexture, f"{where} normalTexture")
        if normal is not None:
            material.normal_texture = np.ascontiguousarray(_rgba(normal)[..., :3])
        for key in ("shininess", "reflectivity"):
            value = (source.extras or {}).get(key)
            if value is not None:
                if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                    raise self.fail(f"{where}: extras.{key} must be a number, not {value!r}")
                setattr(material, key, float(value))
        return material

    def _texture(self, info, where: str) -> np.ndarray | None:
        """The decoded image (H, W, C) float32 in [0, 1] behind a material's texture reference."""
        if info is None or info.index is None:
            return None
        texture = self.item(self.doc.textures, info.index, f"{where}: texture")
        if texture.source is None:
            self.warnings.append(f"{where}: texture {info.index} has no PNG/JPEG source (ignored)")
            return None
        if info.texCoord:
            self.warnings.append(f"{where} uses TEXCOORD_{info.texCoord}; patchlight samples it with TEXCOORD_0")
        return self._image(texture.source)

    def _image(self, index) -> np.ndarray:
        if index not in self._images:
            image = self.item(self.doc.images, index, "image")
            if image.bufferView is not None:
                data, label = bytes(self.view_bytes(image.bufferView)), f"image {index} (bufferView {image.bufferView})"
            elif image.uri:
                data, label = self._resource(image.uri, f"image {index}"), f"image {index} ({image.uri[:40]!r})"
            else:
                raise self.fail(f"image {index} has neither a uri nor a bufferView")
            self._images[index] = decode_image(data, f"{self.path}: {label}")
        return self._images[index]

    # ------------------------------------------------------------------ lights and sky

    def _lights(self, instances) -> list[Light]:
        definitions = ((self.doc.extensions or {}).get("KHR_lights_punctual") or {}).get("lights") or []
        lights = []
        for node_index, world in instances:
            reference = (self.doc.nodes[node_index].extensions or {}).get("KHR_lights_punctual")
            if reference is not None:
                spec = self.item(definitions, reference.get("light"), f"node {node_index}: KHR_lights_punctual light")
                light = self._light(spec, world, f"light {reference.get('light')}")
                light.source = reference.get("light")
                lights.append(light)
        return lights

    def _light(self, spec: dict, world: np.ndarray, where: str) -> Light:
        kind = spec.get("type")
        if kind not in ("directional", "point", "spot"):
            raise self.fail(f"{where}: unknown light type {kind!r}")
        intensity = float(spec.get("intensity", 1.0))
        light_range = spec.get("range")
        cone = spec.get("spot") or {}
        inner, outer = float(cone.get("innerConeAngle", 0.0)), float(cone.get("outerConeAngle", math.pi / 4))
        extras = spec.get("extras") or {}
        falloff, angle = extras.get("falloff"), float(extras.get("angle", 0.0))
        baked = extras.get("baked", True)
        if not isinstance(baked, bool):
            raise self.fail(f"{where}: extras 'baked' must be true or false, got {baked!r}")
        direction = world[:3, :3] @ np.array([0.0, 0.0, -1.0])
        if intensity < 0 or (light_range is not None and float(light_range) <= 0):
            raise self.fail(f"{where}: intensity must be >= 0 and range > 0")
        if kind == "spot" and not 0 <= inner <= outer <= math.pi / 2:
            raise self.fail(f"{where}: cone angles need 0 <= inner ({inner}) <= outer ({outer}) <= pi/2")
        if falloff not in (None, "inverse-square", "range") or not 0 <= angle < math.pi:
            raise self.fail(f"{where}: extras need falloff 'inverse-square' | 'range' and 0 <= angle < pi")
        if not np.linalg.norm(direction) > 0:
            raise self.fail(f"{where}: its node's transform collapses the light direction")
        return Light(kind=kind, color=self.vector(spec.get("color"), [1.0, 1.0, 1.0], 3, f"{where} color", 0.0),
                     intensity=intensity / LUMENS_PER_WATT,
                     position=world[:3, 3].astype(np.float32),
                     direction=(direction / np.linalg.norm(direction)).astype(np.float32),
                     range=None if light_range is None else float(light_range),
                     inner_cone=inner, outer_cone=outer, falloff=falloff, angle=angle,
                     name=str(spec.get("name", "")), baked=baked)

    def _camera(self, instances) -> dict | None:
        """The first perspective camera node as {eye, target, fov (vertical, degrees)}: the
        view `render` and `view` start from."""
        for node_index, world in instances:
            number = self.doc.nodes[node_index].camera
            if number is None:
                continue
            camera = self.item(self.doc.cameras, number, f"node {node_index}: camera")
            if camera.type != "perspective" or camera.perspective is None:
                continue
            forward = world[:3, :3] @ np.array([0.0, 0.0, -1.0])
            if not np.linalg.norm(forward) > 0:
                continue
            eye = world[:3, 3]
            return {"eye": _floats(eye), "target": _floats(eye + forward / np.linalg.norm(forward)),
                    "fov": math.degrees(float(camera.perspective.yfov))}
        return None

    def _sky(self) -> Sky | None:
        holders = []
        if self.doc.scenes:
            holders.append(self.doc.scenes[self.doc.scene if self.doc.scene is not None else 0].extras)
        holders.append(self.doc.asset.extras if self.doc.asset else None)
        for extras in holders:
            spec = ((extras or {}).get("patchlight") or {}).get("sky") if isinstance(extras, dict) else None
            if spec is not None:
                return self._parse_sky(spec)
        return None

    def _parse_sky(self, spec) -> Sky:
        bad = self.fail("extras.patchlight.sky must hold one of 'uniform', 'gradient' or 'image'")
        if not isinstance(spec, dict) or len(spec) != 1:
            raise bad
        (kind, value), = spec.items()

        def radiance(rgb, what):
            color = self.vector(rgb, None, 3, f"sky {what}")
            if not np.all(color >= 0):
                raise self.fail(f"sky {what}: want three non-negative numbers")
            return color

        if kind == "uniform":
            return Sky.uniform(radiance(value, "uniform"))
        if kind == "gradient":
            if not isinstance(value, dict):
                raise bad
            return Sky.gradient(*(radiance(value.get(k), f"gradient.{k}") for k in ("zenith", "horizon", "ground")))
        if kind == "image" and isinstance(value, str):
            return Sky.from_image(read_environment(self.path.parent / value), source=str(self.path.parent / value))
        raise bad


def _attribute_map(primitive: gl.Primitive) -> dict[str, int]:
    raw = primitive.attributes
    items = vars(raw) if isinstance(raw, gl.Attributes) else dict(raw or {})
    return {name: index for name, index in items.items() if index is not None}


def _quaternion_matrix(q: np.ndarray) -> np.ndarray:
    """(4, 4) rotation from a non-zero glTF quaternion [x, y, z, w] (normalised here)."""
    x, y, z, w = np.asarray(q, np.float64) / np.linalg.norm(np.asarray(q, np.float64))
    matrix = np.eye(4)
    matrix[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return matrix


def _unit_rows(v: np.ndarray) -> np.ndarray:
    """Rows scaled to unit length (zero rows stay zero), float32."""
    length = np.linalg.norm(v, axis=1, keepdims=True)
    return np.divide(v, length, out=np.zeros_like(v, np.float64), where=length > 0).astype(np.float32)


def _degenerate(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(T,) bool: a repeated vertex index, or an area below float32 precision."""
    repeated = ((triangles[:, 0] == triangles[:, 1]) | (triangles[:, 1] == triangles[:, 2])
                | (triangles[:, 0] == triangles[:, 2]))
    corners = positions[triangles].astype(np.float64)
    edges = corners[:, [1, 2, 0]] - corners
    twice_area = np.linalg.norm(np.cross(edges[:, 0], -edges[:, 2]), axis=1)
    longest = (edges ** 2).sum(axis=2).max(axis=1)
    return repeated | (twice_area <= _DEGENERATE_SINE * longest)


def _fill_colors(blocks: list[_Block]) -> np.ndarray | None:
    """RGBA colours for every vertex when any primitive has COLOR_0 (white where it is missing)."""
    if all(b.colors is None for b in blocks):
        return None
    return np.concatenate([b.colors if b.colors is not None else np.ones((len(b.positions), 4), np.float32)
                           for b in blocks])


def _rgba(image: np.ndarray) -> np.ndarray:
    """(H, W, C) grey, grey+alpha, RGB or RGBA -> a new (H, W, 4) float32 array."""
    channels = image.shape[2]
    if channels in (1, 2):
        rgb, alpha = np.repeat(image[..., :1], 3, axis=2), image[..., 1:] if channels == 2 else None
    else:
        rgb, alpha = image[..., :3], image[..., 3:] if channels == 4 else None
    if alpha is None:
        alpha = np.ones(image.shape[:2] + (1,), np.float32)
    return np.concatenate([rgb, alpha], axis=2).astype(np.float32)


# =========================================================================== export

def save_baked_glb(scene: Scene, path, lightmap: EncodedLightmap | None = None,
                   lightmap_meta: dict | None = None, unlit: bool = False, folder=None,
                   extras: dict | None = None) -> Path:
    """Write `scene` (and its lightmap, if given) as one .glb, atomically; returns the path.

    lightmap_meta: JSON-able dict stored with the lightmap's description in the root extras.
    extras: JSON-able dict merged into the root extras.patchlight.  Layout: see the module docstring.
    unlit: mark every material KHR_materials_unlit (used, not required): the light is baked
    into COLOR_0, so viewers must not light it again. folder: the directory the file will end
    up in, when it is written elsewhere first (a staging directory): an image sky's path is
    made relative to it. A scene loaded from a glTF file is written as that file's document
    plus TEXCOORD_1 (`_SourceWriter`); a built-in scene, or one whose provenance no longer
    describes it (or that the writer cannot map back), as the flattened world-space copy
    (`_GlbWriter`), with a warning.
    """
    if lightmap is not None:
        if scene.uv1 is None:
            raise ValueError("save_baked_glb: a lightmap needs scene.uv1 (TEXCOORD_1)")
        _lightmap_description(lightmap, lightmap_meta or {})  # refuse bad input before any work
    folder = Path(path).parent if folder is None else Path(folder)
    source, glb = _SourceWriter.open(scene), None
    if isinstance(source, _SourceWriter):
        try:
            glb = source.write(folder, lightmap, lightmap_meta or {}, unlit, extras or {})
        except (PatchlightError, ValueError) as exc:
            source = f"its file could not be rewritten ({exc})"
    if glb is None:
        if source is not None:
            warnings.warn(f"{scene.label}: {source}; {Path(path).name} written as a flattened copy", stacklevel=2)
        glb = _flattened_glb(scene, folder, lightmap, lightmap_meta or {}, unlit, extras or {})
    with atomic_path(path) as tmp:
        tmp.write_bytes(glb)
    return Path(path)


def _flattened_glb(scene: Scene, folder: Path, lightmap: EncodedLightmap | None, meta: dict, unlit: bool,
                   extras: dict) -> bytes:
    """The world-space soup as one .glb: one identity node and mesh per material."""
    writer = _GlbWriter()
    attributes = writer.vertex_attributes(scene)
    writer.doc.materials = [writer.material(m, unlit) for m in scene.materials]
    if unlit:
        writer.use_extension(UNLIT)
    nodes = writer.meshes(scene, attributes) + writer.lights(scene.lights) + writer.camera(scene.extras.get("camera"))
    sky = scene.sky.to_extras(folder) if scene.sky is not None else None
    writer.doc.scenes = [gl.Scene(name=scene.name, nodes=nodes, extras={"patchlight": {"sky": sky}} if sky else {})]
    writer.doc.scene = 0
    writer.doc.extras = {"patchlight": _jsonable(extras)} if extras else {}
    if lightmap is not None:
        writer.lightmap(lightmap, meta)
    return writer.finish()


class _GlbWriter:
    """Builds one pygltflib document whose single buffer is the GLB binary chunk."""

    def __init__(self):
        self.doc = gl.GLTF2(asset=gl.Asset(generator="patchlight", version="2.0"))
        self.blob = bytearray()

    def finish(self) -> bytes:
        self.doc.buffers = [gl.Buffer(byteLength=len(self.blob))]
        self.doc.set_binary_blob(bytes(self.blob))
        return b"".join(self.doc.save_to_bytes())

    def use_extension(self, name: str) -> None:
        if name not in self.doc.extensionsUsed:
            self.doc.extensionsUsed.append(name)

    def view(self, data: bytes, target: int | None = None) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        self.doc.bufferViews.append(gl.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(data),
                                                  target=target))
        self.blob += data
        return len(self.doc.bufferViews) - 1

    def accessor(self, array: np.ndarray, kind: str, target: int, bounds: bool = False) -> int:
        """A float32 vertex attribute or a uint32 index list, tightly packed."""
        array = np.ascontiguousarray(array)
        check_finite(array, f"scene.glb {kind} attribute")
        accessor = gl.Accessor(bufferView=self.view(array.tobytes(), target), count=len(array), type=kind,
                               componentType=_FLOAT if array.dtype == np.float32 else _UINT)
        if bounds:  # POSITION must carry its bounds
            accessor.min, accessor.max = array.min(axis=0).tolist(), array.max(axis=0).tolist()
        self.doc.accessors.append(accessor)
        return len(self.doc.accessors) - 1

    def vertex_attributes(self, scene: Scene) -> dict[str, int]:
        """Accessor per attribute, shared by every mesh."""
        def add(values, kind, bounds=False):
            return self.accessor(np.asarray(values, np.float32), kind, _ARRAY_BUFFER, bounds)

        attributes = {"POSITION": add(scene.positions, "VEC3", bounds=True),
                      "NORMAL": add(scene.normals, "VEC3"), "TEXCOORD_0": add(scene.uv0, "VEC2")}
        optional = {"TEXCOORD_1": (scene.uv1, "VEC2"), "COLOR_0": (scene.colors, "VEC4"),
                    "TANGENT": (scene.tangents, "VEC4")}
        attributes.update({name: add(values, kind) for name, (values, kind) in optional.items() if values is not None})
        return attributes

    def meshes(self, scene: Scene, attributes: dict[str, int]) -> list[int]:
        """One mesh (and one identity node) per material that has triangles; returns the node indices."""
        nodes = []
        for material_id, material in enumerate(scene.materials):
            triangles = scene.indices[scene.material_ids == material_id]
            if not len(triangles):
                continue
            indices = self.accessor(triangles.astype(np.uint32).ravel(), "SCALAR", _ELEMENT_ARRAY_BUFFER)
            primitive = gl.Primitive(attributes=gl.Attributes(**attributes), indices=indices,
                                     material=material_id, mode=_TRIANGLES)
            self.doc.meshes.append(gl.Mesh(name=material.name, primitives=[primitive]))
            self.doc.nodes.append(gl.Node(name=material.name, mesh=len(self.doc.meshes) - 1))
            nodes.append(len(self.doc.nodes) - 1)
        return nodes

    def texture(self, png: bytes, name: str | None = None, sampler: int | None = None) -> int:
        self.doc.images.append(gl.Image(bufferView=self.view(png), mimeType="image/png", name=name))
        self.doc.textures.append(gl.Texture(source=len(self.doc.images) - 1, sampler=sampler, name=name))
        return len(self.doc.textures) - 1

    def material(self, material: Material, unlit: bool = False) -> gl.Material:
        """The glTF material; unlit: KHR_materials_unlit, else a Lambertian surface (specular 0)."""
        peak = float(np.max(material.emissive))
        strength = peak if peak > 1.0 else 1.0  # emissiveFactor must stay in [0, 1]
        pbr = gl.PbrMetallicRoughness(baseColorFactor=_floats(material.base_color), metallicFactor=0.0,
                                      roughnessFactor=1.0)
        out = gl.Material(name=material.name, pbrMetallicRoughness=pbr, doubleSided=bool(material.double_sided),
                          emissiveFactor=_floats(material.emissive / np.float32(strength)),
                          extras={"shininess": float(material.shininess), "reflectivity": float(material.reflectivity)})
        shading = UNLIT if unlit else "KHR_materials_specular"
        out.extensions = {shading: {} if unlit else {"specularFactor": 0.0}}
        self.use_extension(shading)
        if strength > 1.0:
            out.extensions["KHR_materials_emissive_strength"] = {"emissiveStrength": strength}
            self.use_extension("KHR_materials_emissive_strength")
        if material.base_color_texture is not None:
            pbr.baseColorTexture = gl.TextureInfo(index=self.texture(_srgb_png(material.base_color_texture)))
        if material.emissive_texture is not None:
            out.emissiveTexture = gl.TextureInfo(index=self.texture(_srgb_png(material.emissive_texture)))
        if material.normal_texture is not None:
            raw = encode_png(_to_uint8(material.normal_texture))  # normal maps are linear data
            out.normalTexture = gl.NormalMaterialTexture(index=self.texture(raw))
        return out

    def lights(self, lights: list[Light]) -> list[int]:
        """KHR_lights_punctual definitions in photometric units and one oriented node each."""
        nodes, specs = [], []
        for number, light in enumerate(lights):
            spec = {"type": light.kind, "color": _floats(light.color),
                    "intensity": float(light.intensity) * LUMENS_PER_WATT}
            if light.name:
                spec["name"] = light.name
            if light.range is not None:
                spec["range"] = float(light.range)
            if light.kind == "spot":
                spec["spot"] = {"innerConeAngle": float(light.inner_cone), "outerConeAngle": float(light.outer_cone)}
            extras = {"falloff": light.falloff, "angle": float(light.angle) if light.angle else None}
            spec["extras"] = {**{k: v for k, v in extras.items() if v is not None}, "baked": bool(light.baked)}
            specs.append(spec)
            self.doc.nodes.append(gl.Node(name=light.name or f"light_{number}", translation=_floats(light.position),
                                          rotation=_rotation_onto(light.direction),
                                          extensions={"KHR_lights_punctual": {"light": number}}))
            nodes.append(len(self.doc.nodes) - 1)
        if specs:
            self.doc.extensions["KHR_lights_punctual"] = {"lights": specs}
            self.use_extension("KHR_lights_punctual")
        return nodes

    def camera(self, camera: dict | None) -> list[int]:
        """A perspective camera node looking from camera["eye"] at camera["target"]."""
        if not camera:
            return []
        eye = np.asarray(camera["eye"], np.float64)
        self.doc.cameras.append(gl.Camera(type="perspective", perspective=gl.Perspective(
            yfov=math.radians(float(camera.get("fov", 60.0))), znear=0.01)))
        self.doc.nodes.append(gl.Node(name="camera", camera=len(self.doc.cameras) - 1, translation=_floats(eye),
                                      rotation=_look_rotation(np.asarray(camera["target"], np.float64) - eye)))
        return [len(self.doc.nodes) - 1]

    def lightmap(self, lightmap: EncodedLightmap, meta: dict) -> None:
        """The lightmap as texture "patchlight_lightmap" (PNG source, .hdr through MOZ_texture_rgbe),
        MOZ_lightmap on every material, and its description in the root extras."""
        description = _lightmap_description(lightmap, meta)
        self.doc.samplers.append(gl.Sampler(**_LIGHTMAP_SAMPLER))
        texture = self.texture(lightmap.png, LIGHTMAP_NAME, sampler=len(self.doc.samplers) - 1)
        self.doc.images.append(gl.Image(bufferView=self.view(lightmap.hdr), mimeType=HDR_MIME, name=LIGHTMAP_HDR_NAME))
        self.doc.textures[texture].extensions = {MOZ_RGBE: {"source": len(self.doc.images) - 1}}
        for material in self.doc.materials:
            material.extensions = {**(material.extensions or {}), MOZ_LIGHTMAP: _lightmap_reference(texture, lightmap)}
        for name in (MOZ_LIGHTMAP, MOZ_RGBE):
            self.use_extension(name)
        description["texture"] = texture
        self.doc.extras = {"patchlight": {**self.doc.extras.get("patchlight", {}), "lightmap": description}}


LIGHTMAP_NAME = "patchlight_lightmap"
LIGHTMAP_HDR_NAME = "patchlight_lightmap_hdr"
_LIGHTMAP_SAMPLER = {"magFilter": _LINEAR_FILTER, "minFilter": _LINEAR_FILTER,
                     "wrapS": _CLAMP_TO_EDGE, "wrapT": _CLAMP_TO_EDGE}


def _lightmap_description(lightmap: EncodedLightmap, meta: dict) -> dict:
    """extras.patchlight.lightmap without its "texture" index; ValueError for bad images or scale."""
    if not lightmap.png.startswith(b"\x89PNG\r\n\x1a\n") or not lightmap.hdr.startswith(b"#?"):
        raise ValueError("save_baked_glb: the lightmap needs PNG and Radiance .hdr bytes")
    if not 0 < lightmap.scale < math.inf:
        raise ValueError(f"save_baked_glb: the lightmap's scale must be positive, got {lightmap.scale!r}")
    return {**_jsonable(meta), "texture": None, "texCoord": 1, "scale": lightmap.scale,
            "intensity": _lightmap_intensity(lightmap)}


def _lightmap_intensity(lightmap: EncodedLightmap) -> float:
    """MOZ_lightmap's intensity: texel x scale is I; three.js's lightMap is irradiance pi I."""
    return math.pi * lightmap.scale


def _lightmap_reference(texture: int, lightmap: EncodedLightmap) -> dict:
    """A material's MOZ_lightmap extension."""
    return {"index": texture, "texCoord": 1, "intensity": _lightmap_intensity(lightmap)}


class _SourceWriter:
    """scene.glb as the input document: every node, material, texture, sampler, image (its
    bytes as they were), camera, light, skin, animation, extra and extension kept; each mesh
    instance's triangle primitives rewritten in the primitive's local space with the vertices
    the lightmap UVs split (vertex v of the scene is element `provenance.vertex_source[v]` of
    the file's accessors), TEXCOORD_1 added; a mesh drawn by several nodes gets one copy per
    further node, "<mesh> (lightmap k)", because each instance has its own lightmap region.

    A vertex block is what the loader flattened as one: the vertices of one set of attribute
    accessors under one world matrix (`owner`: the first node with both; nodes drawing the same
    mesh at the same place share it).  A block whose scene vertices are exactly its accessors'
    elements, each once (no split: the file's own TEXCOORD_1 was used), keeps its accessors
    and indices; only an attribute whose values changed (TEXCOORD_1, COLOR_0 after
    `vertexbake`) gets a new accessor.  Otherwise its attributes (morph targets, JOINTS and
    WEIGHTS included) are copied through vertex_source in their stored component types and its
    primitives get new uint16/uint32 triangle lists (mode 4, the file's winding).
    """

    def __init__(self, scene: Scene, path: Path, raw: dict, importer: "_Importer"):
        self.scene, self.path, self.raw, self.importer = scene, path, raw, importer
        self.provenance = scene.provenance
        for key in ("accessors", "bufferViews", "meshes", "nodes", "images", "textures", "samplers"):
            if not isinstance(raw.get(key, []), list):
                raise ValueError(f"'{key}' is not a list")
            raw.setdefault(key, [])
        self.source_views = len(raw["bufferViews"])
        self.new_views: list[bytes] = []  # bytes of bufferViews source_views, source_views + 1, ...
        self.instances = {node: world for node, world in importer._instances()}  # traversal order
        self.set_id: dict[tuple, int] = {}      # accessor set (sorted attribute pairs) -> number
        self.sets: dict[tuple[int, int], int] = {}  # (mesh, primitive) -> accessor set number
        self.owner: dict[tuple[bytes, int], int] = {}  # (world matrix, set) -> node of the loader's block
        self._blocks: list[_VertexBlock] | None = None

    # ------------------------------------------------------------------ opening, and checking the provenance

    @classmethod
    def open(cls, scene: Scene) -> "_SourceWriter | str | None":
        """A writer for a scene loaded from glTF; None for a scene without provenance; a reason
        (str) when the provenance does not describe the scene or the file has changed."""
        provenance = scene.provenance
        if provenance is None:
            return None
        path = Path(provenance.path)
        if not provenance.fits(len(scene.positions), scene.n_triangles):
            return "its provenance no longer matches its vertices and triangles"
        if _file_stamp(path) != provenance.stamp:
            return f"{path} has changed (or gone) since it was loaded"
        try:
            data = read_bytes(path)
            text, blob = _split_glb(data, path) if data[:4] == _GLB_MAGIC else (_json_text(data, path), None)
            doc = gl.GLTF2.from_json(text, infer_missing=True)
            writer = cls(scene, path, json.loads(text), _Importer(path, doc, blob))
            reason = writer.mismatch()
        except (PatchlightError, TypeError, ValueError, AttributeError, KeyError, IndexError) as exc:
            return f"{path} cannot be mapped back ({exc})"
        return reason or writer

    def mismatch(self) -> str | None:
        """Why the provenance does not describe the scene (None when it does): nodes, meshes,
        primitives, accessor sets, materials and world-space positions must all agree."""
        p, doc, scene = self.provenance, self.importer.doc, self.scene
        nodes, meshes = doc.nodes or [], doc.meshes or []
        for node in np.unique(np.concatenate([p.triangle_node, p.vertex_node])):
            if node not in self.instances or nodes[node].mesh is None:
                return f"node {node} is not a mesh node of the scene"
        self.node_mesh = np.array([-1 if n.mesh is None else n.mesh for n in nodes], np.int64)
        if not np.array_equal(self.node_mesh[p.triangle_node], p.triangle_mesh):
            return "a triangle's mesh is not its node's"
        widest = max([len(mesh.primitives or []) for mesh in meshes], default=0)
        set_table = np.full((len(meshes) + 1, widest + 1), -1, np.int64)  # (mesh, primitive) -> set; -1: none
        material_table = np.full_like(set_table, -1)
        default_material = len(doc.materials or [])
        for m, mesh in enumerate(meshes):
            for k, primitive in enumerate(mesh.primitives or []):
                self.sets[m, k] = self.set_id.setdefault(tuple(sorted(_attribute_map(primitive).items())),
                                                         len(self.set_id))
                set_table[m, k] = self.sets[m, k]
                material_table[m, k] = default_material if primitive.material is None else primitive.material
        for node, world in self.instances.items():  # the loader's blocks: one per world matrix and set
            mesh = nodes[node].mesh
            for k, primitive in enumerate(meshes[mesh].primitives or [] if mesh is not None else []):
                if (_TRIANGLES if primitive.mode is None else primitive.mode) not in _POINTS_AND_LINES:
                    self.owner.setdefault((world.tobytes(), self.sets[mesh, k]), node)
        vertex_mesh = self.node_mesh[p.vertex_node]
        if not (np.all((0 <= p.triangle_primitive) & (p.triangle_primitive <= widest))
                and np.all((0 <= p.vertex_primitive) & (p.vertex_primitive <= widest))):
            return "a primitive index is past its mesh's primitives"
        self.tri_set = set_table[p.triangle_mesh, p.triangle_primitive]
        self.vertex_set = set_table[vertex_mesh, p.vertex_primitive]
        if self.tri_set.min() < 0 or self.vertex_set.min() < 0:
            return "a primitive index is past its mesh's primitives"
        pairs, inverse = np.unique(np.stack([p.triangle_node, self.tri_set], axis=1), axis=0, return_inverse=True)
        tri_owner = np.array([self.owner.get((self.instances[n].tobytes(), a), -1) for n, a in pairs.tolist()],
                             np.int64)[inverse.ravel()]
        corners = scene.indices
        if not (np.all(p.vertex_node[corners] == tri_owner[:, None])
                and np.all(self.vertex_set[corners] == self.tri_set[:, None])):
            return "a triangle's corners are not vertices of its primitive's accessors"
        if not np.array_equal(material_table[p.triangle_mesh, p.triangle_primitive], scene.material_ids):
            return "a triangle's material is not its primitive's"
        for block in self.blocks():
            local = self.local_positions(block)
            if local is None:
                return f"vertex indices past the accessors of node {block.node}"
            world = self.instances[block.node]
            expected = local @ world[:3, :3].T + world[:3, 3]
            size = float(np.abs(expected).max(initial=0.0)) + 1.0
            if not np.allclose(scene.positions[block.vertices], expected, rtol=0.0, atol=1e-5 * size):
                return f"vertex positions of node {block.node} are not its mesh's under its transform"
        return None

    def blocks(self) -> list["_VertexBlock"]:
        """The scene's vertices grouped by (owner node, accessor set), each in scene order."""
        if self._blocks is None:
            p = self.provenance
            key = p.vertex_node.astype(np.int64) * (len(self.set_id) + 1) + self.vertex_set
            order = np.argsort(key, kind="stable")
            starts = np.flatnonzero(np.diff(key[order], prepend=-1))
            self._blocks = []
            for vertices in np.split(order, starts[1:]):
                first = int(vertices[0])
                node, primitive = int(p.vertex_node[first]), int(p.vertex_primitive[first])
                attributes = _attribute_map(self.importer.doc.meshes[self.node_mesh[node]].primitives[primitive])
                self._blocks.append(_VertexBlock(node, int(self.vertex_set[first]), attributes, vertices,
                                                 p.vertex_source[vertices].astype(np.int64)))
        return self._blocks

    def local_positions(self, block: "_VertexBlock") -> np.ndarray | None:
        """(n, 3) f64 local POSITION of the block's vertices, or None if an index is out of range."""
        positions = self.importer.floats(block.attributes["POSITION"], (3,), f"node {block.node} POSITION")
        if block.sources.size and (block.sources.min() < 0 or block.sources.max() >= len(positions)):
            return None
        block.count = len(positions)
        return positions[block.sources].astype(np.float64)

    # ------------------------------------------------------------------ the document

    def write(self, folder: Path, lightmap: EncodedLightmap | None, meta: dict, unlit: bool = False,
              extras: dict | None = None) -> bytes:
        """The .glb bytes; folder: where it will live (image sky paths are relative to it)."""
        primitives = self.rewritten_primitives()
        self.assign_meshes(primitives)
        self.drop_unused_draco()
        self.root_extras(extras or {})
        if lightmap is not None:
            self.lightmap(lightmap, meta, primitives)
        if unlit:
            self.mark_unlit()
        self.mark_lights()
        self.sky(folder)
        self.embed_external_images()
        self.compact()
        return self.container()

    def root_extras(self, extras: dict) -> None:
        """`extras` merged into the root extras.patchlight."""
        if not extras:
            return
        raw = self.raw
        root = raw.get("extras") if isinstance(raw.get("extras"), dict) else {}
        patchlight = root.get("patchlight") if isinstance(root.get("patchlight"), dict) else {}
        raw["extras"] = {**root, "patchlight": {**patchlight, **_jsonable(extras)}}

    def mark_lights(self) -> None:
        """extras.baked on every light definition a scene light came from."""
        definitions = ((self.raw.get("extensions") or {}).get("KHR_lights_punctual") or {}).get("lights") or []
        for light in self.scene.lights:
            if light.source is not None and 0 <= light.source < len(definitions):
                spec = definitions[light.source]
                extras = spec.get("extras") if isinstance(spec.get("extras"), dict) else {}
                spec["extras"] = {**extras, "baked": bool(light.baked)}

    def mark_unlit(self) -> None:
        """KHR_materials_unlit on every material, listed as used (not required); the light is in
        COLOR_0, so an earlier bake's MOZ_lightmap references and description go."""
        for material in self.raw.get("materials") or []:
            material.setdefault("extensions", {})[UNLIT] = {}
            material["extensions"].pop(MOZ_LIGHTMAP, None)
        if MOZ_LIGHTMAP in (self.raw.get("extensionsUsed") or []):
            self.raw["extensionsUsed"].remove(MOZ_LIGHTMAP)
        patchlight = (self.raw.get("extras") or {}).get("patchlight")
        if isinstance(patchlight, dict):
            patchlight.pop("lightmap", None)
        if self.raw.get("materials") and UNLIT not in self.raw.setdefault("extensionsUsed", []):
            self.raw["extensionsUsed"].append(UNLIT)

    def rewritten_primitives(self) -> dict[int, list[dict]]:
        """node -> its mesh's primitives (JSON) as this instance writes them."""
        p, scene = self.provenance, self.scene
        by_block = {(b.node, b.set): b for b in self.blocks()}
        tri_key = p.triangle_node.astype(np.int64) * (int(p.triangle_primitive.max(initial=0)) + 1) + p.triangle_primitive
        order = np.argsort(tri_key, kind="stable")
        starts = np.flatnonzero(np.diff(tri_key[order], prepend=-1))
        triangles_of = {(int(p.triangle_node[t[0]]), int(p.triangle_primitive[t[0]])): t
                        for t in np.split(order, starts[1:]) if len(t)}
        touched = set(p.triangle_mesh.tolist()) | set(self.node_mesh[p.vertex_node].tolist())
        out = {}
        for node in (n for n in self.instances if self.node_mesh[n] in touched):
            mesh = int(self.node_mesh[node])
            flip = np.linalg.det(self.instances[node][:3, :3]) < 0
            written = []
            world = self.instances[node].tobytes()
            for k, primitive in enumerate(self.raw["meshes"][mesh].get("primitives") or []):
                block = by_block.get((self.owner.get((world, self.sets[mesh, k])), self.sets[mesh, k]))
                triangles = triangles_of.get((node, k))
                if block is None or primitive.get("mode", _TRIANGLES) in _POINTS_AND_LINES:
                    # points or lines: not lightmapped, kept as they were
                    written.append(primitive)
                    continue
                prepared = self.block_attributes(block)
                if block.same_layout:
                    written.append({**primitive, "attributes": {**primitive["attributes"], **prepared}})
                elif triangles is None:  # every triangle degenerate: nothing to light, kept as it was
                    written.append(primitive)
                else:
                    corners = scene.indices[triangles]
                    corners = corners[:, [0, 2, 1]] if flip else corners
                    rows = np.searchsorted(block.vertices, corners.ravel())
                    written.append(self.split_primitive(primitive, prepared, block, rows, mesh, k))
            out[node] = written
        return out

    def block_attributes(self, block: "_VertexBlock") -> dict[str, int]:
        """Accessors for the block's attributes that change (no split) or all of them (split); cached."""
        if block.prepared is not None:
            return block.prepared
        scene, importer = self.scene, self.importer
        if block.count is None:
            self.local_positions(block)
        block.same_layout = (len(block.sources) == block.count
                             and np.array_equal(np.sort(block.sources), np.arange(block.count)))
        if block.same_layout:  # values in the accessors' element order
            rows = np.empty(block.count, np.int64)
            rows[block.sources] = block.vertices
        else:
            rows = block.vertices
        prepared = {}
        if scene.uv1 is not None:
            uv1 = np.ascontiguousarray(scene.uv1[rows], np.float32)
            own = block.attributes.get("TEXCOORD_1")
            if not (block.same_layout and own is not None
                    and importer.floats(own, (2,), "TEXCOORD_1").tobytes() == uv1.tobytes()):
                prepared["TEXCOORD_1"] = self.add_accessor(uv1, _FLOAT, "VEC2", vertex=True)
                if "TEXCOORD_0" not in block.attributes:  # glTF wants TEXCOORD_n numbered from 0
                    prepared["TEXCOORD_0"] = self.add_accessor(np.zeros_like(uv1), _FLOAT, "VEC2", vertex=True)
        if scene.colors is not None:
            colors = np.ascontiguousarray(scene.colors[rows], np.float32)
            own = block.attributes.get("COLOR_0")
            if own is None:
                loaded = np.ones((block.count, 4), np.float32)
            else:
                loaded = importer.floats(own, (3, 4), "COLOR_0")
                if loaded.shape[1] == 3:
                    loaded = np.concatenate([loaded, np.ones((len(loaded), 1), np.float32)], axis=1)
            expected = loaded if block.same_layout else loaded[block.sources]
            if colors.tobytes() != np.ascontiguousarray(expected, np.float32).tobytes():  # vertexbake's light
                prepared["COLOR_0"] = self.add_accessor(colors, _FLOAT, "VEC4", vertex=True)
        if not block.same_layout:
            for name, index in block.attributes.items():
                if name not in prepared:
                    prepared[name] = self.copy_accessor(index, block.sources, bounds=name == "POSITION")
        block.prepared = prepared
        return prepared

    def split_primitive(self, primitive: dict, prepared: dict, block: "_VertexBlock", rows: np.ndarray,
                        mesh: int, k: int) -> dict:
        """A primitive over the block's split vertices: new attributes, morph targets and triangle list."""
        out = {key: value for key, value in primitive.items() if key not in ("attributes", "indices", "mode", "targets")}
        out["attributes"] = {name: prepared[name] for name in primitive["attributes"]}
        out["attributes"].update({name: prepared[name] for name in ("TEXCOORD_0", "TEXCOORD_1", "COLOR_0")
                                  if name in prepared})
        if primitive.get("targets"):
            if block.targets is None or block.targets[0] != (mesh, k):
                block.targets = ((mesh, k), [{name: self.copy_accessor(index, block.sources, bounds=name == "POSITION")
                                              for name, index in target.items()} for target in primitive["targets"]])
            out["targets"] = block.targets[1]
        component = 5123 if len(block.vertices) < 65535 else _UINT
        out["indices"] = self.add_accessor(rows.astype(np.uint16 if component == 5123 else np.uint32).reshape(-1, 1),
                                           component, "SCALAR", vertex=False)
        extensions = {key: value for key, value in (primitive.get("extensions") or {}).items()
                      if key != "KHR_draco_mesh_compression"}  # the compressed data is the old vertices
        if extensions:
            out["extensions"] = extensions
        else:
            out.pop("extensions", None)
        return out

    def assign_meshes(self, primitives: dict[int, list[dict]]) -> None:
        """Each node's primitives into its mesh: the first instance of a mesh rewrites it, every
        further instance whose primitives differ gets a copy named "<mesh> (lightmap k)"."""
        meshes, nodes = self.raw["meshes"], self.raw["nodes"]
        instances: dict[int, list[int]] = {}
        for node in self.instances:  # traversal order
            if node in primitives:
                instances.setdefault(int(self.node_mesh[node]), []).append(node)
        for mesh, users in instances.items():
            original = meshes[mesh]
            meshes[mesh] = {**original, "primitives": primitives[users[0]]}
            for number, node in enumerate(users[1:], start=2):
                if primitives[node] == primitives[users[0]]:
                    continue  # nothing of this instance changed: it keeps sharing the mesh
                name = f"{original.get('name') or f'mesh {mesh}'} (lightmap {number})"
                meshes.append({**json.loads(json.dumps(original)), "name": name, "primitives": primitives[node]})
                nodes[node]["mesh"] = len(meshes) - 1

    def drop_unused_draco(self) -> None:
        name = "KHR_draco_mesh_compression"
        if any(name in (p.get("extensions") or {}) for m in self.raw["meshes"] for p in m.get("primitives") or []):
            return
        for key in ("extensionsUsed", "extensionsRequired"):
            if name in (self.raw.get(key) or []):
                self.raw[key] = [e for e in self.raw[key] if e != name]
                if not self.raw[key]:
                    del self.raw[key]

    # ------------------------------------------------------------------ lightmap, sky, images

    def lightmap(self, lightmap: EncodedLightmap, meta: dict, primitives: dict[int, list[dict]]) -> None:
        """The lightmap: the texture an earlier bake left (re-baking a scene.glb) gets the new
        images, else a new texture "patchlight_lightmap" (PNG source, .hdr through
        MOZ_texture_rgbe); MOZ_lightmap on the materials of the triangle primitives written;
        root extras.patchlight.lightmap."""
        raw = self.raw
        description = _lightmap_description(lightmap, meta)
        extras = raw.get("extras") if isinstance(raw.get("extras"), dict) else {}
        patchlight = extras.get("patchlight") if isinstance(extras.get("patchlight"), dict) else {}
        old = (patchlight.get("lightmap") or {}).get("texture") if isinstance(patchlight.get("lightmap"), dict) else None
        textures, images = raw["textures"], raw["images"]
        png = {"name": LIGHTMAP_NAME, "bufferView": self.add_view(lightmap.png), "mimeType": "image/png"}
        hdr = {"name": LIGHTMAP_HDR_NAME, "bufferView": self.add_view(lightmap.hdr), "mimeType": HDR_MIME}
        if (isinstance(old, int) and 0 <= old < len(textures) and textures[old].get("name") == LIGHTMAP_NAME
                and isinstance(textures[old].get("source"), int) and 0 <= textures[old]["source"] < len(images)):
            texture = old
            images[textures[old]["source"]] = png
            source = ((textures[old].get("extensions") or {}).get(MOZ_RGBE) or {}).get("source")
            if isinstance(source, int) and 0 <= source < len(images) and images[source].get("name") == LIGHTMAP_HDR_NAME:
                images[source] = hdr
            else:
                images.append(hdr)
                source = len(images) - 1
        else:
            raw["samplers"].append(dict(_LIGHTMAP_SAMPLER))
            images += [png, hdr]
            textures.append({"name": LIGHTMAP_NAME, "sampler": len(raw["samplers"]) - 1, "source": len(images) - 2})
            texture, source = len(textures) - 1, len(images) - 1
        textures[texture]["extensions"] = {**(textures[texture].get("extensions") or {}), MOZ_RGBE: {"source": source}}
        materials = raw.get("materials") or []
        lit = {p["material"] for written in primitives.values() for p in written
               if p.get("mode", _TRIANGLES) not in _POINTS_AND_LINES and isinstance(p.get("material"), int)}
        for number in sorted(m for m in lit if 0 <= m < len(materials)):
            materials[number]["extensions"] = {**(materials[number].get("extensions") or {}),
                                               MOZ_LIGHTMAP: _lightmap_reference(texture, lightmap)}
        used = raw.setdefault("extensionsUsed", [])
        used += [name for name in (MOZ_LIGHTMAP, MOZ_RGBE) if name not in used]
        description["texture"] = texture
        raw["extras"] = {**extras, "patchlight": {**patchlight, "lightmap": description}}

    def sky(self, folder: Path) -> None:
        """The bake's sky in extras.patchlight.sky of the scene the loader reads (that scene's
        extras, else asset.extras); an image sky of unknown file clears the old entry."""
        raw, sky = self.raw, self.scene.sky
        spec = None if sky is None else sky.to_extras(folder)
        scenes = raw.get("scenes") if isinstance(raw.get("scenes"), list) else []
        chosen = raw.get("scene", 0) if scenes else None
        holders = [scenes[chosen]] if scenes else []
        holders.append(raw.setdefault("asset", {}))
        for number, holder in enumerate(holders):
            extras = holder.get("extras", {})
            if not isinstance(extras, dict):
                continue
            patchlight = extras.get("patchlight", {})
            if not isinstance(patchlight, dict):
                continue
            if number == 0 and spec is not None:
                holder["extras"] = {**extras, "patchlight": {**patchlight, "sky": spec}}
            elif "sky" in patchlight:
                rest = {k: v for k, v in patchlight.items() if k != "sky"}
                holder["extras"] = {**extras, "patchlight": rest} if rest else {k: v for k, v in extras.items()
                                                                              if k != "patchlight"}
                if not holder["extras"]:
                    del holder["extras"]

    def embed_external_images(self) -> None:
        """Images in files beside a .gltf that a texture uses move into the .glb, their bytes
        unchanged (a data: URI stays as it is; an image that cannot be read, or that nothing
        uses, keeps its uri and is never read)."""
        used = _used_images(self.raw)
        for number, image in enumerate(self.raw["images"]):
            uri = image.get("uri")
            if not isinstance(uri, str) or uri.startswith("data:") or number not in used:
                continue
            try:
                data = self.importer._resource(uri, f"image {number}")
            except PatchlightError:
                continue
            mime = image.get("mimeType") or _image_mime(data)
            if mime is None:
                continue
            del image["uri"]
            image.update(bufferView=self.add_view(data), mimeType=mime)

    # ------------------------------------------------------------------ accessors, views and the container

    def add_view(self, data: bytes, target: int | None = None, stride: int | None = None) -> int:
        view = {"buffer": 0, "byteLength": len(data)}
        if stride is not None:
            view["byteStride"] = stride
        if target is not None:
            view["target"] = target
        self.raw["bufferViews"].append(view)
        self.new_views.append(bytes(data))
        return len(self.raw["bufferViews"]) - 1

    def add_accessor(self, values: np.ndarray, component: int, kind: str, vertex: bool, normalized: bool = False,
                     bounds: bool = False) -> int:
        """values (n, width) in the component type; vertex attributes padded to 4-byte elements."""
        values = np.ascontiguousarray(values)
        check_finite(values, f"{self.path.name}: a {kind} attribute")
        element = values.shape[1] * values.itemsize
        stride = None
        if vertex and element % 4:
            stride = element + (-element % 4)
            padded = np.zeros((len(values), stride), np.uint8)
            padded[:, :element] = values.view(np.uint8).reshape(len(values), element)
            data = padded.tobytes()
        else:
            data = values.tobytes()
        accessor = {"bufferView": self.add_view(data, _ARRAY_BUFFER if vertex else _ELEMENT_ARRAY_BUFFER, stride),
                    "componentType": component, "count": len(values), "type": kind}
        if normalized:
            accessor["normalized"] = True
        if bounds and len(values):
            cast = float if component == _FLOAT else int
            accessor["min"] = [cast(v) for v in values.min(axis=0)]
            accessor["max"] = [cast(v) for v in values.max(axis=0)]
        self.raw["accessors"].append(accessor)
        return len(self.raw["accessors"]) - 1

    def copy_accessor(self, index: int, sources: np.ndarray, bounds: bool) -> int:
        """A new vertex accessor holding elements `sources` of accessor `index`, same component
        type, type and normalization (sparse substitutions applied)."""
        original = self.raw["accessors"][index]
        if original.get("type") not in _TYPE_WIDTHS:
            raise PatchlightError(f"{self.path}: accessor {index} of type {original.get('type')!r} "
                                  f"cannot be a vertex attribute")
        values = self.importer.accessor(index)[sources]
        return self.add_accessor(values, original["componentType"], original["type"], vertex=True,
                                 normalized=bool(original.get("normalized")),
                                 bounds=bounds or "min" in original or "max" in original)

    def compact(self) -> None:
        """Drop accessors and bufferViews nothing refers to any more (the replaced vertices), and
        renumber the references.  Skipped when the file uses an extension whose references to
        accessors or views this writer does not know: then everything stays, unused or not."""
        raw = self.raw
        used_extensions = set(raw.get("extensionsUsed") or [])
        if any(not (e in _KNOWN_EXTENSIONS or e.startswith("KHR_materials_")) for e in used_extensions):
            self.view_order = list(range(len(raw["bufferViews"])))
            return
        references = _distinct(self.accessor_references())
        referenced = sorted({holder[key] for holder, key in references})
        accessor_map = {old: new for new, old in enumerate(referenced)}
        for holder, key in references:
            holder[key] = accessor_map[holder[key]]
        raw["accessors"] = [raw["accessors"][old] for old in referenced]
        references = _distinct(self.view_references())
        views = sorted({holder[key] for holder, key in references})
        view_map = {old: new for new, old in enumerate(views)}
        for holder, key in references:
            holder[key] = view_map[holder[key]]
        self.view_order = views
        raw["bufferViews"] = [raw["bufferViews"][old] for old in views]

    def accessor_references(self):
        """(holder dict, key) of every accessor reference this writer knows."""
        raw = self.raw
        for mesh in raw["meshes"]:
            for primitive in mesh.get("primitives") or []:
                yield from ((primitive["attributes"], name) for name in primitive.get("attributes") or {})
                if primitive.get("indices") is not None:
                    yield primitive, "indices"
                for target in primitive.get("targets") or []:
                    yield from ((target, name) for name in target)
        for skin in raw.get("skins") or []:
            if skin.get("inverseBindMatrices") is not None:
                yield skin, "inverseBindMatrices"
        for animation in raw.get("animations") or []:
            for sampler in animation.get("samplers") or []:
                yield from ((sampler, key) for key in ("input", "output") if key in sampler)
        for node in raw["nodes"]:
            instancing = (node.get("extensions") or {}).get("EXT_mesh_gpu_instancing") or {}
            attributes = instancing.get("attributes") or {}
            yield from ((attributes, name) for name in attributes)

    def view_references(self):
        raw = self.raw
        for accessor in raw["accessors"]:
            if accessor.get("bufferView") is not None:
                yield accessor, "bufferView"
            sparse = accessor.get("sparse") or {}
            for part in ("indices", "values"):
                if (sparse.get(part) or {}).get("bufferView") is not None:
                    yield sparse[part], "bufferView"
        for image in raw["images"]:
            if image.get("bufferView") is not None:
                yield image, "bufferView"
        for mesh in raw["meshes"]:
            for primitive in mesh.get("primitives") or []:
                draco = (primitive.get("extensions") or {}).get("KHR_draco_mesh_compression") or {}
                if draco.get("bufferView") is not None:
                    yield draco, "bufferView"

    def container(self) -> bytes:
        """The GLB: the JSON chunk and one BIN chunk holding every bufferView, 8-byte aligned."""
        blob = bytearray()
        for view, old in zip(self.raw["bufferViews"], self.view_order):
            data = self.new_views[old - self.source_views] if old >= self.source_views else \
                bytes(self.importer.view_bytes(old))
            blob += b"\0" * (-len(blob) % 8)
            view.update(buffer=0, byteOffset=len(blob), byteLength=len(data))
            blob += data
        blob += b"\0" * (-len(blob) % 4)
        self.raw["buffers"] = [{"byteLength": len(blob)}] if blob else []
        if not self.raw["buffers"]:
            del self.raw["buffers"]
        for key in ("accessors", "bufferViews", "meshes", "nodes", "images", "textures", "samplers"):
            if not self.raw[key]:  # glTF forbids empty top-level arrays
                del self.raw[key]
        text = json_text(self.raw, "scene.glb", indent=None).encode("utf-8")
        text += b" " * (-len(text) % 4)
        chunks = struct.pack("<II", len(text), _CHUNK_JSON) + text
        if blob:
            chunks += struct.pack("<II", len(blob), _CHUNK_BIN) + bytes(blob)
        return _GLB_MAGIC + struct.pack("<II", 2, 12 + len(chunks)) + chunks


@dataclass
class _VertexBlock:
    """The scene vertices of one accessor set under one node: vertices (n,) scene indices,
    ascending; sources (n,) their elements in the accessors; count: the accessors' length."""

    node: int
    set: int
    attributes: dict[str, int]
    vertices: np.ndarray
    sources: np.ndarray
    count: int | None = None
    same_layout: bool = False
    prepared: dict | None = None
    targets: tuple | None = None


# Extensions whose references to accessors and bufferViews the writer knows (or that have none).
_KNOWN_EXTENSIONS = {"KHR_lights_punctual", "KHR_texture_transform", "KHR_mesh_quantization", "KHR_texture_basisu",
                     MOZ_LIGHTMAP, MOZ_RGBE,
                     "EXT_texture_webp", "EXT_texture_avif", "KHR_xmp_json_ld", "EXT_mesh_gpu_instancing",
                     "KHR_draco_mesh_compression", "KHR_animation_pointer"}


def _distinct(references) -> list[tuple[dict, str]]:
    """(holder, key) pairs, each once: primitives and morph targets may be shared by meshes."""
    seen, out = set(), []
    for holder, key in references:
        if (id(holder), key) not in seen:
            seen.add((id(holder), key))
            out.append((holder, key))
    return out


def _used_images(raw: dict) -> set[int]:
    """Indices of the images some texture names as its source (or an extension's source)."""
    used = set()
    for texture in raw.get("textures") or []:
        if isinstance(texture, dict):
            sources = [texture] + [e for e in (texture.get("extensions") or {}).values() if isinstance(e, dict)]
            used.update(s["source"] for s in sources if isinstance(s.get("source"), int))
    return used


def _image_mime(data: bytes) -> str | None:
    """The MIME type of PNG, JPEG, WebP or KTX2 bytes (None for anything else)."""
    if data.startswith(b"\x89PNG\r\n\x1a\n"):
        return "image/png"
    if data.startswith(b"\xff\xd8\xff"):
        return "image/jpeg"
    if data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        return "image/webp"
    if data.startswith(b"\xabKTX 20\xbb\r\n\x1a\n"):
        return "image/ktx2"
    return None


def _floats(values) -> list[float]:
    return [float(v) for v in np.asarray(values).ravel()]


def _to_uint8(values: np.ndarray) -> np.ndarray:
    return np.round(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)


def _srgb_png(linear: np.ndarray) -> bytes:
    """PNG of a linear (H, W, 3|4) float texture: RGB sRGB-encoded, alpha kept linear."""
    encoded = np.array(linear, np.float32)
    encoded[..., :3] = linear_to_srgb(np.clip(encoded[..., :3], 0.0, 1.0))
    return encode_png(_to_uint8(encoded))


def _rotation_onto(direction) -> list[float]:
    """Unit quaternion [x, y, z, w] turning the node's -Z onto `direction`."""
    forward = np.array([0.0, 0.0, -1.0])
    d = np.asarray(direction, np.float64)
    d = d / np.linalg.norm(d)
    cosine = float(forward @ d)
    if cosine < -1.0 + 1e-12:  # opposite: half a turn about Y
        return [0.0, 1.0, 0.0, 0.0]
    q = np.array([*np.cross(forward, d), 1.0 + cosine])
    return _floats(q / np.linalg.norm(q))


def _look_rotation(direction) -> list[float]:
    """Unit quaternion [x, y, z, w] turning a camera's -Z onto `direction` with its +Y as
    near world +Y as it can be (no roll: the view the renderer's camera shows)."""
    back = -np.asarray(direction, np.float64) / np.linalg.norm(direction)
    right = np.cross([0.0, 1.0, 0.0], back)
    if np.linalg.norm(right) < 1e-9:  # looking straight up or down: any right will do
        right = np.array([1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    m = np.stack([right, np.cross(back, right), back], axis=1)  # columns: the camera's X, Y, Z
    w = math.sqrt(max(0.0, 1.0 + np.trace(m))) / 2
    x = math.copysign(math.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2, m[2, 1] - m[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2, m[0, 2] - m[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2, m[1, 0] - m[0, 1])
    q = np.array([x, y, z, w])
    return _floats(q / np.linalg.norm(q))


def _jsonable(value):
    """Numpy scalars and arrays inside dicts/lists turned into plain JSON values."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value
