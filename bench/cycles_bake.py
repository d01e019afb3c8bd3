"""Bake one scene's lightmap with Blender Cycles; run by bench_vs_cycles.py with the Python of
.venv-cycles (which has bpy), never by patchlight.

  python cycles_bake.py SCENE.glb SIDECAR.json OUT.npy --samples N --resolution R

The sidecar (JSON) gives what glTF cannot carry or Blender's importer changes: `world`
(uniform sky colour, strength), `lights` (per sun: blender_strength, color, angle_deg) and
`materials` (per name: albedo, optional emission_radiance). Every material becomes a pure
Lambert diffuse (plus emission), so Cycles computes what patchlight does. The bake is
Cycles' DIFFUSE pass, direct + indirect, without the colour: incident light E / pi per
texel of TEXCOORD_1, 4 diffuse bounces. OUT.npy gets (R, R, 4) float32, row 0 = v 0;
the last line on stdout is JSON with the bake's seconds (bpy.ops.object.bake alone).
"""
import argparse
import json
import math
import time

import numpy as np


def lambert(material, albedo, emission):
    """Replace a material's nodes by Lambert diffuse of `albedo`, plus `emission` radiance."""
    tree = material.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = [*albedo, 1.0]
    diffuse.inputs["Roughness"].default_value = 0.0
    shader = diffuse.outputs[0]
    if max(emission) > 0:
        glow = tree.nodes.new("ShaderNodeEmission")
        glow.inputs["Color"].default_value = [*emission, 1.0]
        glow.inputs["Strength"].default_value = 1.0
        both = tree.nodes.new("ShaderNodeAddShader")
        tree.links.new(shader, both.inputs[0])
        tree.links.new(glow.outputs[0], both.inputs[1])
        shader = both.outputs[0]
    tree.links.new(shader, out.inputs["Surface"])


def set_world(scene, colour, strength):
    """A uniform background of radiance colour x strength."""
    import bpy

    scene.world = scene.world or bpy.data.worlds.new("World")
    scene.world.use_nodes = True
    tree = scene.world.node_tree
    tree.nodes.clear()
    background = tree.nodes.new("ShaderNodeBackground")
    background.inputs["Color"].default_value = [*colour, 1.0]
    background.inputs["Strength"].default_value = strength
    tree.links.new(background.outputs[0], tree.nodes.new("ShaderNodeOutputWorld").inputs["Surface"])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("sidecar")
    ap.add_argument("out")
    ap.add_argument("--samples", type=int, required=True)
    ap.add_argument("--resolution", type=int, required=True)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    import bpy

    side = json.load(open(args.sidecar))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.import_scene.gltf(filepath=args.scene)
    world = side.get("world", {})
    set_world(scene, world.get("color", [0, 0, 0]), world.get("strength", 0.0))
    suns = [o for o in scene.objects if o.type == "LIGHT" and o.data.type == "SUN"]
    for sun, spec in zip(suns, [s for s in side.get("lights", []) if s["type"] == "directional"]):
        sun.data.energy, sun.data.color = spec["blender_strength"], spec["color"]
        sun.data.angle = math.radians(spec.get("angle_deg", 0.0))
    for material in bpy.data.materials:
        spec = side.get("materials", {}).get(material.name, {})
        if material.node_tree is not None:
            lambert(material, spec.get("albedo", [0.8] * 3), spec.get("emission_radiance", [0.0] * 3))

    meshes = [o for o in scene.objects if o.type == "MESH"]
    bpy.ops.object.select_all(action="DESELECT")
    for o in meshes:
        o.select_set(True)
    bpy.context.view_layer.objects.active = meshes[0]
    if len(meshes) > 1:
        bpy.ops.object.join()
    mesh = bpy.context.view_layer.objects.active.data
    lightmap_uv = mesh.uv_layers[-1].name  # TEXCOORD_1 comes in after TEXCOORD_0
    r = args.resolution
    image = bpy.data.images.new("lightmap", r, r, alpha=True, float_buffer=True)
    for material in mesh.materials:
        node = material.node_tree.nodes.new("ShaderNodeTexImage")
        node.image = image
        material.node_tree.nodes.active = node

    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device, cycles.samples, cycles.seed = "CPU", args.samples, 1
    scene.render.threads_mode, scene.render.threads = "FIXED", args.threads
    cycles.use_adaptive_sampling = cycles.use_denoising = False
    cycles.max_bounces = cycles.diffuse_bounces = 4
    cycles.glossy_bounces = cycles.transmission_bounces = cycles.volume_bounces = 0
    cycles.transparent_max_bounces = 0
    cycles.sample_clamp_direct = cycles.sample_clamp_indirect = 0.0
    cycles.light_sampling_threshold = 0.0
    start = time.perf_counter()
    bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT"}, margin=0, use_clear=True,
                        uv_layer=lightmap_uv, target="IMAGE_TEXTURES")
    seconds = time.perf_counter() - start
    pixels = np.empty(r * r * 4, np.float32)
    image.pixels.foreach_get(pixels)
    np.save(args.out, pixels.reshape(r, r, 4)[::-1].copy())  # Blender's rows run bottom up
    print(json.dumps({"bake_seconds": seconds, "samples": args.samples}))


if __name__ == "__main__":
    main()
