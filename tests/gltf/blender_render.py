"""Renders a .blend with Cycles to a linear EXR (run by test_blender.py in its own process).
    python blender_render.py SCENE.blend OUT.exr SIZE"""
import sys

import bpy

blend, out, size = sys.argv[1], sys.argv[2], int(sys.argv[3])
bpy.ops.wm.open_mainfile(filepath=blend)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 4
scene.cycles.use_denoising = False
scene.cycles.filter_width = 0.01  # every sample at the pixel's centre, as the CPU renderer's rays
scene.render.resolution_x = scene.render.resolution_y = size
scene.render.resolution_percentage = 100
scene.render.film_transparent = True
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
