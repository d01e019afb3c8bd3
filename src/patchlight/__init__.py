"""patchlight: baked radiosity lightmaps and the classic real-time lighting models, on the CPU.

The Python API the CLI calls:

    import patchlight
    scene = patchlight.load_scene("room")                 # or a .glb / .gltf path
    settings = patchlight.BakeSettings(resolution=256)
    result = patchlight.bake(scene, settings)
    result.lightmap                                       # (H, W, 3) float32 incident light
    patchlight.write_bake(result, "out/room", settings)  # EXR, PNG, glTF, bake.json
"""
from .bake import BakeResult, bake, write_bake
from .config import BakeSettings
from .errors import PatchlightError
from .scene import Light, Material, Scene, SceneBuilder, Sky, load_scene
from .solved import SolvedScene, load_solved

__all__ = ["BakeResult", "BakeSettings", "Light", "Material", "PatchlightError", "Scene", "SceneBuilder",
           "Sky", "SolvedScene", "bake", "load_scene", "load_solved", "write_bake"]
