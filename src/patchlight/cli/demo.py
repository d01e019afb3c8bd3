"""`patchlight demo`: bake the built-in room into ./out/room and say where the results are."""
from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("demo", help="bake the built-in room into ./out/room", description=__doc__)
    p.add_argument("-o", "--output", type=Path, default=Path("out/room"), metavar="DIR")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=run)


def run(args) -> int:
    from .main import main

    argv = ["bake", "room", "-o", str(args.output), "--resolution", "512", "--save-passes"]
    status = main(argv + (["--quiet"] if args.quiet else []))
    if status == 0:
        out = args.output.resolve()
        print(f"open {out}/lightmap.png (the lightmap), {out}/adaptive.png (computed vs interpolated texels),")
        print(f"     {out}/scene.glb (the room with its lightmap), {out}/bake.json (figures);")
        print(f"look at it with: patchlight view {args.output}")
    return status
