"""`patchlight bake SCENE -o DIR`: converged radiosity lightmap of a glTF or built-in scene."""
from __future__ import annotations

import argparse
import warnings
from pathlib import Path

from ..config import DIRECTIONAL_MODES, GATHERS, BakeSettings
from ..errors import PatchlightError, PatchlightWarning
from .options import DEFAULTS, about, add_scene_options, declared_field, load_lit_scene
from .parser import finite_number, writes_output

MAX_MEMORY_GIB = declared_field("max_memory").metadata["hi"] // 2**30  # --max-memory counts GiB


def register(sub) -> None:
    p = sub.add_parser("bake", help="bake a radiosity lightmap", description=__doc__)
    p.add_argument("scene", help="a .glb/.gltf file or a built-in scene: room, cornell")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="DIR")
    add_bake_options(p)
    p.set_defaults(func=writes_output(run))


def add_bake_options(p: argparse.ArgumentParser) -> None:
    """The bake's flags; their help texts, defaults and ranges come from BakeSettings' fields."""
    add_scene_options(p)
    p.add_argument("--keep-lights", nargs="?", const="all", metavar="NAME,...",
                   help="leave these lights (by name, or all when no names are given) out of the bake: they stay "
                        "dynamic (extras.baked false in scene.glb), for the runtime to light")
    size = p.add_mutually_exclusive_group()
    size.add_argument("--resolution", type=int, metavar="N", help=about("resolution"))
    size.add_argument("--texels-per-unit", type=finite_number, default=DEFAULTS.texels_per_unit, metavar="T",
                      help=about("texels_per_unit"))
    p.add_argument("--max-atlas", type=int, default=DEFAULTS.max_atlas, metavar="N", help=about("max_atlas"))
    p.add_argument("--gather", choices=GATHERS, default=DEFAULTS.gather, help=about("gather"))
    p.add_argument("--hemicube-size", type=int, default=DEFAULTS.hemicube_size, metavar="N", help=about("hemicube_size"))
    p.add_argument("--rays", type=int, default=DEFAULTS.rays, metavar="N", help=about("rays"))
    p.add_argument("--emitter-samples", type=int, default=DEFAULTS.emitter_samples, metavar="N",
                   help=about("emitter_samples"))
    p.add_argument("--passes", type=int, default=DEFAULTS.passes, metavar="N", help=about("passes"))
    p.add_argument("--tolerance", type=finite_number, default=DEFAULTS.tolerance, help=about("tolerance"))
    p.add_argument("--accuracy", type=finite_number, default=DEFAULTS.accuracy, help=about("accuracy"))
    p.add_argument("--first-accuracy", type=finite_number, default=DEFAULTS.first_accuracy, help=about("first_accuracy"))
    p.add_argument("--no-adaptive", action="store_true", help="gather at every texel")
    p.add_argument("--save-passes", action="store_true", help=about("save_passes"))
    p.add_argument("--denoise", action="store_true", help=about("denoise"))
    p.add_argument("--directional", choices=DIRECTIONAL_MODES, help=about("directional"))
    p.add_argument("--no-stitch", dest="stitch", action="store_false",
                   help="leave UV chart seams as solved (default: texels across a seam made to agree)")
    p.add_argument("--ray", metavar="ADDRESS", help=about("ray"))
    p.add_argument("--density", action="append", default=[], metavar="NAME=T",
                   help="texels per metre for the objects (glTF nodes or meshes) named NAME; repeatable")
    p.add_argument("--exposure", default=DEFAULTS.exposure, help=about("exposure"))
    p.add_argument("--max-memory", type=finite_number, default=DEFAULTS.max_memory / 2**30, metavar="GiB",
                   help=f"{declared_field('max_memory').metadata['meaning']}, "
                        f"in GiB: 0..{MAX_MEMORY_GIB} (default %(default)s)")
    p.add_argument("--seed", type=int, default=DEFAULTS.seed, help=about("seed"))
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
    settings = BakeSettings(resolution=args.resolution, texels_per_unit=args.texels_per_unit, max_atlas=args.max_atlas,
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


def run(args) -> int:
    from ..bake import bake
    from ..bakedir import write_bake

    from ..imaging.io import check_output_dir, json_text

    settings = settings_from_args(args)
    check_output_dir(args.output)
    scene = load_lit_scene(args)
    result = bake(scene, settings, quiet=args.quiet or args.json)
    summary = write_bake(result, args.output, settings, quiet=args.quiet or args.json)
    if args.json:
        print(json_text(summary, "bake summary"))
    elif not args.quiet:
        s = summary
        print(f"baked {s['patches']} patches ({s['computed_patches']} computed, "
              f"{s['interpolated_patches']} interpolated) in {s['seconds_total']:.1f} s, "
              f"{s['passes']} passes, {s['rays_per_second'] / 1e6:.2f} Mrays/s")
        print(f"results in {args.output}/: {' '.join(s['files'])}")
    for warning in summary.get("warnings", []):
        warnings.warn(warning, PatchlightWarning)  # one line on stderr (cli/main.py)
    return 0
