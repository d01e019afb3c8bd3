"""`patchlight groundmap SCENE_OR_BAKE_DIR -o DIR`: a top-down radiosity ground map with static
sun shadows, for hemisphere lighting of moving objects (runtime model hemisphere-radiosity).

Given a scene (file or built-in name) rather than a bake directory, the scene is baked first
and the bake is written into DIR too, so DIR is also a bake directory that `patchlight view`
shows, with the ground map lighting cars that drive through it (render and view need the lit
level the map lies over; keeping the bake saves baking it again). The bake and the map are one
set: every check that needs no light (settings, the output, ground under the area) is made
before the bake, and nothing is written into DIR unless the whole command succeeds.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import warnings
from pathlib import Path

from ..config import BakeSettings
from ..errors import PatchlightWarning
from .options import about, add_scene_options, load_lit_scene, sky_from_args
from .parser import finite_number, writes_output
from .values import parse_area

DENSE_TEXELS_PER_UNIT = BakeSettings.texels_per_unit  # the bake's default lightmap density ...
LEVEL_TEXELS = 320            # ... lowered so a large level's width spans this many texels


def register(sub) -> None:
    from ..ground.encode import ENCODINGS
    from ..ground.groundmap import GroundMapSettings
    from ..shading.hemisphere_radiosity import OFFSET_MODES

    p = sub.add_parser("groundmap", help="bake a top-down radiosity ground map", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", metavar="SCENE_OR_BAKE_DIR", help="a bake directory, a .glb/.gltf file or a built-in scene")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="DIR")
    d = GroundMapSettings
    p.add_argument("--area", metavar="X0,Z0,X1,Z1", help=about("area", d))
    p.add_argument("--size", type=int, default=d.size, metavar="N", help=about("size", d))
    p.add_argument("--max-height", type=finite_number, default=d.max_height, metavar="H", help=about("max_height", d))
    p.add_argument("--noise", type=finite_number, default=d.noise, metavar="A", help=about("noise", d))
    p.add_argument("--shadows", choices=ENCODINGS, default=d.shadows, help=about("shadows", d))
    p.add_argument("--seed", type=int, default=d.seed, help=about("seed", d))
    p.add_argument("--offset-distance", dest="offset", type=finite_number, default=d.offset, metavar="M",
                   help=about("offset", d))
    p.add_argument("--offset-mode", choices=OFFSET_MODES, default=d.offset_mode, metavar="normal|side|none",
                   help=about("offset_mode", d))
    p.add_argument("--texels-per-unit", type=finite_number, metavar="T",
                   help=f"lightmap density when baking a scene here (default {DENSE_TEXELS_PER_UNIT:g}, "
                        f"or less so the level spans {LEVEL_TEXELS} texels)")
    add_scene_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress or summary")
    p.add_argument("--json", action="store_true", help="print groundmap.json on stdout")
    p.set_defaults(func=writes_output(run))


def settings_from_args(args):
    from ..ground.groundmap import GroundMapSettings

    settings = GroundMapSettings(size=args.size, area=parse_area(args.area) if args.area else None,
                                 max_height=args.max_height, noise=args.noise, shadows=args.shadows,
                                 seed=args.seed, offset=args.offset, offset_mode=args.offset_mode,
                                 sun_angle=args.sun_angle)
    settings.validate()
    return settings


def bake_density(args, scene) -> float:
    """The lightmap density for baking `scene` here: --texels-per-unit, else DENSE_TEXELS_PER_UNIT
    lowered so the level's width spans LEVEL_TEXELS texels."""
    density = args.texels_per_unit
    if density is None:
        lo, hi = scene.bounds()
        density = min(DENSE_TEXELS_PER_UNIT, LEVEL_TEXELS / max(float(hi[0] - lo[0]), float(hi[2] - lo[2]), 1e-3))
    return density


def run(args) -> int:
    """Check everything that needs no light, then solve (read the bake, or bake the scene in
    memory), make the map and write it (with the bake made here) as one set."""
    from ..bake import bake
    from ..ground.groundmap import make_groundmap, plan_groundmap, write_groundmap
    from ..imaging.io import check_output_dir
    from ..bakedir import recorded_sun_angle, require_bake_dir
    from ..inputs import open_input
    from ..progress import Progress
    from ..solved import SolvedScene

    settings = settings_from_args(args)
    check_output_dir(args.output)
    made = None  # (BakeResult, BakeSettings) of a scene baked here
    source = open_input(args.scene)
    if source.kind in ("bake", "groundmap"):
        bake_dir = os.path.relpath(require_bake_dir(source.path).resolve(), args.output.resolve())
        if settings.sun_angle is None:  # the map's shadows are the bake's
            settings.sun_angle = recorded_sun_angle(source.path)
        solved = source.solved(sky=sky_from_args(args))
        plan = None
    else:
        scene = load_lit_scene(args)
        bake_settings = BakeSettings(texels_per_unit=bake_density(args, scene), sun_angle=args.sun_angle,
                                     falloff=args.falloff)
        bake_settings.validate()
        plan = plan_groundmap(scene, settings)  # refuses a map it cannot make before the bake
        result = bake(scene, bake_settings, quiet=args.quiet or args.json)
        solved = SolvedScene.from_bake(result, str(args.scene))
        made, bake_dir = (result, bake_settings), None
    with Progress(args.quiet or args.json) as progress:
        with progress.stage("ground map"):
            ground_map = make_groundmap(solved, settings, plan)
        with progress.stage("writing"):
            manifest = write_groundmap(ground_map, args.output, str(args.scene), bake_dir, bake=made)
    if args.json:
        json.dump(json.loads((args.output / "groundmap.json").read_text()), sys.stdout, indent=2)
        print()
    elif not args.quiet:
        e = ground_map.encoded
        files = " ".join(v for f in manifest["files"].values() for k, v in f.items() if k in ("png", "dds"))
        print(f"ground map {settings.size} x {settings.size} ({e.encoding}) in "
              f"{sum(ground_map.seconds.values()):.2f} s, {100 * ground_map.shadowed:.0f}% in shadow")
        print(f"results in {args.output}/: {files} groundmap.json" + (" and the bake" if made else ""))
    for warning in ground_map.warnings:
        warnings.warn(warning, PatchlightWarning)  # one line on stderr (cli/main.py)
    return 0
