"""Scenes: the data model, glTF I/O and the built-in scenes."""
from __future__ import annotations

from pathlib import Path

from ..errors import PatchlightError
from .builtin import SceneBuilder, cornell, room
from .model import Light, Material, Scene
from .sky import Sky
from .track import track

__all__ = ["BUILTIN_SCENES", "Light", "Material", "Scene", "SceneBuilder", "Sky", "is_builtin", "load_scene"]

BUILTIN_SCENES = {"room": room, "cornell": cornell, "track": track}  # name -> function making the scene


def is_builtin(spec: str | Path) -> bool:
    """The bare name of a built-in scene ("room", "cornell", "track"). It always means the
    built-in, even beside a file or folder of that name: write "./room" for those."""
    return isinstance(spec, str) and spec in BUILTIN_SCENES


def load_scene(spec: str | Path) -> Scene:
    """A built-in scene by name (`is_builtin`) or a .glb/.gltf file by path."""
    if is_builtin(spec):
        return BUILTIN_SCENES[spec]()
    path = Path(spec)
    if path.suffix.lower() not in (".glb", ".gltf"):
        if not path.exists():
            raise PatchlightError(f"{spec}: no such file, and not a built-in scene ({', '.join(BUILTIN_SCENES)})")
        raise PatchlightError(f"{spec}: not a glTF file (expected .glb or .gltf)")
    from .gltf import load_gltf

    return load_gltf(path)
