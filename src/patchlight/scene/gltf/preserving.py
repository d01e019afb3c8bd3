"""The source-preserving writer: scene.glb as the input document itself, with the lightmap's
vertex splits and TEXCOORD_1 (the package docstring, "Export"; the mapping: `SourceWriter`)."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pygltflib as gl

from ...errors import PatchlightError
from ...imaging.io import read_bytes
from ...imaging.lightmap import EncodedDirectional, EncodedLightmap
from ..model import Scene, atlas_uv1, triangle_atlas
from .container import Document, FLOAT, GLB_MAGIC, POINTS_AND_LINES, TRIANGLES, UINT, attribute_map, document_text, file_stamp, split_glb
from .baked import DIRECTIONAL, EXR, EXR_MIME, directional_name, directional_reference, is_bake_map
from .baked import HDR_MIME, LIGHTMAP_HDR_NAME, LIGHTMAP_NAME, LIGHTMAP_SAMPLER, MOZ_LIGHTMAP, MOZ_RGBE, UNLIT, atlas_material, is_lightmap_occlusion, jsonable, lightmap_description, lightmap_occlusion, lightmap_pages, lightmap_reference
from .editor import GlbEditor

class SourceWriter(GlbEditor):
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

    def __init__(self, scene: Scene, path: Path, raw: dict, importer: Document):
        super().__init__(path, raw, importer)
        self.scene, self.provenance = scene, scene.provenance
        self.instances = {node: world for node, world in importer.instances()}  # traversal order
        self.set_id: dict[tuple, int] = {}      # accessor set (sorted attribute pairs) -> number
        self.sets: dict[tuple[int, int], int] = {}  # (mesh, primitive) -> accessor set number
        self.owner: dict[tuple[bytes, int], int] = {}  # (world matrix, set) -> node of the loader's block
        self._blocks: list[_VertexBlock] | None = None
        self.uv1 = None if scene.uv1 is None else atlas_uv1(scene.uv1, scene.atlases)[0]  # in each atlas
        self.atlas: dict[int, int] = {}  # id of a written primitive -> the atlas of its triangles

    @classmethod
    def open(cls, scene: Scene) -> "SourceWriter | str | None":
        """A writer for a scene loaded from glTF; None for a scene without provenance; a reason
        (str) when the provenance does not describe the scene or the file has changed."""
        provenance = scene.provenance
        if provenance is None:
            return None
        path = Path(provenance.path)
        if not provenance.fits(len(scene.positions), scene.n_triangles):
            return "its provenance no longer matches its vertices and triangles"
        if file_stamp(path) != provenance.stamp:
            return f"{path} has changed (or gone) since it was loaded"
        try:
            data = read_bytes(path)
            text, blob = split_glb(data, path) if data[:4] == GLB_MAGIC else (document_text(data, path), None)
            doc = gl.GLTF2.from_json(text, infer_missing=True)
            writer = cls(scene, path, json.loads(text), Document(path, doc, blob))
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
                self.sets[m, k] = self.set_id.setdefault(tuple(sorted(attribute_map(primitive).items())),
                                                         len(self.set_id))
                set_table[m, k] = self.sets[m, k]
                material_table[m, k] = default_material if primitive.material is None else primitive.material
        for node, world in self.instances.items():  # the loader's blocks: one per world matrix and set
            mesh = nodes[node].mesh
            for k, primitive in enumerate(meshes[mesh].primitives or [] if mesh is not None else []):
                if (TRIANGLES if primitive.mode is None else primitive.mode) not in POINTS_AND_LINES:
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
                attributes = attribute_map(self.importer.doc.meshes[self.node_mesh[node]].primitives[primitive])
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

    def write(self, folder: Path, lightmap: list[EncodedLightmap] | None, meta: dict, unlit: bool = False,
              extras: dict | None = None, directional: EncodedDirectional | None = None) -> bytes:
        """The .glb bytes; folder: where it will live (image sky paths are relative to it)."""
        primitives = self.rewritten_primitives()
        self.assign_meshes(primitives)
        self.drop_unused_draco()
        self.root_extras(extras or {})
        if lightmap is not None:
            self.lightmap(lightmap_pages(lightmap), meta, primitives,
                          None if directional is None else lightmap_pages(directional))
        if unlit:
            self.mark_unlit()
        self.mark_lights()
        self.sky(folder)
        self.embed_external_images()
        self.drop_unreferenced(is_bake_map)
        self.drop_unused_extensions()
        self.compact()
        return self.container()

    def drop_unused_extensions(self) -> None:
        """The bake's texture and material extensions left out of extensionsUsed where no
        texture or material has them any more (a re-bake without directional maps, vertexbake)."""
        used = self.raw.get("extensionsUsed")
        holders = [h for h in (self.raw.get("textures") or []) + (self.raw.get("materials") or []) if isinstance(h, dict)]
        for name in (MOZ_LIGHTMAP, MOZ_RGBE, DIRECTIONAL, EXR):
            if isinstance(used, list) and name in used and not any(name in (h.get("extensions") or {}) for h in holders):
                used.remove(name)

    def root_extras(self, extras: dict) -> None:
        """`extras` merged into the root extras.patchlight."""
        if not extras:
            return
        raw = self.raw
        root = raw.get("extras") if isinstance(raw.get("extras"), dict) else {}
        patchlight = root.get("patchlight") if isinstance(root.get("patchlight"), dict) else {}
        raw["extras"] = {**root, "patchlight": {**patchlight, **jsonable(extras)}}

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
        COLOR_0, so an earlier bake's MOZ_lightmap references, occlusion stand-ins and description go."""
        for material in self.raw.get("materials") or []:
            if is_lightmap_occlusion(material):
                del material["occlusionTexture"]
            material.setdefault("extensions", {})[UNLIT] = {}
            material["extensions"].pop(MOZ_LIGHTMAP, None)
            material["extensions"].pop(DIRECTIONAL, None)
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
        atlas = np.zeros(scene.n_triangles, np.int32) if scene.uv1 is None else triangle_atlas(scene)
        out = {}
        for node in (n for n in self.instances if self.node_mesh[n] in touched):
            mesh = int(self.node_mesh[node])
            flip = np.linalg.det(self.instances[node][:3, :3]) < 0
            written = []
            world = self.instances[node].tobytes()
            for k, primitive in enumerate(self.raw["meshes"][mesh].get("primitives") or []):
                block = by_block.get((self.owner.get((world, self.sets[mesh, k])), self.sets[mesh, k]))
                triangles = triangles_of.get((node, k))
                if block is None or primitive.get("mode", TRIANGLES) in POINTS_AND_LINES:
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
                if triangles is not None:
                    self.atlas[id(written[-1])] = int(atlas[triangles[0]])
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
            uv1 = np.ascontiguousarray(self.uv1[rows], np.float32)
            own = block.attributes.get("TEXCOORD_1")
            if not (block.same_layout and own is not None
                    and importer.floats(own, (2,), "TEXCOORD_1").tobytes() == uv1.tobytes()):
                prepared["TEXCOORD_1"] = self.add_accessor(uv1, FLOAT, "VEC2", vertex=True)
                if "TEXCOORD_0" not in block.attributes:  # glTF wants TEXCOORD_n numbered from 0
                    prepared["TEXCOORD_0"] = self.add_accessor(np.zeros_like(uv1), FLOAT, "VEC2", vertex=True)
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
                prepared["COLOR_0"] = self.add_accessor(colors, FLOAT, "VEC4", vertex=True)
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
        component = 5123 if len(block.vertices) < 65535 else UINT
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

    def lightmap(self, pages: list[EncodedLightmap], meta: dict, primitives: dict[int, list[dict]],
                 directional: list[EncodedDirectional] | None = None) -> None:
        """The lightmap: one texture per atlas (`lightmap_texture`, `new_lightmap_texture`);
        MOZ_lightmap on the materials of the triangle primitives written (a material whose
        primitives lie on several atlases gets a copy per further atlas, "<name> (atlas k)"),
        and its atlas's texture as their occlusionTexture at strength 0 where they have none of
        their own; root extras.patchlight.lightmap; the directional lightmap (`directional`, one
        per atlas)."""
        raw = self.raw
        description = lightmap_description(pages, meta)
        extras = raw.get("extras") if isinstance(raw.get("extras"), dict) else {}
        patchlight = extras.get("patchlight") if isinstance(extras.get("patchlight"), dict) else {}
        old = patchlight.get("lightmap") if isinstance(patchlight.get("lightmap"), dict) else {}
        old = old.get("textures") if isinstance(old.get("textures"), list) else [old.get("texture")]
        atlas_textures = [self.lightmap_texture(page, old[k] if k < len(old) else None) for k, page in enumerate(pages)]
        description.update({"texture": atlas_textures[0]} if len(pages) == 1 else {"textures": atlas_textures})
        materials, textures = raw.get("materials") or [], raw["textures"]
        lit = [p for written in primitives.values() for p in written
               if p.get("mode", TRIANGLES) not in POINTS_AND_LINES and isinstance(p.get("material"), int)
               and 0 <= p["material"] < len(materials)]
        copies: dict[tuple[int, int], int] = {}
        first: dict[int, int] = {}
        for primitive in sorted(lit, key=lambda p: self.atlas.get(id(p), 0)):
            number = primitive["material"]
            primitive["material"] = atlas_material(materials, number, self.atlas.get(id(primitive), 0),
                                                   materials[number].get("name") or f"material {number}",
                                                   first, copies,
                                                   lambda material, name: {**json.loads(json.dumps(material)), "name": name})
        for number, atlas in [*sorted(first.items()), *copies]:
            material = materials[copies.get((number, atlas), number)]
            texture, stand_in = atlas_textures[atlas], is_lightmap_occlusion(material)
            material["extensions"] = {**(material.get("extensions") or {}),
                                      MOZ_LIGHTMAP: lightmap_reference(texture, pages[atlas])}
            if "occlusionTexture" not in material or stand_in:
                material["occlusionTexture"] = lightmap_occlusion(texture)  # the file's own occlusion map stays
        used = raw.setdefault("extensionsUsed", [])
        used += [name for name in (MOZ_LIGHTMAP, MOZ_RGBE) if name not in used]
        raw["extras"] = {**extras, "patchlight": {**patchlight, "lightmap": description}}
        sampler = textures[atlas_textures[0]].get("sampler")
        drawn = [(materials[copies.get((number, atlas), number)], atlas) for number, atlas in [*first.items(), *copies]]
        if directional is None:
            self.directional(None, sampler, [material for material, _ in drawn])
        for k, maps in enumerate(directional or []):
            self.directional(maps, sampler, [material for material, atlas in drawn if atlas == k],
                             None if len(pages) == 1 else k)

    def new_lightmap_texture(self, lightmap: EncodedLightmap) -> int:
        """A new texture "patchlight_lightmap" of one atlas: PNG source, .hdr through MOZ_texture_rgbe."""
        raw = self.raw
        images, textures = raw["images"], raw["textures"]
        raw["samplers"].append(dict(LIGHTMAP_SAMPLER))
        images += [{"name": LIGHTMAP_NAME, "bufferView": self.add_view(lightmap.png), "mimeType": "image/png"},
                   {"name": LIGHTMAP_HDR_NAME, "bufferView": self.add_view(lightmap.hdr), "mimeType": HDR_MIME}]
        textures.append({"name": LIGHTMAP_NAME, "sampler": len(raw["samplers"]) - 1, "source": len(images) - 2,
                         "extensions": {MOZ_RGBE: {"source": len(images) - 1}}})
        return len(textures) - 1

    def lightmap_texture(self, lightmap: EncodedLightmap, old) -> int:
        """The texture of one atlas: `old`, the one an earlier bake left for it (re-baking a
        scene.glb), with the new images, else a new one."""
        raw = self.raw
        textures, images = raw["textures"], raw["images"]
        if not (isinstance(old, int) and 0 <= old < len(textures) and textures[old].get("name") == LIGHTMAP_NAME
                and isinstance(textures[old].get("source"), int) and 0 <= textures[old]["source"] < len(images)):
            return self.new_lightmap_texture(lightmap)
        images[textures[old]["source"]] = {"name": LIGHTMAP_NAME, "bufferView": self.add_view(lightmap.png),
                                           "mimeType": "image/png"}
        hdr = {"name": LIGHTMAP_HDR_NAME, "bufferView": self.add_view(lightmap.hdr), "mimeType": HDR_MIME}
        source = ((textures[old].get("extensions") or {}).get(MOZ_RGBE) or {}).get("source")
        if isinstance(source, int) and 0 <= source < len(images) and images[source].get("name") == LIGHTMAP_HDR_NAME:
            images[source] = hdr
        else:
            images.append(hdr)
            source = len(images) - 1
        textures[old]["extensions"] = {**(textures[old].get("extensions") or {}), MOZ_RGBE: {"source": source}}
        return old

    def directional(self, directional: EncodedDirectional | None, sampler: int | None, lit: list[dict],
                    atlas: int | None = None) -> None:
        """Each directional layer (of atlas `atlas` in a bake of several) as the texture named
        directional_name(layer, atlas) (an earlier bake's reused) naming its EXR image through PATCHLIGHT_texture_exr, and
        PATCHLIGHT_lightmap_directional on the lit materials; without one, an earlier bake's
        reference goes."""
        raw = self.raw
        if directional is None:
            for material in lit:
                (material.get("extensions") or {}).pop(DIRECTIONAL, None)
            return
        used = raw.setdefault("extensionsUsed", [])
        textures, images = raw["textures"], raw["images"]
        named = {t.get("name"): k for k, t in enumerate(textures) if isinstance(t, dict)}
        indices = []
        for layer, exr in zip(directional.layers, directional.exr):
            name = directional_name(layer, atlas)
            image = {"name": name, "bufferView": self.add_view(exr), "mimeType": EXR_MIME}
            k = named.get(name)
            source = None if k is None else ((textures[k].get("extensions") or {}).get(EXR) or {}).get("source")
            if isinstance(source, int) and 0 <= source < len(images) and images[source].get("name") == name:
                images[source] = image
            else:
                images.append(image)
                source = len(images) - 1
            if k is None:
                textures.append({"name": name, **({} if sampler is None else {"sampler": sampler})})
                k = len(textures) - 1
            textures[k]["extensions"] = {**(textures[k].get("extensions") or {}), EXR: {"source": source}}
            indices.append(k)
        for material in lit:
            material["extensions"][DIRECTIONAL] = directional_reference(indices, directional)
        used += [name for name in (DIRECTIONAL, EXR) if name not in used]

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
