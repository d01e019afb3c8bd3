"""The scene as one world-space triangle soup, plus materials, lights and sky.

Every importer (glTF, built-in scenes) produces a `Scene`; every later stage reads
only these arrays. Units: metres, +Y up, linear RGB; light units as docs/architecture.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import PatchlightError


@dataclass
class Material:
    """A glTF metallic-roughness material reduced to what lighting needs.

    base_color: (4,) linear RGBA factor.  base_color_texture: (H, W, 4) float32 linear
    (RGB converted from sRGB, alpha kept linear) or None.  emissive: (3,) radiance factor
    (emissiveFactor x KHR_materials_emissive_strength).  emissive_texture: (H, W, 3) linear or None.
    normal_texture: (H, W, 3) float32 in [0, 1] (decoded as 2t - 1) or None.
    Textures are sampled with uv0, glTF convention (v = 0 is the image's top row).
    """

    name: str = "default"
    base_color: np.ndarray = field(default_factory=lambda: np.ones(4, np.float32))
    base_color_texture: np.ndarray | None = None
    emissive: np.ndarray = field(default_factory=lambda: np.zeros(3, np.float32))
    emissive_texture: np.ndarray | None = None
    normal_texture: np.ndarray | None = None
    double_sided: bool = False
    shininess: float = 16.0
    reflectivity: float = 0.0

    @property
    def is_emissive(self) -> bool:
        return bool(np.any(self.emissive > 0))


MAX_LIGHT = 1e12  # the largest radiance, irradiance or intensity taken: sums stay finite in float32


def check_light_values(values, what: str) -> None:
    """PatchlightError unless every value is a finite number in 0..MAX_LIGHT."""
    values = np.asarray(values, np.float64)
    ok = np.isfinite(values) & (values >= 0) & (values <= MAX_LIGHT)
    if not ok.all():
        bad = values[~ok].flat[0]
        raise PatchlightError(f"{what}: {bad:g} is not a number in 0..{MAX_LIGHT:g}")


@dataclass
class Light:
    """A KHR_lights_punctual light in radiometric units.

    kind: "directional" | "point" | "spot".  color: (3,) linear.  intensity: for a
    directional light the irradiance Es (W/m^2 on a perpendicular surface); for point and
    spot the radiant intensity (W/sr).  direction: (3,) unit vector the light travels along
    (glTF's -Z of the light node).  range: metres, or None for infinite.  Cone angles in radians.
    falloff: "inverse-square" | "range" | None (None: take the bake's falloff setting).
    angle: apparent angular diameter of a sun, radians (0 = hard shadows).
    baked: whether the bake puts its light into the lightmap (scene.glb then marks it baked, so
    runtimes do not light the scene with it a second time); False keeps it dynamic.
    source: its KHR_lights_punctual definition's index in the glTF file it came from, or None.
    """

    kind: str
    color: np.ndarray
    intensity: float
    position: np.ndarray = field(default_factory=lambda: np.zeros(3, np.float32))
    direction: np.ndarray = field(default_factory=lambda: np.array([0, -1, 0], np.float32))
    range: float | None = None
    inner_cone: float = 0.0
    outer_cone: float = np.pi / 4
    falloff: str | None = None
    angle: float = 0.0
    name: str = ""
    baked: bool = True
    source: int | None = None

    def validate(self, where: str) -> None:
        """One line naming the light when a value is not finite or out of its range."""
        what = f"{where}: light {self.name or self.kind!r}"
        check_light_values(np.asarray(self.color, np.float64) * self.intensity, f"{what} colour x intensity")
        geometry = np.concatenate([np.ravel(self.position), np.ravel(self.direction),
                                   [self.inner_cone, self.outer_cone, self.angle]]).astype(np.float64)
        if not np.all(np.isfinite(geometry)) or not (self.range is None or 0 < self.range < math.inf):
            raise PatchlightError(f"{what}: its position, direction, range or angles are not finite numbers")

    @property
    def radiometric(self) -> np.ndarray:
        """(3,) colour x intensity."""
        return np.asarray(self.color, np.float32) * np.float32(self.intensity)


@dataclass
class Provenance:
    """Where each triangle and vertex of a glTF-loaded Scene came from in its file, so that
    scene.glb can be written as that file plus lightmap UVs (`scene.gltf.save_baked_glb`).

    path: the glTF file; stamp: its (size in bytes, mtime in ns) when it was read.
    triangle_node (T,) i32: the node whose mesh instance holds triangle t; triangle_mesh (T,) i32:
    that node's mesh; triangle_primitive (T,) i32: the primitive's index in mesh.primitives.
    vertex_node (V,) i32 and vertex_primitive (V,) i32: the node and the first primitive of its
    mesh whose attribute accessors hold vertex v; vertex_source (V,) i32: v's element in those
    accessors (so its local, untransformed attributes are accessor[vertex_source[v]]).
    Triangles keep the file's corners, except that the loader reverses the winding under a
    mirroring node (negative determinant); the writer reverses it back.
    """

    path: str
    stamp: tuple[int, int]
    triangle_node: np.ndarray
    triangle_mesh: np.ndarray
    triangle_primitive: np.ndarray
    vertex_node: np.ndarray
    vertex_primitive: np.ndarray
    vertex_source: np.ndarray

    def split(self, vmapping: np.ndarray) -> "Provenance":
        """The provenance of a vertex split where new vertex i copies vertex vmapping[i]
        (triangles keep their order)."""
        return Provenance(self.path, self.stamp, self.triangle_node, self.triangle_mesh, self.triangle_primitive,
                          self.vertex_node[vmapping], self.vertex_primitive[vmapping], self.vertex_source[vmapping])

    def fits(self, n_vertices: int, n_triangles: int) -> bool:
        """True when the arrays have the scene's vertex and triangle counts."""
        return (all(len(a) == n_triangles for a in (self.triangle_node, self.triangle_mesh, self.triangle_primitive))
                and all(len(a) == n_vertices for a in (self.vertex_node, self.vertex_primitive, self.vertex_source)))


@dataclass
class Objects:
    """The scene's objects (a glTF file's mesh instances), for per-object lightmap density.

    names: K names (the node's, else its mesh's, else "node N"; several objects may share
    one); triangle (T,) i32: the object of each triangle; texels_per_unit (K,) f64: the
    density the file asks for (`extras.patchlight.texelsPerUnit` of the node, else of its
    mesh), NaN where it asks none.
    """

    names: list[str]
    triangle: np.ndarray
    texels_per_unit: np.ndarray


@dataclass
class Scene:
    """One triangle soup in world space.

    positions (V, 3) f32; normals (V, 3) f32 unit; uv0 (V, 2) f32; uv1 (V, 2) f32 or None
    (the lightmap UVs, TEXCOORD_1); tangents (V, 4) f32 or None; colors (V, 4) f32 or None;
    indices (T, 3) i32; material_ids (T,) i32 into `materials`.  provenance: where a glTF
    scene's triangles and vertices came from (None for built-in scenes); a stage that re-indexes
    vertices carries it (`Provenance.split`), one that drops or reorders triangles sets it to None.
    objects: the objects each triangle belongs to (None: the scene is one object).
    atlases: how many lightmap atlases uv1 addresses, stacked along v (`stacked_uv1`): atlas k
    is v in [k / atlases, (k + 1) / atlases]; one atlas is the plain [0, 1] square.
    """

    positions: np.ndarray
    normals: np.ndarray
    uv0: np.ndarray
    indices: np.ndarray
    material_ids: np.ndarray
    materials: list[Material]
    lights: list[Light] = field(default_factory=list)
    sky: "object | None" = None
    uv1: np.ndarray | None = None
    tangents: np.ndarray | None = None
    colors: np.ndarray | None = None
    name: str = "scene"
    source: str = ""
    extras: dict = field(default_factory=dict)
    provenance: Provenance | None = None
    objects: Objects | None = None
    atlases: int = 1

    @property
    def label(self) -> str:
        """How messages name the scene: its file, else its name."""
        return self.source or self.name

    @property
    def n_triangles(self) -> int:
        return int(self.indices.shape[0])

    def triangle_vertices(self) -> np.ndarray:
        """(T, 3, 3) f32 world-space corners."""
        return self.positions[self.indices]

    def triangle_uv1(self) -> np.ndarray:
        """(T, 3, 2) f32 (contiguous) lightmap UVs of every triangle's corners: what the ray
        casts that look patches up (the gather's item buffer, the probes, the emitters)
        interpolate at a hit."""
        return np.ascontiguousarray(self.uv1[self.indices], np.float32)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds (lo, hi), each (3,)."""
        used = self.positions[np.unique(self.indices)]
        return used.min(axis=0), used.max(axis=0)

    @property
    def baked_lights(self) -> list[Light]:
        """The lights a bake puts into the lightmap (the rest stay dynamic)."""
        return [light for light in self.lights if light.baked]

    def has_light(self) -> bool:
        """True when anything lights the bake: a baked lamp of some power, an emissive material
        (a positive emissive factor: glTF multiplies any emissive texture by it) or a sky."""
        lamps = any(np.any(light.radiometric > 0) for light in self.baked_lights)
        emissive = any(m.is_emissive for m in self.materials)
        sky_lit = self.sky is not None and not self.sky.is_black()
        return lamps or emissive or sky_lit

    def validate(self) -> None:
        """Refuse NaN or infinite vertex attributes, out-of-range indices, and light values (lamps,
        emission, sky) that are not finite or beyond MAX_LIGHT, with one clear line."""
        for light in self.lights:
            light.validate(self.label)
        for material in self.materials:
            check_light_values(material.emissive, f"{self.label}: material {material.name!r} emission")
        if self.sky is not None:
            self.sky.validate(self.label)
        attributes = {"positions": self.positions, "normals": self.normals, "TEXCOORD_0": self.uv0,
                      "TEXCOORD_1": self.uv1, "tangents": self.tangents, "colours": self.colors}
        for name, values in attributes.items():
            if values is not None and not np.all(np.isfinite(values)):
                bad = int(np.count_nonzero(~np.isfinite(values).all(axis=1)))
                raise PatchlightError(f"{self.label}: {bad} vertex {name} are NaN or infinite")
        if self.indices.size and (self.indices.min() < 0 or self.indices.max() >= len(self.positions)):
            raise PatchlightError(f"{self.label}: triangle indices point outside the vertex array")
        if self.n_triangles == 0:
            raise PatchlightError(f"{self.label}: no triangles to light")


MAX_ATLASES = 256  # lightmap atlases a scene may address


def stacked_uv1(local: np.ndarray, atlas: np.ndarray, atlases: int) -> np.ndarray:
    """(V, 2) f32 lightmap UVs over `atlases` atlases stacked along v, from each vertex's UVs in
    its own atlas (V, 2) f32 and that atlas (V,) int. `atlas_uv1` turns them back bit for bit:
    a bake, its scene.glb (per-atlas TEXCOORD_1) and the scene read back address the same texels."""
    if atlases == 1:
        return local
    v = (local[:, 1].astype(np.float64) + atlas) / atlases
    return np.stack([local[:, 0], v.astype(np.float32)], axis=1)


def atlas_uv1(uv1: np.ndarray, atlases: int) -> tuple[np.ndarray, np.ndarray]:
    """(local (V, 2) f32, atlas (V,) i32): stacked lightmap UVs split into each vertex's atlas
    and its UVs there, the inverse of `stacked_uv1` (a vertex lies inside its atlas's band:
    the packer keeps at least a texel free along each atlas's edges)."""
    if atlases == 1:
        return uv1, np.zeros(len(uv1), np.int32)
    v = uv1[:, 1].astype(np.float64) * atlases
    atlas = np.clip(np.floor(v), 0, atlases - 1).astype(np.int32)
    return np.stack([uv1[:, 0], (v - atlas).astype(np.float32)], axis=1), atlas


def triangle_atlas(scene: "Scene") -> np.ndarray:
    """(T,) i32 the lightmap atlas of each triangle (all of a chart's corners share one)."""
    return atlas_uv1(scene.uv1, scene.atlases)[1][scene.indices[:, 0]]


def face_normals(positions: np.ndarray, indices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-triangle unit normals (T, 3) and areas (T,). Degenerate triangles get a zero normal."""
    tri = positions[indices].astype(np.float64)
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(cross, axis=1)
    normal = np.divide(cross, length[:, None], out=np.zeros_like(cross), where=length[:, None] > 0)
    return normal.astype(np.float32), (0.5 * length).astype(np.float32)


def vertex_normals(positions: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Area-weighted smooth normals (V, 3) for meshes that carry none."""
    normal, area = face_normals(positions, indices)
    acc = np.zeros((len(positions), 3), np.float64)
    for corner in range(3):
        np.add.at(acc, indices[:, corner], normal * area[:, None])
    length = np.linalg.norm(acc, axis=1, keepdims=True)
    return np.divide(acc, length, out=np.tile([0, 1.0, 0], (len(acc), 1)), where=length > 0).astype(np.float32)
