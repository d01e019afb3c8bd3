"""`patchlight blender BAKE_DIR -o scene.blend`: the bake as a Blender file, lightmap wired.

Imports scene.glb with Blender's glTF importer and makes every lightmapped material draw
base colour x lightmap.exr (through the lightmap UVs) + its emission as an Emission shader,
so Cycles and Eevee show the baked light as it is; lights marked baked are removed. Needs
Blender's Python module: pip install 'patchlight[blender]'."""
from __future__ import annotations

import argparse
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("blender", help="write a bake as a .blend with its lightmap wired (needs bpy)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bake_dir", type=Path, metavar="BAKE_DIR", help="a directory `patchlight bake` wrote")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.blend")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..blender import write_blend

    out = write_blend(args.bake_dir, args.output)
    print(f"wrote {out}")
    return 0
