"""What the subcommands share: option groups, and loading what the flags name (the parsers of
flag values: values.py)."""
from __future__ import annotations

import argparse
from dataclasses import fields
from pathlib import Path

import numpy as np

from ..config import FALLOFFS, PLAIN_UNITS, BakeSettings, accepted
from ..errors import PatchlightError
from ..shading.hemisphere_radiosity import OFFSET_MODES
from ..shading.models import ShadingSettings
from .parser import finite_number
from .values import parse_light_spec, parse_rgb

DEFAULTS = BakeSettings()


def about(name: str, settings=BakeSettings) -> str:
    """The --help text of the flag that sets field `name` of a settings class: its meaning,
    unit, what it accepts and its default, from the field's metadata (config.setting)."""
    field = declared_field(name, settings)
    meta = field.metadata
    unit = "" if meta["unit"] in PLAIN_UNITS else f", {meta['unit']}"
    accepts = accepted(meta)
    if meta["unit"] == "bool":
        return meta["meaning"]
    default = "" if meta["none"] and field.default is None else " (default %(default)s)"  # "unset (...)" says it
    return f"{meta['meaning']}{unit}" + (f"; {accepts}" if accepts else "") + default


def declared_field(name: str, settings=BakeSettings):
    """The dataclass field `name` of a settings class (its declaration in .metadata)."""
    return next(f for f in fields(settings) if f.name == name)


def add_scene_options(p: argparse.ArgumentParser, settings=BakeSettings) -> None:
    """Sky and light options shared by every command that lights a scene; the help texts of
    --falloff and --sun-angle from those fields of `settings`."""
    sky = p.add_mutually_exclusive_group()
    sky.add_argument("--sky", type=parse_rgb, metavar="R,G,B", help="uniform sky radiance")
    sky.add_argument("--sky-gradient", type=parse_rgb, nargs=3, metavar=("ZENITH", "HORIZON", "GROUND"),
                     help="sky radiance at the zenith, at the horizon and below it (three R,G,B)")
    sky.add_argument("--sky-image", type=Path, metavar="FILE", help="equirectangular .exr or .hdr sky")
    p.add_argument("--falloff", choices=FALLOFFS, default=settings.falloff, help=about("falloff", settings))
    p.add_argument("--sun-angle", type=finite_number, metavar="DEG", help=about("sun_angle", settings))


def add_shading_options(p: argparse.ArgumentParser) -> None:
    """Options shared by `render` and `view`: lights, surroundings and the model options."""
    p.add_argument("--light", action="append", metavar="SPEC",
                   help="replace the scene's lights (repeatable): dir:DX,DY,DZ:R,G,B:E | "
                        "point:X,Y,Z:R,G,B:J[:RANGE] | spot:X,Y,Z:DX,DY,DZ:R,G,B:J:OUTER[:INNER[:RANGE]] "
                        "(E in W/m^2, J in W/sr, angles in degrees)")
    p.add_argument("--falloff", choices=FALLOFFS, default="inverse-square",
                   help="point/spot falloff for lights that name none (default %(default)s)")
    sky = p.add_mutually_exclusive_group()  # add_scene_options' flags, read by sky_from_args
    sky.add_argument("--sky", type=parse_rgb, metavar="R,G,B", help="replace the scene's sky: uniform radiance")
    sky.add_argument("--sky-gradient", type=parse_rgb, nargs=3, metavar=("ZENITH", "HORIZON", "GROUND"),
                     help="replace the scene's sky: radiance at the zenith, the horizon and below it")
    sky.add_argument("--sky-image", type=Path, metavar="FILE",
                     help="replace the scene's sky: an equirectangular .exr or .hdr")
    p.add_argument("--ambient", type=parse_rgb, metavar="R,G,B",
                   help="ambient incident light (default: from the sky, else 0.05 grey)")
    p.add_argument("--reflectivity", type=finite_number, metavar="K", help=about("reflectivity", ShadingSettings))
    p.add_argument("--specular", dest="lightmap_specular", action="store_true",
                   help=about("lightmap_specular", ShadingSettings))
    p.add_argument("--normal-map", nargs="?", const=True, default=False, type=Path, metavar="PNG",
                   help=f"{declared_field('normal_map', ShadingSettings).metadata['meaning']}: the materials' own, "
                        "or this tangent-space image (e.g. from `patchlight normalmap`) for every material")
    p.add_argument("--per-vertex", action="store_true", help=about("per_vertex", ShadingSettings))
    p.add_argument("--volume", type=Path, metavar="DIR",
                   help="ambient-cube model: the light volume (default: the bake directory's, if it holds one)")
    p.add_argument("--naive-weights", dest="ambient_cube_naive", action="store_true",
                   help=about("ambient_cube_naive", ShadingSettings))
    p.add_argument("--offset-mode", choices=OFFSET_MODES, metavar="normal|side|none",
                   help="hemisphere-radiosity model: where a ground map directory's map is sampled, offset along "
                        "the normal, its left-right part only, or not at all (default: the map's groundmap.json)")


def sky_from_args(args):
    """The Sky the --sky / --sky-gradient / --sky-image flags ask for, or None (keep the scene's)."""
    from ..scene import Sky

    if args.sky is not None:
        return Sky.uniform(args.sky)
    if args.sky_gradient is not None:
        return Sky.gradient(*args.sky_gradient)
    if args.sky_image is not None:
        from ..imaging.io import read_environment

        return Sky.from_image(read_environment(args.sky_image), source=args.sky_image)
    return None


def load_lit_scene(args):
    """The scene named on the command line, with the sky the flags give and the lights
    --keep-lights names kept dynamic."""
    from ..inputs import open_input

    scene = open_input(args.scene).scene()
    sky = sky_from_args(args)
    if sky is not None:
        scene.sky = sky
    if getattr(args, "keep_lights", None):
        scene.lights = keep_dynamic(scene.lights, args.keep_lights, scene.label)
    return scene


def keep_dynamic(lights, names: str, where: str):
    """The lights with those named in `names` ("all", or comma-separated light names) marked
    dynamic (baked False); PatchlightError for a name no light has."""
    from dataclasses import replace

    if names == "all":
        return [replace(light, baked=False) for light in lights]
    wanted = {name.strip() for name in names.split(",") if name.strip()}
    unknown = wanted - {light.name for light in lights}
    if unknown:
        known = ", ".join(sorted({light.name for light in lights if light.name})) or "none has a name"
        raise PatchlightError(f"--keep-lights: {where} has no light named {', '.join(sorted(unknown))} (lights: {known})")
    return [replace(light, baked=False) if light.name in wanted else light for light in lights]


def load_target_and_settings(args, model: str | None):
    """The target the arguments name and its ShadingSettings (exposure left at 1). A ground
    map directory names its bake, with the map as the hemisphere-radiosity model's. model None:
    lightmap when the target has one (a bake), else lambert."""
    from ..inputs import open_input
    from ..render.settings import target_settings

    target, ground_map = open_input(args.target).target(args.offset_mode)
    sky = sky_from_args(args)
    if sky is not None:
        target.scene.sky = sky
    lights = None if args.light is None else [parse_light_spec(spec) for spec in args.light]
    if isinstance(args.normal_map, Path):
        use_normal_map(target, args.normal_map)
    if args.normal_map and all(m.normal_texture is None for m in target.scene.materials):
        raise PatchlightError(f"--normal-map: no material of {target.name} has a normal texture")
    if model is None:
        model = "lightmap" if target.lightmap is not None else "lambert"
    settings = target_settings(target, model=model, lights=lights, falloff=args.falloff, ambient=args.ambient,
                               per_vertex=args.per_vertex, normal_map=bool(args.normal_map),
                               lightmap_specular=args.lightmap_specular, reflectivity=args.reflectivity,
                               ground_map=ground_map, volume=target_volume(args.volume, target),
                               ambient_cube_naive=args.ambient_cube_naive)
    return target, settings


def target_volume(spec, target):
    """The ambient-cube model's light volume: --volume's, else the one the target's bake
    directory holds, else None."""
    from ..inputs import open_input

    if spec is not None:
        return open_input(spec, wanted="volume").volume()
    return None if target.bake_dir is None else open_input(target.bake_dir).volume(required=False)


def use_normal_map(target, path: Path) -> None:
    """Give every material of `target` the normal map image at `path` (RGB, stored values)."""
    from ..imaging.io import read_image

    image = read_image(path)
    if image.shape[2] < 3:
        raise PatchlightError(f"--normal-map {path}: a normal map needs RGB channels, the image has {image.shape[2]}")
    for material in target.scene.materials:
        material.normal_texture = np.ascontiguousarray(image[..., :3])


def load_solved_from_args(args, quiet: bool):
    """The solved scene the arguments name, baked now (default settings, the flags' falloff
    and sun angle) when it is not a bake directory."""
    from ..config import BakeSettings
    from ..inputs import open_input

    settings = BakeSettings(falloff=args.falloff, sun_angle=args.sun_angle)
    return open_input(args.scene).solved(settings, sky=sky_from_args(args), quiet=quiet)


