"""The glTF container: the JSON of a .gltf file or a GLB container's chunks, the binary data
behind buffers and images (the GLB BIN chunk, data: URIs, files in the glTF's folder),
accessors (strided, normalized, sparse) and the node tree's world matrices. `Document` is one
parsed file; the reader (`reader.py`) and the source-preserving writer (`preserving.py`) read
through it, and `pack_glb` assembles a GLB container. Which files a uri may name: the package
docstring and `outside_reason`.
"""
from __future__ import annotations

import base64
import binascii
import math
import struct
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Iterator
from urllib.parse import unquote, unquote_to_bytes

import numpy as np
import pygltflib as gl

from ...errors import PatchlightError
from ...imaging.io import read_bytes
from ...limits import load_json

# Photometric -> radiometric: 683 lm/W at 555 nm (KHR_lights_punctual intensities are lux / candela).
LUMENS_PER_WATT = 683.0
_COMPONENT_DTYPES = {5120: np.dtype("<i1"), 5121: np.dtype("<u1"), 5122: np.dtype("<i2"),
                     5123: np.dtype("<u2"), 5125: np.dtype("<u4"), 5126: np.dtype("<f4")}
_NORMALIZED_MAX = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}
INDEX_TYPES = (5121, 5123, 5125)
TYPE_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
_TOP_LEVEL_LISTS = ("accessors", "animations", "buffers", "bufferViews", "cameras", "images", "materials",
                    "meshes", "nodes", "samplers", "scenes", "skins", "textures")
_WHOLE_NUMBER_FIELDS = {"accessors": ("bufferView", "byteOffset", "componentType", "count"),
                        "bufferViews": ("buffer", "byteOffset", "byteLength", "byteStride", "target"),
                        "buffers": ("byteLength",), "images": ("bufferView",), "textures": ("sampler", "source"),
                        "nodes": ("camera", "mesh", "skin")}
GLB_MAGIC, CHUNK_JSON, CHUNK_BIN = b"glTF", 0x4E4F534A, 0x004E4942
POINTS_AND_LINES = (0, 1, 2, 3)
TRIANGLES, STRIP, FAN = 4, 5, 6
FLOAT, UINT = 5126, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
LINEAR_FILTER, CLAMP_TO_EDGE = 9729, 33071


def file_stamp(path: Path) -> tuple[int, int] | None:
    """(size, mtime in ns) of a file: how save_baked_glb knows the source has not changed."""
    try:
        status = path.stat()
    except OSError:
        return None
    return status.st_size, status.st_mtime_ns


def read_document(path: Path) -> tuple[gl.GLTF2, bytes | None]:
    """Parse the JSON (from a .gltf or a GLB container) into pygltflib objects + the BIN chunk."""
    data = read_bytes(path)
    if data[:4] == GLB_MAGIC:
        text, blob = split_glb(data, path)
    else:
        text, blob = document_text(data, path), None
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
    _check_references(raw, bad)


def _check_references(raw: dict, bad) -> None:
    """Every accessor and bufferView reference the reader and the writer follow is a whole
    number, inside objects and lists of the shapes they expect."""
    def objects(value, where: str) -> list[dict]:
        if not isinstance(value, list) or not all(isinstance(item, dict) for item in value):
            raise bad(f"{where} must be a list of objects")
        return value

    def entry(value, where: str) -> dict:
        if not isinstance(value, dict):
            raise bad(f"{where} must be an object")
        return value

    def whole(holder: dict, keys, where: str) -> None:
        for key in keys:
            if key in holder and not _whole(holder[key]):
                raise bad(f"{where}: {key} {holder[key]!r} is not a whole number >= 0")

    for m, mesh in enumerate(raw.get("meshes", [])):
        for p, primitive in enumerate(objects(mesh.get("primitives", []), f"meshes[{m}].primitives")):
            where = f"meshes[{m}].primitives[{p}]"
            whole(primitive, ("indices", "material", "mode"), where)
            for attributes in [entry(primitive.get("attributes", {}), f"{where}.attributes"),
                               *objects(primitive.get("targets", []), f"{where}.targets")]:
                whole(attributes, list(attributes), where)
            extensions = entry(primitive.get("extensions", {}), f"{where}.extensions")
            whole(entry(extensions.get("KHR_draco_mesh_compression", {}), f"{where} draco"), ("bufferView",), where)
    for n, accessor in enumerate(raw.get("accessors", [])):
        if "sparse" in accessor:
            sparse = entry(accessor["sparse"], f"accessors[{n}].sparse")
            whole(sparse, ("count",), f"accessors[{n}].sparse")
            for part in ("indices", "values"):
                whole(entry(sparse.get(part), f"accessors[{n}].sparse.{part}"),
                      ("bufferView", "byteOffset", "componentType"), f"accessors[{n}].sparse.{part}")
    for n, skin in enumerate(raw.get("skins", [])):
        whole(skin, ("inverseBindMatrices", "skeleton"), f"skins[{n}]")
    for a, animation in enumerate(raw.get("animations", [])):
        for n, sampler in enumerate(objects(animation.get("samplers", []), f"animations[{a}].samplers")):
            whole(sampler, ("input", "output"), f"animations[{a}].samplers[{n}]")
    for n, node in enumerate(raw.get("nodes", [])):
        instancing = entry(entry(node.get("extensions", {}), f"nodes[{n}].extensions")
                           .get("EXT_mesh_gpu_instancing", {}), f"nodes[{n}] instancing")
        attributes = entry(instancing.get("attributes", {}), f"nodes[{n}] instancing attributes")
        whole(attributes, list(attributes), f"nodes[{n}] instancing")


def _whole(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 2**53


def document_text(data: bytes, path: Path) -> str:
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise PatchlightError(f"{path}: not a glTF file (neither a GLB container nor UTF-8 JSON)") from None


def split_glb(data: bytes, path: Path) -> tuple[str, bytes | None]:
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
    if not chunks or chunks[0][0] != CHUNK_JSON:
        raise PatchlightError(f"{path}: malformed .glb (the first chunk is not JSON)")
    blob = next((chunk for kind, chunk in chunks[1:] if kind == CHUNK_BIN), None)
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


class Document:
    """One parsed glTF file: `doc` the pygltflib objects, `blob` the GLB BIN chunk (or None);
    buffers are decoded on first use. Errors name the file (`fail`)."""

    def __init__(self, path: Path, doc: gl.GLTF2, blob: bytes | None):
        self.path, self.doc, self.blob = path, doc, blob
        self._buffers: dict[int, bytes] = {}
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

    def instances(self) -> list[tuple[int, np.ndarray]]:
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

    def buffer(self, index) -> bytes:
        if index not in self._buffers:
            buf = self.item(self.doc.buffers, index, "buffer")
            data = self.resource(buf.uri, f"buffer {index}") if buf.uri is not None else self.blob
            if data is None:
                raise self.fail(f"buffer {index} has no uri and the file has no GLB binary chunk")
            if buf.byteLength is not None and len(data) < buf.byteLength:
                raise self.fail(f"buffer {index} holds {len(data)} bytes, less than its byteLength {buf.byteLength}")
            self._buffers[index] = data
        return self._buffers[index]

    def resource(self, uri: str, what: str) -> bytes:
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
                            f"are read (`allow_outside_files` reads it)")
        try:
            found = target.is_file()
        except OSError:  # a name too long for the file system
            found = False
        if not found:
            raise self.fail(f"{what}: file {uri[:60]!r} not found next to the glTF")
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
        width = TYPE_WIDTHS.get(acc.type)
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
        if sparse.indices.componentType not in INDEX_TYPES:
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
        if acc.componentType == FLOAT:
            return values
        if acc.normalized:
            return np.maximum(values / _NORMALIZED_MAX[acc.componentType], -1.0).astype(np.float32)
        return values.astype(np.float32)


def attribute_map(primitive: gl.Primitive) -> dict[str, int]:
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


def pack_glb(text: bytes, blob: bytes) -> bytes:
    """A GLB container of JSON `text` (padded with spaces here) and a BIN chunk `blob` (none
    when empty; its length a multiple of 4)."""
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<II", len(text), CHUNK_JSON) + text
    if blob:
        chunks += struct.pack("<II", len(blob), CHUNK_BIN) + bytes(blob)
    return GLB_MAGIC + struct.pack("<II", 2, 12 + len(chunks)) + chunks


def float_list(values) -> list[float]:
    return [float(v) for v in np.asarray(values).ravel()]
