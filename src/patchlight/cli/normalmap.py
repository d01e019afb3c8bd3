"""`patchlight normalmap HIGH.glb LOW.glb -o normal.png`: the high-poly model's normals baked
into the low-poly model's TEXCOORD_0 map (tangent space, glTF convention, +Y green; or
`--object-space`), with an ambient-occlusion map from the same rays (`--ao ao.png`). The map
drops into `patchlight render LOW.glb --normal-map normal.png`."""
from __future__ import annotations

import time
from pathlib import Path

from ..errors import PatchlightError
from ..normalmap import NormalMapSettings
from .options import about
from .parser import finite_number
from .values import parse_size


AO_RAYS = 64  # AO rays per texel when --ao asks for the map


def register(sub) -> None:
    p = sub.add_parser("normalmap", help="bake a normal map (and AO) from a high-poly model onto a low-poly one",
                       description=__doc__)
    p.add_argument("high", type=Path, metavar="HIGH.glb", help="the detailed model")
    p.add_argument("low", type=Path, metavar="LOW.glb", help="the model the map is for (its TEXCOORD_0)")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.png")
    p.add_argument("--size", type=parse_size, default=(512, 512), metavar="WxH", help="default 512x512")
    reach = p.add_mutually_exclusive_group()
    reach.add_argument("--distance", type=finite_number, metavar="M", help=about("distance", NormalMapSettings))
    reach.add_argument("--cage", type=Path, metavar="CAGE.glb",
                       help="rays run from this mesh (the low model's vertices, moved out) to the low surface")
    p.add_argument("--object-space", action="store_true", help="object-space normals instead of tangent space")
    p.add_argument("--ao", type=Path, metavar="AO.png", help="also write ambient occlusion (grey, 1 = open)")
    p.add_argument("--ao-rays", type=int, default=AO_RAYS, metavar="N",
                   help=f"ambient-occlusion rays per texel, for --ao (default {AO_RAYS})")
    p.add_argument("--ao-distance", type=finite_number, metavar="M", help=about("ao_distance", NormalMapSettings))
    p.add_argument("--dilate", dest="dilation", type=int, default=NormalMapSettings.dilation, metavar="TEXELS",
                   help=about("dilation", NormalMapSettings))
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    import numpy as np

    from ..imaging.io import atomic_path, check_output_dir, encode_png, write_bytes
    from ..normalmap import bake_normal_map
    from ..progress import Progress
    from ..scene import load_scene

    outputs = [args.output] + ([args.ao] if args.ao else [])
    for out in outputs:
        if out.suffix.lower() != ".png":
            raise PatchlightError(f"{out}: the output must be a .png file")
        check_output_dir(out.parent)
    started = time.perf_counter()
    width, height = args.size
    settings = NormalMapSettings(width=width, height=height, distance=args.distance,
                                 cage=load_scene(args.cage) if args.cage else None,
                                 space="object" if args.object_space else "tangent", dilation=args.dilation,
                                 ao_rays=args.ao_rays if args.ao else 0, ao_distance=args.ao_distance)
    settings.validate()
    high, low = load_scene(args.high), load_scene(args.low)
    with Progress(quiet=args.quiet) as progress:
        with progress.stage("normal map", total=width * height) as advance:
            result = bake_normal_map(high, low, settings, advance)
    images = [encode_png(result.encoded())]
    if args.ao:
        images.append(encode_png(np.rint(np.clip(result.ao, 0, 1) * 255).astype(np.uint8)))
    with atomic_path(args.output) as first:  # the AO map is written before the normal map is renamed in
        first.write_bytes(images[0])
        if args.ao:
            write_bytes(args.ao, images[1])
    covered = int(result.covered.sum())
    missed = covered - int((result.covered & result.hit).sum())
    if not args.quiet:
        print(f"wrote {', '.join(map(str, outputs))} ({width}x{height}, {settings.space} space; {covered} texels, "
              f"{missed} without a hit, filled) in {time.perf_counter() - started:.1f} s")
    return 0
