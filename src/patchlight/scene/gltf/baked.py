"""What both writers put into a baked .glb: the lightmap textures and their description, the
directional lightmap's (the package docstring, "Export"), the unlit marker of vertex-baked
light."""
from __future__ import annotations

import math

import numpy as np

from ...imaging.lightmap import EncodedDirectional, EncodedLightmap
from .container import CLAMP_TO_EDGE, LINEAR_FILTER

UNLIT = "KHR_materials_unlit"  # vertex-baked light: viewers show base colour x COLOR_0 as it is
MOZ_LIGHTMAP, MOZ_RGBE = "MOZ_lightmap", "MOZ_texture_rgbe"  # the lightmap, and its HDR image
HDR_MIME = "image/vnd.radiance"
LIGHTMAP_NAME = "patchlight_lightmap"
LIGHTMAP_HDR_NAME = "patchlight_lightmap_hdr"
DIRECTIONAL = "PATCHLIGHT_lightmap_directional"  # a material's directional lightmap (package docstring)
EXR = "PATCHLIGHT_texture_exr"  # a texture's EXR image (its source: none a stock viewer could decode)
EXR_MIME = "image/x-exr"
DIRECTIONAL_NAME = "patchlight_directional"  # + "_" + layer: the directional textures and images
LIGHTMAP_SAMPLER = {"magFilter": LINEAR_FILTER, "minFilter": LINEAR_FILTER,
                     "wrapS": CLAMP_TO_EDGE, "wrapT": CLAMP_TO_EDGE}


def lightmap_description(pages: list[EncodedLightmap], meta: dict) -> dict:
    """extras.patchlight.lightmap of the lightmap's atlases, without the texture index (one
    atlas: "texture") or indices (several: "textures", atlas by atlas); ValueError for bad
    images or scales."""
    for lightmap in pages:
        if not lightmap.png.startswith(b"\x89PNG\r\n\x1a\n") or not lightmap.hdr.startswith(b"#?"):
            raise ValueError("save_baked_glb: the lightmap needs PNG and Radiance .hdr bytes")
        if not 0 < lightmap.scale < math.inf or lightmap.scale != pages[0].scale:
            raise ValueError(f"save_baked_glb: the lightmap's scale must be positive and the same for every atlas, "
                             f"got {lightmap.scale!r}")
    where = {"texture": None} if len(pages) == 1 else {"textures": [None] * len(pages)}
    return {**jsonable(meta), **where, "texCoord": 1, "scale": pages[0].scale,
            "intensity": _lightmap_intensity(pages[0])}


def lightmap_pages(lightmap):
    """save_baked_glb's lightmap (or directional lightmap): one, or a list of one per atlas,
    as a list of atlases."""
    return list(lightmap) if isinstance(lightmap, list) else [lightmap]


def atlas_of_materials(extras, material_extensions: list) -> tuple[int, dict[int, int]]:
    """(count, {material index: atlas}): a scene.glb's lightmap atlases (root `extras`
    .patchlight.lightmap "textures") and the atlas each material's MOZ_lightmap texture is;
    (1, {}) for a lightmap of one atlas or none."""
    patchlight = extras.get("patchlight") if isinstance(extras, dict) else None
    description = patchlight.get("lightmap") if isinstance(patchlight, dict) else None
    textures = description.get("textures") if isinstance(description, dict) else None
    if not isinstance(textures, list) or len(textures) < 2:
        return 1, {}
    atlas = {texture: k for k, texture in enumerate(textures) if isinstance(texture, int)}
    out = {}
    for number, extensions in enumerate(material_extensions):
        reference = extensions.get(MOZ_LIGHTMAP) if isinstance(extensions, dict) else None
        if isinstance(reference, dict) and isinstance(reference.get("index"), int) and reference["index"] in atlas:
            out[number] = atlas[reference["index"]]
    return len(textures), out


def atlas_material(materials: list, number: int, atlas: int, name: str, first: dict[int, int],
                   copies: dict[tuple[int, int], int], duplicate) -> int:
    """The material a primitive of material `number` on atlas `atlas` uses: `number` itself on the
    first atlas it is drawn on (first: material -> that atlas), else its copy for this atlas,
    "<name> (atlas k)", appended to `materials` once (copies: (number, atlas) -> the copy) as
    duplicate(material, copy's name)."""
    if first.setdefault(number, atlas) == atlas:
        return number
    if (number, atlas) not in copies:
        materials.append(duplicate(materials[number], f"{name} (atlas {atlas})"))
        copies[number, atlas] = len(materials) - 1
    return copies[number, atlas]


def _lightmap_intensity(lightmap: EncodedLightmap) -> float:
    """MOZ_lightmap's intensity: texel x scale is I; three.js's lightMap is irradiance pi I."""
    return math.pi * lightmap.scale


def lightmap_reference(texture: int, lightmap: EncodedLightmap) -> dict:
    """A material's MOZ_lightmap extension."""
    return {"index": texture, "texCoord": 1, "intensity": _lightmap_intensity(lightmap)}


def lightmap_occlusion(texture: int) -> dict:
    """The occlusionTexture a lightmapped material without one of its own gets: the lightmap
    at strength 0, glTF's exact no-op (occlusion = 1 + strength x (texel - 1)). It shades
    nothing; validators and tools that prune unused data see the lightmap texture and
    TEXCOORD_1 as used (they do not know MOZ_lightmap)."""
    return {"index": texture, "texCoord": 1, "strength": 0.0}


def is_lightmap_occlusion(material: dict) -> bool:
    """Whether a material's (JSON) occlusionTexture is the stand-in of `lightmap_occlusion`, by
    the package docstring's rule: strength 0 and the texture of the material's MOZ_lightmap."""
    occlusion = material.get("occlusionTexture")
    lightmap = (material.get("extensions") or {}).get(MOZ_LIGHTMAP)
    return (isinstance(occlusion, dict) and isinstance(lightmap, dict) and occlusion.get("strength") == 0
            and isinstance(occlusion.get("index"), int) and occlusion["index"] == lightmap.get("index"))


def directional_name(layer: str, atlas: int | None = None) -> str:
    """The name of a directional layer's texture and image ("" : the dominant direction), of
    atlas `atlas` in a bake of several."""
    name = f"{DIRECTIONAL_NAME}_{layer}" if layer else DIRECTIONAL_NAME
    return name if atlas is None else f"{name}_atlas{atlas}"


def is_bake_map(item) -> bool:
    """Whether a texture or image (JSON) is one a bake writes, the lightmap's or a directional
    layer's, by its name (a re-bake drops those nothing refers to any more)."""
    name = item.get("name") if isinstance(item, dict) else None
    return isinstance(name, str) and (name in (LIGHTMAP_NAME, LIGHTMAP_HDR_NAME, DIRECTIONAL_NAME)
                                      or name.startswith(DIRECTIONAL_NAME + "_"))


def directional_reference(textures: list[int], directional: EncodedDirectional) -> dict:
    """A material's PATCHLIGHT_lightmap_directional extension: the layers' textures in order."""
    return {"mode": directional.mode, "maps": [{"index": t, "texCoord": 1} for t in textures],
            "scale": directional.scale}


def jsonable(value):
    """Numpy scalars and arrays inside dicts/lists turned into plain JSON values."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value
