"""What a name or path on the command line stands for: the one place that decides.

`open_input(spec)` classifies it once, as one of

    builtin    a built-in scene's name (room, cornell, track): always the built-in, even beside
               a file or folder of that name (write ./room for those)
    scene      a .glb or .gltf file
    bake       a complete bake directory (patchlight.bakedir)
    groundmap  a ground map directory (groundmap.json), which names the bake it lies over (or
               holds it)
    volume     a light volume: a directory holding light_volume.json (not a bake), or that file

and each command asks the Input for what it works on: `scene()` (to bake), `solved()` (light
volumes, vertex colours, ground maps), `target()` (render, view) or `volume()` (the
ambient-cube model's light volume: a volume's, or one a bake directory holds). A missing path,
a file that is not glTF or a directory that is none of these is a one-line PatchlightError.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from . import bakedir
from .errors import PatchlightError, SettingError
from .scene import is_builtin

KINDS = ("builtin", "scene", "bake", "groundmap", "volume")


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

    def volume(self, required: bool = True):
        """The light volume (patchlight.volumes.LightVolume) this names: a volume's, or the one
        a bake directory holds (`patchlight volume BAKE -o BAKE`); None when a bake holds none
        and it is not `required`."""
        from .volumes.io import HEADER, read_volume

        if self.kind == "volume" or (self.kind == "bake" and (required or (self.path / HEADER).is_file())):
            return read_volume(self.path)
        if required:
            raise PatchlightError(f"{self.spec}: not a light volume (write one with `patchlight volume`)")
        return None

    def target(self, offset_mode: str | None = None):
        """(patchlight.render.Target, the ground map or None) for render and view: a ground map
        directory is its bake plus the map (offset_mode, when given, replacing the map's
        recorded one); a bake directory is its scene with the lightmap; a scene is never baked."""
        from .ground.viewer import ground_map_target
        from .render.target import Target
        from .solved import load_solved
        from .bakedir import read_texels

        ground_map, shown = None, self.path
        if self.kind == "groundmap":
            shown, ground_map = ground_map_target(self.path, offset_mode)
        elif offset_mode is not None:
            raise SettingError("offset_mode", offset_mode, f"is for ground maps: {self.spec} is not a ground map "
                               f"directory (the mode moves where a baked ground map is sampled; make one with "
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


def open_input(spec: str | Path, wanted: str = "bake") -> Input:
    """What `spec` stands for (module docstring), or a one-line PatchlightError. wanted: what
    a directory that is none of the kinds is taken for, so the error names what it lacks
    ("bake" or "volume")."""
    from .ground.files import is_groundmap_dir
    from .volumes.io import HEADER

    if is_builtin(spec):
        return Input(str(spec), "builtin")
    path = Path(spec)
    if path.name == HEADER and not path.is_dir():
        return Input(str(spec), "volume", path)
    if not path.is_dir():
        return Input(str(spec), "scene", path)  # load_scene says what is wrong with a bad one
    if is_groundmap_dir(path):
        return Input(str(spec), "groundmap", path)
    if ((path / HEADER).is_file() or wanted == "volume") and not bakedir.is_bake_dir(path):
        return Input(str(spec), "volume", path)
    return Input(str(spec), "bake", bakedir.require_bake_dir(path))
