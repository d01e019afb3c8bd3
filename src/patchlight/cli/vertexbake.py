"""`patchlight vertexbake SCENE_OR_BAKE_DIR -o out.glb`: incident light per vertex as COLOR_0.

The vertex values are fitted to the solved patches around them (least squares over the
triangles' interpolation, patches inside geometry left out; see patchlight.volumes.vertex).
COLOR_0 = the file's vertex colour x incident light I / colorScale, linear, within 0..1 as
glTF requires (colorScale: the largest colour x I, at least 1, recorded in the root
extras.patchlight.vertexLight; HDR light = COLOR_0.rgb x colorScale): drawn unlit, base colour
x COLOR_0 is the lit surface, scaled. So every material is marked
KHR_materials_unlit (in extensionsUsed): glTF viewers that support it (three.js, Babylon.js,
Blender, the Khronos sample viewer) show base colour x COLOR_0 without lighting it again;
others fall back to lit PBR, which counts the light twice. Emission is not drawn unlit."""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import PatchlightError
from .options import add_scene_options, load_solved_from_args


def register(sub) -> None:
    p = sub.add_parser("vertexbake", help="bake incident light to vertex colours (COLOR_0, materials unlit)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", metavar="SCENE_OR_BAKE_DIR",
                   help="a bake directory, a .glb/.gltf file or a built-in scene (room, cornell)")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.glb",
                   help="the scene with COLOR_0 = incident light, every material KHR_materials_unlit")
    add_scene_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--json", action="store_true", help="print a summary as JSON on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..imaging.io import check_output_dir
    from ..volumes.vertex import save_vertex_lit_glb, vertex_incident, with_vertex_light

    out = args.output
    if out.suffix.lower() != ".glb":
        raise PatchlightError(f"{out}: the output must be a .glb file")
    check_output_dir(out.parent)
    if not out.parent.is_dir():
        raise PatchlightError(f"{out}: directory {out.parent} does not exist")
    started = time.perf_counter()
    solved = load_solved_from_args(args, quiet=args.quiet or args.json)
    incident = vertex_incident(solved)
    lit, scale = with_vertex_light(solved.scene, incident)
    save_vertex_lit_glb(lit, out, scale)
    summary = {"scene": solved.source, "output": str(out), "vertices": len(incident), "color_scale": scale,
               "incident_min": incident.min(axis=0).tolist(), "incident_max": incident.max(axis=0).tolist(),
               "incident_mean": incident.mean(axis=0).tolist(), "seconds": time.perf_counter() - started}
    if args.json:
        json.dump(summary, sys.stdout, indent=2)
        print()
    elif not args.quiet:
        peak = float(np.max(incident))
        print(f"wrote {out}: {len(incident)} vertex colours (incident light up to {peak:.3g}) "
              f"in {summary['seconds']:.1f} s")
    return 0
