"""glTF 2.0 in (`load_gltf`) and the baked, lightmapped .glb out (`save_baked_glb`).

Modules: `container` (GLB chunks, data: URIs, buffers, accessors, the node tree), `reader` (the
document into a Scene), `preserving` (scene.glb as the input document plus the lightmap UVs,
through `editor`), `flattened` (a world-space copy), `baked` (what both writers add).

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
`save_baked_glb` writes one .glb.  For a scene loaded from a glTF file (`preserving`) it is
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
a diffuse surface turns into albedo / pi x irradiance = albedo x I), and, unless the material
has an occlusion map of its own (kept as it is), as

    "occlusionTexture": {"index": <texture>, "texCoord": 1, "strength": 0}

glTF's no-op (occlusion 1 + strength x (texel - 1) = 1), so that validators and pruning tools,
which do not know MOZ_lightmap, see the texture and TEXCOORD_1 used.  The rule that tells this
stand-in from a material's own occlusion map (a re-bake replaces it, a vertex bake drops it,
the viewer's plugin does not sample it): strength 0 on the texture of the material's own
MOZ_lightmap.  The texture's source is
the 8-bit PNG any viewer can read; its MOZ_texture_rgbe extension names the HDR Radiance .hdr
image (mimeType image/vnd.radiance) that three.js's HDRLoader decodes
(`viewer/static/patchlight_gltf.js`, the GLTFLoader plugin, does it).  The texture is linear
data, no sRGB, no mipmaps, v = 0 at the top.  The root `extras` describe it:

    {"patchlight": {"lightmap": {"texture": <texture index>, "texCoord": 1, "scale": <float>,
                                 "intensity": pi x scale, ...the caller's metadata}}}

A directional bake (`directional`: `imaging.lightmap.EncodedDirectional`) adds, on the same
materials (listed in extensionsUsed, never required: a viewer without it shows the plain
lightmap),

    "extensions": {"PATCHLIGHT_lightmap_directional": {"mode": "sh" | "dominant",
                   "maps": [{"index": <texture>, "texCoord": 1}, ...], "scale": <float>}}

maps: sh: L0, L1x, L1y, L1z (the L1 spherical-harmonic coefficients of the incident radiance
per colour channel, world axes, `shading.directional`); dominant: the dominant direction
times its share. Texel x scale is the bake's value (`lightmap_sh.exr` / `lightmap_dir.exr`);
scale is the lightmap's for sh, 1 for dominant. Each texture ("patchlight_directional_L0",
..., or "patchlight_directional"; re-baking reuses them) has no core source, only
`"extensions": {"PATCHLIGHT_texture_exr": {"source": <image>}}`, a half-float ZIP EXR
(mimeType image/x-exr, 2^-11 relative precision, row 0 at v = 0) that three.js's EXRLoader
decodes; the lightmap's sampler.

save_baked_glb's `extras` go into the root extras.patchlight too (vertexbake's colorScale).

Several atlases (`Scene.atlases` > 1, uv1 stacked along v: `scene.model.stacked_uv1`): one
such texture per atlas, all of one scale; TEXCOORD_1 written in each vertex's own atlas; each
material references its atlas's texture, a material drawn on several atlases getting a copy
per further atlas, "<name> (atlas k)"; the description lists "textures" (atlas by atlas)
instead of "texture". `load_gltf` stacks TEXCOORD_1 again from it (`baked.atlas_of_materials`).
The directional lightmap comes one set per atlas (textures "patchlight_directional_L0_atlas1",
...), each material naming its own atlas's.
"""
from __future__ import annotations

import warnings
from pathlib import Path

from ...errors import PatchlightError, PatchlightWarning
from ...imaging.io import atomic_path
from ...imaging.lightmap import EncodedDirectional, EncodedLightmap
from ..model import Scene
from .baked import lightmap_description, lightmap_pages
from .container import outside_files_allowed, outside_reason
from .flattened import flattened_glb
from .preserving import SourceWriter
from .reader import load_gltf

__all__ = ["load_gltf", "outside_files_allowed", "outside_reason", "save_baked_glb"]


def save_baked_glb(scene: Scene, path, lightmap: EncodedLightmap | list[EncodedLightmap] | None = None,
                   lightmap_meta: dict | None = None, unlit: bool = False, folder=None,
                   extras: dict | None = None, directional: EncodedDirectional | None = None) -> Path:
    """Write `scene` (and its lightmap, if given) as one .glb, atomically; returns the path.

    lightmap: one image, or one per atlas (`scene.atlases`, in order).
    lightmap_meta: JSON-able dict stored with the lightmap's description in the root extras.
    extras: JSON-able dict merged into the root extras.patchlight.  directional: the directional
    lightmap beside the lightmap (needs `lightmap`).  Layout: see the module docstring.
    unlit: mark every material KHR_materials_unlit (used, not required): the light is baked
    into COLOR_0, so viewers must not light it again. folder: the directory the file will end
    up in, when it is written elsewhere first (a staging directory): an image sky's path is
    made relative to it. A scene loaded from a glTF file is written as that file's document
    plus TEXCOORD_1 (`preserving`); a built-in scene, or one whose provenance no longer
    describes it (or that the writer cannot map back), as the flattened world-space copy
    (`flattened`), with a warning.
    """
    if lightmap is not None:
        if scene.uv1 is None:
            raise ValueError("save_baked_glb: a lightmap needs scene.uv1 (TEXCOORD_1)")
        lightmap = lightmap_pages(lightmap)
        if len(lightmap) != scene.atlases:
            raise ValueError(f"save_baked_glb: {len(lightmap)} lightmap images for {scene.atlases} atlases")
        lightmap_description(lightmap, lightmap_meta or {})  # refuse bad input before any work
        if directional is not None and len(lightmap_pages(directional)) != scene.atlases:
            raise ValueError(f"save_baked_glb: {len(lightmap_pages(directional))} directional maps for "
                             f"{scene.atlases} atlases")
    elif directional is not None:
        raise ValueError("save_baked_glb: a directional lightmap needs the lightmap")
    folder = Path(path).parent if folder is None else Path(folder)
    source, glb = SourceWriter.open(scene), None
    if isinstance(source, SourceWriter):
        try:
            glb = source.write(folder, lightmap, lightmap_meta or {}, unlit, extras or {}, directional)
        except (PatchlightError, ValueError) as exc:
            source = f"its file could not be rewritten ({exc})"
    if glb is None:
        if source is not None:
            warnings.warn(f"{scene.label}: {source}; {Path(path).name} written as a flattened copy",
                          PatchlightWarning, stacklevel=2)
        glb = flattened_glb(scene, folder, lightmap, lightmap_meta or {}, unlit, extras or {}, directional)
    with atomic_path(path) as tmp:
        tmp.write_bytes(glb)
    return Path(path)
