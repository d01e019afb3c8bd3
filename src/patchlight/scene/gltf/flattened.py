"""The flattened writer: a scene as one world-space .glb (built-in scenes, and scenes whose
source file cannot be rewritten): one identity node and mesh per material, every mesh sharing
the vertex accessors; materials, lights in photometric units and the camera."""
from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pygltflib as gl

from ...imaging.color import linear_to_srgb
from ...imaging.io import check_finite, encode_png
from ...imaging.lightmap import EncodedDirectional, EncodedLightmap
from ..model import Light, Material, Scene, atlas_uv1, triangle_atlas
from .container import ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER, FLOAT, LUMENS_PER_WATT, TRIANGLES, UINT, float_list
from .baked import DIRECTIONAL, EXR, EXR_MIME, directional_name, directional_reference
from .baked import HDR_MIME, LIGHTMAP_HDR_NAME, LIGHTMAP_NAME, LIGHTMAP_SAMPLER, MOZ_LIGHTMAP, MOZ_RGBE, UNLIT, atlas_material, jsonable, lightmap_description, lightmap_occlusion, lightmap_pages, lightmap_reference

def flattened_glb(scene: Scene, folder: Path, lightmap: EncodedLightmap | list[EncodedLightmap] | None, meta: dict,
                  unlit: bool, extras: dict, directional: EncodedDirectional | None = None) -> bytes:
    """The world-space soup as one .glb: one identity node and mesh per material and atlas
    (a material on several atlases gets a copy per further atlas, "<name> (atlas k)")."""
    writer = _GlbWriter()
    attributes = writer.vertex_attributes(scene)
    writer.doc.materials = [writer.material(m, unlit) for m in scene.materials]
    if unlit:
        writer.use_extension(UNLIT)
    meshes, atlas_of = writer.meshes(scene, attributes)
    nodes = meshes + writer.lights(scene.lights) + writer.camera(scene.extras.get("camera"))
    sky = scene.sky.to_extras(folder) if scene.sky is not None else None
    writer.doc.scenes = [gl.Scene(name=scene.name, nodes=nodes, extras={"patchlight": {"sky": sky}} if sky else {})]
    writer.doc.scene = 0
    writer.doc.extras = {"patchlight": jsonable(extras)} if extras else {}
    if lightmap is not None:
        sampler = writer.lightmap(lightmap_pages(lightmap), meta, atlas_of)
        for k, maps in enumerate(lightmap_pages(directional) if directional is not None else []):
            writer.directional(maps, sampler, [m for m in range(len(writer.doc.materials)) if atlas_of.get(m, 0) == k],
                               None if scene.atlases == 1 else k)
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
                               componentType=FLOAT if array.dtype == np.float32 else UINT)
        if bounds:  # POSITION must carry its bounds
            accessor.min, accessor.max = array.min(axis=0).tolist(), array.max(axis=0).tolist()
        self.doc.accessors.append(accessor)
        return len(self.doc.accessors) - 1

    def vertex_attributes(self, scene: Scene) -> dict[str, int]:
        """Accessor per attribute, shared by every mesh."""
        def add(values, kind, bounds=False):
            return self.accessor(np.asarray(values, np.float32), kind, ARRAY_BUFFER, bounds)

        attributes = {"POSITION": add(scene.positions, "VEC3", bounds=True),
                      "NORMAL": add(scene.normals, "VEC3"), "TEXCOORD_0": add(scene.uv0, "VEC2")}
        uv1 = None if scene.uv1 is None else atlas_uv1(scene.uv1, scene.atlases)[0]  # in each atlas
        optional = {"TEXCOORD_1": (uv1, "VEC2"), "COLOR_0": (scene.colors, "VEC4"),
                    "TANGENT": (scene.tangents, "VEC4")}
        attributes.update({name: add(values, kind) for name, (values, kind) in optional.items() if values is not None})
        return attributes

    def meshes(self, scene: Scene, attributes: dict[str, int]) -> tuple[list[int], dict[int, int]]:
        """One mesh (and one identity node) per material and atlas that have triangles; returns
        the node indices and the atlas of each glTF material drawn."""
        nodes, atlas_of, first, copies = [], {}, {}, {}
        atlas = np.zeros(scene.n_triangles, np.int32) if scene.uv1 is None else triangle_atlas(scene)
        for material_id, material in enumerate(scene.materials):
            mine = scene.material_ids == material_id
            for k in np.unique(atlas[mine]):
                triangles = scene.indices[mine & (atlas == k)]
                number = atlas_material(self.doc.materials, material_id, int(k), material.name, first, copies, _renamed)
                name = self.doc.materials[number].name
                atlas_of[number] = int(k)
                indices = self.accessor(triangles.astype(np.uint32).ravel(), "SCALAR", ELEMENT_ARRAY_BUFFER)
                primitive = gl.Primitive(attributes=gl.Attributes(**attributes), indices=indices,
                                         material=number, mode=TRIANGLES)
                self.doc.meshes.append(gl.Mesh(name=name, primitives=[primitive]))
                self.doc.nodes.append(gl.Node(name=name, mesh=len(self.doc.meshes) - 1))
                nodes.append(len(self.doc.nodes) - 1)
        return nodes, atlas_of

    def texture(self, png: bytes, name: str | None = None, sampler: int | None = None) -> int:
        self.doc.images.append(gl.Image(bufferView=self.view(png), mimeType="image/png", name=name))
        self.doc.textures.append(gl.Texture(source=len(self.doc.images) - 1, sampler=sampler, name=name))
        return len(self.doc.textures) - 1

    def material(self, material: Material, unlit: bool = False) -> gl.Material:
        """The glTF material; unlit: KHR_materials_unlit, else a Lambertian surface (specular 0)."""
        peak = float(np.max(material.emissive))
        strength = peak if peak > 1.0 else 1.0  # emissiveFactor must stay in [0, 1]
        pbr = gl.PbrMetallicRoughness(baseColorFactor=float_list(material.base_color), metallicFactor=0.0,
                                      roughnessFactor=1.0)
        out = gl.Material(name=material.name, pbrMetallicRoughness=pbr, doubleSided=bool(material.double_sided),
                          emissiveFactor=float_list(material.emissive / np.float32(strength)),
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
            spec = {"type": light.kind, "color": float_list(light.color),
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
            self.doc.nodes.append(gl.Node(name=light.name or f"light_{number}", translation=float_list(light.position),
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
        self.doc.nodes.append(gl.Node(name="camera", camera=len(self.doc.cameras) - 1, translation=float_list(eye),
                                      rotation=_look_rotation(np.asarray(camera["target"], np.float64) - eye)))
        return [len(self.doc.nodes) - 1]

    def lightmap(self, pages: list[EncodedLightmap], meta: dict, atlas_of: dict[int, int]) -> int:
        """The lightmap as one texture "patchlight_lightmap" per atlas (PNG source, .hdr through
        MOZ_texture_rgbe), MOZ_lightmap and the occlusionTexture stand-in (baked.lightmap_occlusion)
        of its atlas's texture on every material, and its description in the root extras; returns
        the sampler of the last atlas's texture (the directional layers use it)."""
        description = lightmap_description(pages, meta)
        textures = []
        for lightmap in pages:
            self.doc.samplers.append(gl.Sampler(**LIGHTMAP_SAMPLER))
            textures.append(self.texture(lightmap.png, LIGHTMAP_NAME, sampler=len(self.doc.samplers) - 1))
            self.doc.images.append(gl.Image(bufferView=self.view(lightmap.hdr), mimeType=HDR_MIME,
                                            name=LIGHTMAP_HDR_NAME))
            self.doc.textures[textures[-1]].extensions = {MOZ_RGBE: {"source": len(self.doc.images) - 1}}
        for number, material in enumerate(self.doc.materials):
            texture = textures[atlas_of.get(number, 0)]
            material.extensions = {**(material.extensions or {}),
                                   MOZ_LIGHTMAP: lightmap_reference(texture, pages[atlas_of.get(number, 0)])}
            material.occlusionTexture = gl.OcclusionTextureInfo(**lightmap_occlusion(texture))
        for name in (MOZ_LIGHTMAP, MOZ_RGBE):
            self.use_extension(name)
        description.update({"texture": textures[0]} if len(pages) == 1 else {"textures": textures})
        self.doc.extras = {"patchlight": {**self.doc.extras.get("patchlight", {}), "lightmap": description}}
        return self.doc.textures[textures[-1]].sampler

    def directional(self, directional: EncodedDirectional, sampler: int, materials: list[int],
                    atlas: int | None = None) -> None:
        """Each directional layer (of atlas `atlas` in a bake of several) as a texture naming its
        EXR through PATCHLIGHT_texture_exr, PATCHLIGHT_lightmap_directional on `materials`."""
        textures = []
        for layer, exr in zip(directional.layers, directional.exr):
            name = directional_name(layer, atlas)
            self.doc.images.append(gl.Image(bufferView=self.view(exr), mimeType=EXR_MIME, name=name))
            self.doc.textures.append(gl.Texture(sampler=sampler, name=name,
                                                extensions={EXR: {"source": len(self.doc.images) - 1}}))
            textures.append(len(self.doc.textures) - 1)
        for number in materials:
            material = self.doc.materials[number]
            material.extensions = {**(material.extensions or {}), DIRECTIONAL: directional_reference(textures, directional)}
        for name in (DIRECTIONAL, EXR):
            self.use_extension(name)


def _renamed(material: gl.Material, name: str) -> gl.Material:
    """A deep copy of `material` named `name`."""
    out = copy.deepcopy(material)
    out.name = name
    return out


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
    return float_list(q / np.linalg.norm(q))


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
    return float_list(q / np.linalg.norm(q))
