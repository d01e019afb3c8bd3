"""A glTF document edited as its JSON (`raw`): bufferViews and accessors appended, images
beside a .gltf embedded, what nothing refers to any more dropped, and the whole written back
as one GLB holding the source file's binary data and the new."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import PatchlightError
from ...imaging.io import check_finite, json_text
from .container import ARRAY_BUFFER, Document, ELEMENT_ARRAY_BUFFER, FLOAT, TYPE_WIDTHS, pack_glb
from .baked import DIRECTIONAL, EXR, MOZ_LIGHTMAP, MOZ_RGBE

class GlbEditor:
    """raw: the document's JSON (edited in place); importer: the same file as a Document (its
    accessors and bufferViews' bytes)."""

    def __init__(self, path: Path, raw: dict, importer: Document):
        self.path, self.raw, self.importer = path, raw, importer
        for key in ("accessors", "bufferViews", "meshes", "nodes", "images", "textures", "samplers"):
            if not isinstance(raw.get(key, []), list):
                raise ValueError(f"'{key}' is not a list")
            raw.setdefault(key, [])
        self.source_views = len(raw["bufferViews"])
        self.new_views: list[bytes] = []  # bytes of bufferViews source_views, source_views + 1, ...

    def embed_external_images(self) -> None:
        """Images in files beside a .gltf that a texture uses move into the .glb, their bytes
        unchanged (a data: URI stays as it is; an image that cannot be read, or that nothing
        uses, keeps its uri and is never read)."""
        used = {holder[key] for holder, key in self.image_references()}
        for number, image in enumerate(self.raw["images"]):
            uri = image.get("uri")
            if not isinstance(uri, str) or uri.startswith("data:") or number not in used:
                continue
            try:
                data = self.importer.resource(uri, f"image {number}")
            except PatchlightError:
                continue
            mime = image.get("mimeType") or _image_mime(data)
            if mime is None:
                continue
            del image["uri"]
            image.update(bufferView=self.add_view(data), mimeType=mime)

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
        accessor = {"bufferView": self.add_view(data, ARRAY_BUFFER if vertex else ELEMENT_ARRAY_BUFFER, stride),
                    "componentType": component, "count": len(values), "type": kind}
        if normalized:
            accessor["normalized"] = True
        if bounds and len(values):
            cast = float if component == FLOAT else int
            accessor["min"] = [cast(v) for v in values.min(axis=0)]
            accessor["max"] = [cast(v) for v in values.max(axis=0)]
        self.raw["accessors"].append(accessor)
        return len(self.raw["accessors"]) - 1

    def copy_accessor(self, index: int, sources: np.ndarray, bounds: bool) -> int:
        """A new vertex accessor holding elements `sources` of accessor `index`, same component
        type, type and normalization (sparse substitutions applied)."""
        original = self.raw["accessors"][index]
        if original.get("type") not in TYPE_WIDTHS:
            raise PatchlightError(f"{self.path}: accessor {index} of type {original.get('type')!r} "
                                  f"cannot be a vertex attribute")
        values = self.importer.accessor(index)[sources]
        return self.add_accessor(values, original["componentType"], original["type"], vertex=True,
                                 normalized=bool(original.get("normalized")),
                                 bounds=bounds or "min" in original or "max" in original)

    def knows_every_reference(self) -> bool:
        """Whether every extension the file uses is one whose references this writer knows."""
        used_extensions = set(self.raw.get("extensionsUsed") or [])
        return all(e in _KNOWN_EXTENSIONS or e.startswith("KHR_materials_") for e in used_extensions)

    def drop_unreferenced(self, owned) -> None:
        """Drop the textures, then the images, for which owned(JSON) is true and that nothing
        refers to any more (an earlier bake's maps), and the samplers only those textures used,
        renumbering the references to the rest. Skipped, as `compact`, when the file uses an
        extension this writer does not know, or refers to an object that does not exist."""
        if not self.knows_every_reference():
            return
        textures, samplers = self.raw["textures"], self.raw["samplers"]
        before = list(textures)
        self._drop(textures, owned, _distinct(self.texture_references()))
        kept = {id(t) for t in textures}
        freed = {id(samplers[t["sampler"]]) for t in before if id(t) not in kept and isinstance(t, dict)
                 and isinstance(t.get("sampler"), int) and 0 <= t["sampler"] < len(samplers)}
        self._drop(samplers, lambda sampler: id(sampler) in freed,
                   [(t, "sampler") for t in textures if isinstance(t, dict) and isinstance(t.get("sampler"), int)])
        self._drop(self.raw["images"], owned, _distinct(self.image_references()))

    @staticmethod
    def _drop(items: list, owned, references: list[tuple[dict, str]]) -> None:
        """Remove the owned, unreferenced items of `items` in place and renumber `references`."""
        referenced = {holder[key] for holder, key in references}
        if not referenced <= set(range(len(items))):
            return
        kept = [k for k, item in enumerate(items) if k in referenced or not owned(item)]
        renumbered = {old: new for new, old in enumerate(kept)}
        for holder, key in references:
            holder[key] = renumbered[holder[key]]
        items[:] = [items[k] for k in kept]

    def texture_references(self):
        """(holder dict, key) of every texture reference: a texture info ("index") anywhere in a
        material (extensions included), and the bake description's lightmap texture or atlas
        textures (holder: their list)."""
        pending = list(self.raw.get("materials") or [])
        while pending:
            item = pending.pop()
            if isinstance(item, list):
                pending += item
            elif isinstance(item, dict):
                if isinstance(item.get("index"), int) and not isinstance(item["index"], bool):
                    yield item, "index"
                pending += [v for k, v in item.items() if k != "extras" and isinstance(v, (dict, list))]
        lightmap = ((self.raw.get("extras") or {}).get("patchlight") or {}).get("lightmap")
        if isinstance(lightmap, dict) and isinstance(lightmap.get("texture"), int):
            yield lightmap, "texture"
        atlases = lightmap.get("textures") if isinstance(lightmap, dict) else None
        if isinstance(atlases, list):
            yield from ((atlases, k) for k, texture in enumerate(atlases) if isinstance(texture, int))

    def image_references(self):
        """(holder dict, key) of every image reference: a texture's source and its extensions'."""
        for texture in self.raw["textures"]:
            if isinstance(texture, dict):
                holders = [texture] + [e for e in (texture.get("extensions") or {}).values() if isinstance(e, dict)]
                yield from ((h, "source") for h in holders if isinstance(h.get("source"), int))

    def compact(self) -> None:
        """Drop accessors and bufferViews nothing refers to any more (the replaced vertices), and
        renumber the references.  Skipped when the file uses an extension whose references to
        accessors or views this writer does not know: then everything stays, unused or not."""
        raw = self.raw
        if not self.knows_every_reference():
            self.view_order = list(range(len(raw["bufferViews"])))
            return
        references = _distinct(self.accessor_references())
        referenced = self._referenced(references, "accessors")
        accessor_map = {old: new for new, old in enumerate(referenced)}
        for holder, key in references:
            holder[key] = accessor_map[holder[key]]
        raw["accessors"] = [raw["accessors"][old] for old in referenced]
        references = _distinct(self.view_references())
        views = self._referenced(references, "bufferViews")
        view_map = {old: new for new, old in enumerate(views)}
        for holder, key in references:
            holder[key] = view_map[holder[key]]
        self.view_order = views
        raw["bufferViews"] = [raw["bufferViews"][old] for old in views]

    def _referenced(self, references, kind: str) -> list[int]:
        """The sorted distinct indices into raw[kind] that `references` hold; PatchlightError
        when one is not such an index (a broken file)."""
        count, indices = len(self.raw[kind]), {holder[key] for holder, key in references}
        bad = [i for i in indices if not isinstance(i, int) or isinstance(i, bool) or not 0 <= i < count]
        if bad:
            raise PatchlightError(f"{self.path}: a reference to {kind} {bad[0]!r}, but the file has {count}")
        return sorted(indices)

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
        return pack_glb(json_text(self.raw, "scene.glb", indent=None).encode("utf-8"), bytes(blob))


_KNOWN_EXTENSIONS = {"KHR_lights_punctual", "KHR_texture_transform", "KHR_mesh_quantization", "KHR_texture_basisu",
                     MOZ_LIGHTMAP, MOZ_RGBE, DIRECTIONAL, EXR,
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
