"""`patchlight bake SCENE -o DIR`: converged radiosity lightmap of a glTF or built-in scene."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..config import DIRECTIONAL_MODES, FALLOFFS, GATHERS, BakeSettings
from ..errors import PatchlightError
from ..scene.model import MAX_LIGHT
from .parser import finite_number, writes_output

DEFAULTS = BakeSettings()
MAX_MEMORY_GIB = 1 << 20


def parse_rgb(text: str) -> tuple[float, float, float]:
    """'R,G,B' -> three floats in 0..MAX_LIGHT, or a one-line error."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(0 <= v <= MAX_LIGHT for v in values):
        raise argparse.ArgumentTypeError(f"expected R,G,B (three numbers in 0..{MAX_LIGHT:g}), got {text!r}")
    return values


def add_scene_options(p: argparse.ArgumentParser) -> None:
    """Sky and light options shared by every command that lights a scene."""
    sky = p.add_mutually_exclusive_group()
    sky.add_argument("--sky", type=parse_rgb, metavar="R,G,B", help="uniform sky radiance")
    sky.add_argument("--sky-gradient", type=parse_rgb, nargs=3, metavar=("ZENITH", "HORIZON", "GROUND"),
                     help="sky radiance at the zenith, at the horizon and below it (three R,G,B)")
    sky.add_argument("--sky-image", type=Path, metavar="FILE", help="equirectangular .exr or .hdr sky")
    p.add_argument("--falloff", choices=FALLOFFS, default=DEFAULTS.falloff,
                   help="point/spot falloff for lights that name none (default %(default)s)")
    p.add_argument("--sun-angle", type=finite_number, metavar="DEG", help="sun's angular diameter, soft shadows")


def register(sub) -> None:
    p = sub.add_parser("bake", help="bake a radiosity lightmap", description=__doc__)
    p.add_argument("scene", help="a .glb/.gltf file or a built-in scene: room, cornell")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="DIR")
    add_bake_options(p)
    p.set_defaults(func=writes_output(run))


def add_bake_options(p: argparse.ArgumentParser) -> None:
    add_scene_options(p)
    p.add_argument("--keep-lights", nargs="?", const="all", metavar="NAME,...",
                   help="leave these lights (by name, or all when no names are given) out of the bake: they stay "
                        "dynamic, unmarked in scene.glb, for the runtime to light")
    size = p.add_mutually_exclusive_group()
    size.add_argument("--resolution", type=int, metavar="N", help="lightmap width = height in texels (16..8192)")
    size.add_argument("--texels-per-unit", type=finite_number, default=DEFAULTS.texels_per_unit, metavar="T")
    p.add_argument("--gather", choices=GATHERS, default=DEFAULTS.gather)
    p.add_argument("--hemicube-size", type=int, default=DEFAULTS.hemicube_size, metavar="N")
    p.add_argument("--rays", type=int, default=DEFAULTS.rays, metavar="N", help="stratified rays per patch")
    p.add_argument("--emitter-samples", type=int, default=DEFAULTS.emitter_samples, metavar="N",
                   help="shadow rays per texel to emissive surfaces (0: the gather alone finds them)")
    p.add_argument("--passes", type=int, default=DEFAULTS.passes, metavar="N")
    p.add_argument("--tolerance", type=finite_number, default=DEFAULTS.tolerance,
                   help="stop when the largest relative change still to come is below (default %(default)s)")
    p.add_argument("--accuracy", type=finite_number, default=DEFAULTS.accuracy,
                   help="adaptive sampling, final run: gather where neighbours differ by more than "
                        "accuracy^spacing (default %(default)s)")
    p.add_argument("--first-accuracy", type=finite_number, default=DEFAULTS.first_accuracy,
                   help="adaptive sampling, first run, for the first passes (default %(default)s)")
    p.add_argument("--no-adaptive", action="store_true", help="gather at every texel")
    p.add_argument("--save-passes", action="store_true", help="also write pass_01.png, pass_02.png, ... (texels.npz keeps every pass anyway)")
    p.add_argument("--denoise", action="store_true", help="denoise the gathered light with Intel OIDN")
    p.add_argument("--directional", choices=DIRECTIONAL_MODES,
                   help="also bake the light's direction: L1 spherical harmonics (lightmap_sh.exr) or the "
                        "dominant direction and its share (lightmap_dir.exr), for --model lightmap-directional")
    p.add_argument("--no-stitch", dest="stitch", action="store_false",
                   help="leave UV chart seams as solved (default: texels across a seam made to agree)")
    p.add_argument("--ray", metavar="ADDRESS", help="run the gather on a Ray cluster: its head's HOST:PORT, auto, or local")
    p.add_argument("--density", action="append", default=[], metavar="NAME=T",
                   help="texels per metre for the objects (glTF nodes or meshes) named NAME; repeatable")
    p.add_argument("--exposure", default="auto", help="K for 1 - exp(-K I), or auto")
    p.add_argument("--max-memory", type=finite_number, default=DEFAULTS.max_memory / 2**30, metavar="GiB",
                   help=f"most memory the form factors may keep, 0..{MAX_MEMORY_GIB} (default %(default)s)")
    p.add_argument("--seed", type=int, default=DEFAULTS.seed)
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--json", action="store_true", help="print the bake summary as JSON on stdout")


def _density(flag: str) -> tuple[str, float]:
    """("NAME", T) from a --density NAME=T flag."""
    name, sep, value = flag.rpartition("=")
    try:
        texels_per_unit = float(value)
    except ValueError:
        texels_per_unit = None
    if not (sep and name) or texels_per_unit is None:
        raise PatchlightError(f"--density {flag}: expected NAME=T, T texels per metre")
    return name, texels_per_unit


def settings_from_args(args) -> BakeSettings:
    """BakeSettings from the flags, checked (BakeSettings.validate) before any work."""
    exposure = args.exposure
    if exposure != "auto":
        try:
            exposure = float(exposure)
        except ValueError:
            raise PatchlightError(f"--exposure must be a number or auto, got {exposure!r}") from None
    if not 0 <= args.max_memory <= MAX_MEMORY_GIB:
        raise PatchlightError(f"--max-memory {args.max_memory:g}: must lie in 0..{MAX_MEMORY_GIB} GiB")
    settings = BakeSettings(resolution=args.resolution, texels_per_unit=args.texels_per_unit,
                            gather=args.gather, hemicube_size=args.hemicube_size, rays=args.rays,
                            emitter_samples=args.emitter_samples,
                            passes=args.passes, tolerance=args.tolerance, adaptive=not args.no_adaptive,
                            accuracy=args.accuracy, first_accuracy=args.first_accuracy, sun_angle=args.sun_angle, falloff=args.falloff,
                            exposure=exposure, max_memory=int(args.max_memory * 2**30), seed=args.seed,
                            save_passes=args.save_passes, denoise=args.denoise, ray=args.ray,
                            stitch=args.stitch, directional=args.directional,
                            density=dict(map(_density, args.density)))
    settings.validate()
    return settings


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
    from ..scene import load_scene

    scene = load_scene(args.scene)
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


def run(args) -> int:
    from ..bake import bake, write_bake

    from ..imaging.io import check_output_dir, json_text

    settings = settings_from_args(args)
    check_output_dir(args.output)
    scene = load_lit_scene(args)
    result = bake(scene, settings, quiet=args.quiet or args.json)
    summary = write_bake(result, args.output, settings)
    if args.json:
        print(json_text(summary, "bake summary"))
    elif not args.quiet:
        s = summary
        print(f"baked {s['patches']} patches ({s['computed_patches']} computed, "
              f"{s['interpolated_patches']} interpolated) in {s['seconds_total']:.1f} s, "
              f"{s['passes']} passes, {s['rays_per_second'] / 1e6:.2f} Mrays/s")
        print(f"results in {args.output}/: {' '.join(s['files'])}")
    for warning in summary.get("warnings", []):
        print(f"patchlight: warning: {warning}", file=sys.stderr)
    return 0
