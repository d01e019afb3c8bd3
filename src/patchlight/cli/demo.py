"""`patchlight demo`: bake the built-in room into ./out/room and say where the results are."""
from __future__ import annotations

import os
import sys
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("demo", help="bake the built-in room into ./out/room", description=__doc__)
    p.add_argument("-o", "--output", type=Path, default=Path("out/room"), metavar="DIR")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=run)


def _command() -> str:
    """How this program was started (`.venv/bin/patchlight` from `make demo`), for the hint."""
    invoked = sys.argv[0] if sys.argv and Path(sys.argv[0]).name == "patchlight" else "patchlight"
    return os.path.relpath(invoked) if os.path.sep in invoked else invoked


def run(args) -> int:
    from .main import main

    argv = ["bake", "room", "-o", str(args.output), "--resolution", "512", "--save-passes"]
    status = main(argv + (["--quiet"] if args.quiet else []))
    if status == 0:
        out = args.output.resolve()
        print(f"open {out}/lightmap.png (the lightmap), {out}/adaptive.png (computed vs interpolated texels),")
        print(f"     {out}/scene.glb (the room with its lightmap), {out}/bake.json (figures);")
        print(f"look at it with: {_command()} view {args.output}")
    return status
