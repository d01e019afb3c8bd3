"""Reading a glTF document into one world-space `Scene` (what is read and how: the package
docstring, "Import")."""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pygltflib as gl

from ...errors import PatchlightError
from ...imaging.color import srgb_to_linear
from ...imaging.io import decode_image, read_environment
from ..model import MAX_ATLASES, Light, Material, Objects, Provenance, Scene, stacked_uv1, vertex_normals
from ..sky import Sky
from .baked import atlas_of_materials
from .container import Document, FAN, INDEX_TYPES, LUMENS_PER_WATT, POINTS_AND_LINES, STRIP, TRIANGLES, attribute_map, file_stamp, float_list, read_document

SUPPORTED_REQUIRED_EXTENSIONS = {"KHR_lights_punctual", "KHR_materials_emissive_strength",
                                 "KHR_mesh_quantization"}
_DEGENERATE_SINE = 1e-7  # |e1 x e2| below this times the longest edge squared: zero area in float32


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
    stamp = file_stamp(path)  # before reading: a file changed meanwhile never matches it later
    doc, blob = read_document(path)
    try:
        scene = SceneReader(path, doc, blob).scene()
    except (TypeError, ValueError, AttributeError, KeyError) as exc:
        # JSON values of the wrong type (a string where a list belongs, ...) surface as these.
        raise PatchlightError(f"{path}: malformed glTF ({type(exc).__name__}: {exc})") from exc
    scene.validate()
    scene.provenance.path, scene.provenance.stamp = str(path), stamp
    return scene


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


class SceneReader(Document):
    """One glTF document being flattened into a Scene; holds the decoded images."""

    def __init__(self, path: Path, doc: gl.GLTF2, blob: bytes | None):
        super().__init__(path, doc, blob)
        self.warnings: list[str] = []
        self.skipped = 0
        self.uses_default_material = False
        self._images: dict[int, np.ndarray] = {}

    def scene(self) -> Scene:
        self._check_required_extensions()
        instances = self.instances()
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
        mode = TRIANGLES if primitive.mode is None else primitive.mode
        if mode in POINTS_AND_LINES:
            self.skipped += 1
            return
        if mode not in (TRIANGLES, STRIP, FAN):
            raise self.fail(f"{where}: unknown mode {mode}")
        attributes = attribute_map(primitive)
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
            if accessor.componentType not in INDEX_TYPES or accessor.type != "SCALAR":
                raise self.fail(f"{where}: indices must be SCALAR unsigned integers")
            index = self.accessor(primitive.indices)[:, 0].astype(np.int64)
            if index.size and index.max() >= vertex_count:
                raise self.fail(f"{where}: index {int(index.max())} is past its {vertex_count} vertices")
        if mode == TRIANGLES:
            if len(index) % 3:
                raise self.fail(f"{where}: {len(index)} triangle indices is not a multiple of 3")
            return index.reshape(-1, 3)
        k = np.arange(max(len(index) - 2, 0))
        if mode == STRIP:  # every odd triangle swaps its last two corners to keep the winding
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
        if scene.uv1 is not None:
            self._stack_atlases(scene)
        return scene

    def _stack_atlases(self, scene: Scene) -> None:
        """A scene.glb of several lightmap atlases (each material's MOZ_lightmap names its
        atlas's texture): TEXCOORD_1, per atlas in the file, stacked into one uv1."""
        count, atlas_of = atlas_of_materials(self.doc.extras, [m.extensions for m in self.doc.materials or []])
        if count > MAX_ATLASES:
            raise self.fail(f"{count} lightmap atlases (at most {MAX_ATLASES})")
        if count == 1:
            return
        triangle = np.array([atlas_of.get(int(m), 0) for m in range(len(scene.materials))], np.int32)[scene.material_ids]
        vertex = np.zeros(len(scene.uv1), np.int32)
        vertex[scene.indices] = triangle[:, None]
        scene.uv1, scene.atlases = stacked_uv1(scene.uv1, vertex, count), count

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
                data, label = self.resource(image.uri, f"image {index}"), f"image {index} ({image.uri[:40]!r})"
            else:
                raise self.fail(f"image {index} has neither a uri nor a bufferView")
            self._images[index] = decode_image(data, f"{self.path}: {label}")
        return self._images[index]

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
            return {"eye": float_list(eye), "target": float_list(eye + forward / np.linalg.norm(forward)),
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
