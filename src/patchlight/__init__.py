"""patchlight: baked radiosity lightmaps and the classic real-time lighting models, on the CPU.

The Python API that the CLI calls:

    from patchlight import BakeSettings, load_scene
    from patchlight.bake import bake
    from patchlight.bakedir import write_bake

    scene = load_scene("room")                      # a built-in name or a .glb / .gltf path
    settings = BakeSettings(resolution=256)
    result = bake(scene, settings)
    result.lightmap                                 # (H, W, 3) float32 incident light
    write_bake(result, "out/room", settings)        # lightmap.exr/.png, scene.glb, bake.json

The names below are imported on first use, so `patchlight` (and the command line, which
installs its Ctrl-C handling first) starts without loading NumPy, numba or Embree.
"""
from importlib import import_module

_HOMES = {"BakeSettings": "config", "PatchlightError": "errors", "Light": "scene", "Material": "scene",
          "Scene": "scene", "SceneBuilder": "scene", "Sky": "scene", "load_scene": "scene",
          "SolvedScene": "solved", "load_solved": "solved"}
__all__ = sorted(_HOMES)


def __getattr__(name: str):
    if name not in _HOMES:
        raise AttributeError(f"module 'patchlight' has no attribute {name!r}")
    value = getattr(import_module(f".{_HOMES[name]}", __name__), name)
    globals()[name] = value
    return value
