"""A bake as a Blender file (`patchlight blender BAKE_DIR -o scene.blend`), through bpy.

bpy is an optional extra (`pip install patchlight[blender]`); this module imports it only when
called. The .blend holds scene.glb as Blender's glTF importer brings it in, with:
- `lightmap.exr` (float incident light I, linear) as an image (with several atlases each
  material gets its own atlas's file, lightmap_0.exr, ...), read through the lightmap UV map
  (glTF's TEXCOORD_1; the importer turns v into 1 - v, as Blender's images have their top
  row at v = 1, so the EXR, top row first, is read upright as it is);
- every material of a lightmapped mesh drawing Emission = base colour x lightmap + its own
  emission, strength 1, straight into the Material Output: the radiance rho x I of a diffuse
  surface under the baked light, the same in Cycles and Eevee. The importer's Principled BSDF
  stays in the node tree, unlinked, for anyone who wants to light the scene again;
- the lights scene.glb marks baked removed (their light is in the lightmap), dynamic ones kept;
- the file's camera as the scene camera, and the Standard view transform (no tone curve).
"""
from __future__ import annotations

import json
import os
import secrets
from pathlib import Path

from . import bakedir
from .errors import PatchlightError
from .imaging.io import read_bytes

LIGHTMAP_IMAGE = "patchlight_lightmap"


def import_bpy():
    """The bpy module, or PatchlightError saying how to install it."""
    try:
        import bpy
    except ImportError:
        raise PatchlightError("Blender's bpy module is not installed: pip install 'patchlight[blender]' "
                              "(bpy needs the Python version Blender was built for)") from None
    return bpy


def glb_json(glb: Path) -> dict:
    """scene.glb's JSON (its GLB container read by scene.gltf's own reader)."""
    from .scene.gltf.container import split_glb

    return json.loads(split_glb(read_bytes(glb), glb)[0])


def atlas_of_material_names(doc: dict) -> dict[str, int]:
    """The lightmap atlas of each material of scene.glb (its JSON `doc`), by name (as Blender's
    importer names them)."""
    from .scene.gltf.baked import atlas_of_materials

    materials = doc.get("materials") or []
    _, atlas_of = atlas_of_materials(doc.get("extras"), [m.get("extensions") for m in materials])
    return {materials[number].get("name") or f"material {number}": atlas for number, atlas in atlas_of.items()}


def baked_light_nodes(doc: dict) -> set[str]:
    """Names of the nodes of scene.glb (its JSON `doc`) that carry a light marked baked
    (extras.baked)."""
    lights = ((doc.get("extensions") or {}).get("KHR_lights_punctual") or {}).get("lights") or []
    names = set()
    for number, node in enumerate(doc.get("nodes") or []):
        light = ((node.get("extensions") or {}).get("KHR_lights_punctual") or {}).get("light")
        if isinstance(light, int) and 0 <= light < len(lights) and (lights[light].get("extras") or {}).get("baked"):
            names.add(node.get("name") or f"node {number}")
    return names


def write_blend(bake_dir, out) -> Path:
    """Import the bake in `bake_dir` into an empty Blender scene, wire its lightmap and save
    `out` (.blend) atomically (module docstring); returns the path."""
    bake_dir, out = Path(bake_dir), Path(out)
    glb = bake_dir / bakedir.SCENE
    count = bakedir.atlas_count(bake_dir)  # 1 without bake.json
    exrs = [bake_dir / name for name in bakedir.atlas_files(bakedir.LIGHTMAP, count)]
    for needed in (glb, *exrs):
        if not needed.is_file():
            raise PatchlightError(f"{bake_dir}: not a bake directory ({needed.name} is missing)")
    if out.suffix.lower() != ".blend":
        raise PatchlightError(f"-o {out}: the output must be a .blend file")
    if not out.parent.resolve().is_dir():
        raise PatchlightError(f"-o {out}: directory {out.parent} does not exist")
    bpy = import_bpy()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if bpy.ops.import_scene.gltf(filepath=str(glb.resolve())) != {"FINISHED"}:
        raise PatchlightError(f"{glb}: Blender's glTF importer failed")
    images = []
    for number, exr in enumerate(exrs):
        images.append(bpy.data.images.load(str(exr.resolve())))
        images[-1].name = LIGHTMAP_IMAGE if count == 1 else f"{LIGHTMAP_IMAGE}_{number}"
        images[-1].colorspace_settings.name = "Non-Color"  # linear data, as stored
    doc = glb_json(glb)
    atlas_of = atlas_of_material_names(doc)
    materials = {}
    for obj in bpy.context.scene.objects:
        if obj.type == "MESH" and len(obj.data.uv_layers) >= 2:
            for slot in obj.material_slots:
                if slot.material is not None:
                    materials.setdefault(slot.material.name, (slot.material, obj.data.uv_layers[1].name))
    if not materials:
        raise PatchlightError(f"{glb}: no mesh has lightmap UVs (TEXCOORD_1)")
    for material, uv_map in materials.values():
        wire_lightmap(material, images[atlas_of.get(material.name, 0)], uv_map)
    baked = baked_light_nodes(doc)
    for obj in [o for o in bpy.context.scene.objects if o.type == "LIGHT" and o.name in baked]:
        bpy.data.objects.remove(obj, do_unlink=True)
    cameras = [o for o in bpy.context.scene.objects if o.type == "CAMERA"]
    if cameras:
        bpy.context.scene.camera = cameras[0]
    bpy.context.scene.view_settings.view_transform = "Standard"
    tmp = out.with_name(f".{out.stem}.{os.getpid()}-{secrets.token_hex(4)}.tmp.blend")
    try:
        bpy.ops.wm.save_as_mainfile(filepath=str(tmp.resolve()), check_existing=False)
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return out


def wire_lightmap(material, image, uv_map: str) -> None:
    """Material Output <- Emission(base colour x lightmap(uv_map) + emission); the importer's
    Principled BSDF (base colour, emission) is read and left in place, unlinked."""
    tree = material.node_tree
    nodes, links = tree.nodes, tree.links
    bsdf = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
    output = next((n for n in nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output), None)
    if bsdf is None or output is None:
        raise PatchlightError(f"material {material.name!r}: no Principled BSDF and Material Output to wire")
    uv = nodes.new("ShaderNodeUVMap")
    uv.uv_map = uv_map
    texture = nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation, texture.extension = image, "Linear", "EXTEND"
    links.new(uv.outputs["UV"], texture.inputs["Vector"])
    lit = nodes.new("ShaderNodeVectorMath")
    lit.operation = "MULTIPLY_ADD"  # base x lightmap + emission
    feed(tree, bsdf.inputs["Base Color"], lit.inputs[0])
    links.new(texture.outputs["Color"], lit.inputs[1])
    own = nodes.new("ShaderNodeVectorMath")
    own.operation = "SCALE"  # emission colour x strength
    feed(tree, bsdf.inputs["Emission Color"], own.inputs[0])
    feed(tree, bsdf.inputs["Emission Strength"], own.inputs["Scale"])
    links.new(own.outputs["Vector"], lit.inputs[2])
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    links.new(lit.outputs["Vector"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], output.inputs["Surface"])


def feed(tree, source, target) -> None:
    """Give `target` what `source` (an input socket) gets: its link's origin, else its value."""
    if source.is_linked:
        tree.links.new(source.links[0].from_socket, target)
    elif hasattr(source.default_value, "__len__"):
        target.default_value = tuple(source.default_value)[:len(target.default_value)]
    else:
        target.default_value = source.default_value
