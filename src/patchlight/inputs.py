"""What a name or path on the command line stands for: the one place that decides.

`open_input(spec)` classifies it once, as one of

    builtin    a built-in scene's name (room, cornell, track): always the built-in, even beside
               a file or folder of that name (write ./room for those)
    scene      a .glb or .gltf file
    bake       a complete bake directory (patchlight.bakedir)
    groundmap  a ground map directory (groundmap.json), which names the bake it lies over (or
               holds it)

and each command asks the Input for what it works on: `scene()` (to bake), `solved()` (light
volumes, vertex colours, ground maps) or `target()` (render, view). A missing path, a file that
is not glTF or a directory that is none of these is a one-line PatchlightError.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from . import bakedir
from .errors import PatchlightError
from .scene import is_builtin

KINDS = ("builtin", "scene", "bake", "groundmap")


@dataclass(frozen=True)
class Input:
    """spec as given; kind: one of KINDS; path: the file or directory (None for a built-in)."""

    spec: str
    kind: str
    path: Path | None = None

    def scene(self):
        """The scene to bake: the built-in, the glTF file, or a bake's scene.glb (baked again)."""
        from .scene import load_scene

        if self.kind in ("builtin", "scene"):
            return load_scene(self.spec)
        return load_scene(bakedir.require_bake_dir(self.path) / bakedir.SCENE)

    def solved(self, settings=None, sky=None, quiet: bool = True):
        """The solved scene: the bake's, or the scene baked now with BakeSettings `settings`
        (patchlight.solved.load_solved); sky, when given, replaces the scene's."""
        from .solved import load_solved

        return load_solved(self.spec if self.kind == "builtin" else self.path, settings, sky=sky, quiet=quiet)

    def target(self, offset_mode: str | None = None):
        """(patchlight.render.Target, the ground map or None) for render and view: a ground map
        directory is its bake plus the map (offset_mode, when given, replacing the map's
        recorded one); a bake directory is its scene with the lightmap; a scene is never baked."""
        from .ground.viewer import ground_map_target
        from .render.target import Target
        from .shading.hemisphere_radiosity import OFFSET_MODES
        from .solved import load_solved
        from .bakedir import read_texels

        if offset_mode is not None and offset_mode not in OFFSET_MODES:
            raise PatchlightError(f"--offset-mode {offset_mode}: choose from {', '.join(OFFSET_MODES)}")
        ground_map, shown = None, self.path
        if self.kind == "groundmap":
            shown, ground_map = ground_map_target(self.path, offset_mode)
        elif offset_mode is not None:
            raise PatchlightError(f"--offset-mode {offset_mode}: {self.spec} is not a ground map directory (the "
                                  f"mode moves where a baked ground map is sampled; make one with "
                                  f"`patchlight groundmap`)")
        if self.kind in ("bake", "groundmap"):
            solved = load_solved(shown)
            target = Target.from_scene(solved.scene, solved.lightmap, Path(shown).resolve())
            target.directional = bakedir.read_directional(target.bake_dir)
            target.texels = read_texels(shown)
            if target.texels is not None and target.texels.status.shape != solved.lightmap.shape[:2]:
                raise PatchlightError(f"{shown}: texels.npz and lightmap.exr differ in size (a mixture of two bakes)")
            return target, ground_map
        return Target.from_scene(self.scene()), None


def open_input(spec: str | Path) -> Input:
    """What `spec` stands for (module docstring), or a one-line PatchlightError."""
    from .ground.files import is_groundmap_dir

    if is_builtin(spec):
        return Input(str(spec), "builtin")
    path = Path(spec)
    if not path.is_dir():
        return Input(str(spec), "scene", path)  # load_scene says what is wrong with a bad one
    if is_groundmap_dir(path):
        return Input(str(spec), "groundmap", path)
    return Input(str(spec), "bake", bakedir.require_bake_dir(path))
