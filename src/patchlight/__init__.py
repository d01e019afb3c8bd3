"""patchlight: baked radiosity lightmaps and the classic real-time lighting models, on the CPU.

The Python API that the CLI calls:

    from patchlight import BakeSettings, load_scene
    from patchlight.bake import bake, write_bake

    scene = load_scene("room")                      # a built-in name or a .glb / .gltf path
    settings = BakeSettings(resolution=256)
    result = bake(scene, settings)
    result.lightmap                                 # (H, W, 3) float32 incident light
    write_bake(result, "out/room", settings)        # lightmap.exr/.png, scene.glb, bake.json
"""
from .config import BakeSettings
from .errors import PatchlightError
from .scene import Light, Material, Scene, SceneBuilder, Sky, load_scene
from .solved import SolvedScene, load_solved

__all__ = ["BakeSettings", "Light", "Material", "PatchlightError", "Scene", "SceneBuilder", "Sky",
           "SolvedScene", "load_scene", "load_solved"]
