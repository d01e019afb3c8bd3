"""`patchlight view SCENE_OR_BAKE_DIR [--port N]`: the runtime lighting models in the browser.

Serves the viewer on 127.0.0.1 only (a free port unless --port), prints the address and
runs until Ctrl-C or SIGTERM (exit status 130 or 143). The page runs the same GLSL chunks the CPU
renderer's reference mirrors."""
from __future__ import annotations

import argparse
import os
import signal
import sys

from ..shading.models import MODELS
from .options import add_shading_options, load_target_and_settings
from .values import parse_exposure, parse_point, parse_texel


def port_number(text: str) -> int:
    try:
        port = int(text)
    except ValueError:
        port = -1
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"expected a port number 0..65535, got {text!r}")
    return port


def register(sub) -> None:
    p = sub.add_parser("view", help="serve the web viewer for a scene or bake", description=__doc__)
    p.add_argument("target", metavar="SCENE_OR_BAKE_DIR",
                   help="a .glb/.gltf file, a built-in scene (room, cornell) or a bake directory")
    p.add_argument("--port", type=port_number, default=0, help="port on 127.0.0.1 (default: a free one)")
    p.add_argument("--model", choices=MODELS, default=None,
                   help="model shown first (default: lightmap for a bake, else lambert)")
    p.add_argument("--exposure", default="auto", metavar="K", help="initial exposure K, or auto")
    p.add_argument("--envmap-from", metavar="X,Y,Z",
                   help="render the envmap's cube map from this point (default: as for render)")
    p.add_argument("--compare", metavar="BAKE_DIR",
                   help="a second bake of the same scene and lightmap UVs: the page can split the picture, "
                        "this bake's lightmap on the left, that one's on the right")
    p.add_argument("--patch", metavar="X,Y",
                   help="a bake: show the view from lightmap texel X,Y (column, row) at start; "
                        "clicking a surface shows its texel's")
    add_shading_options(p)
    p.set_defaults(func=run, say=p.user_line)  # the page's note names flags, as this command's errors do


def run(args) -> int:
    from ..inputs import open_input
    from ..viewer.app import make_server

    exposure = parse_exposure(args.exposure)
    envmap_from = parse_point(args.envmap_from, "--envmap-from") if args.envmap_from else None
    patch = parse_texel(args.patch) if args.patch else None
    target, settings = load_target_and_settings(args, args.model)
    compare = open_input(args.compare).target()[0] if args.compare else None
    server = make_server(target, settings, args.port, exposure, envmap_from, patch, compare, args.say)
    print(f"patchlight viewer for {target.name}: {server.url}  (Ctrl-C to stop)", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt as stop:
        stop_now(server, 128 + (stop.args[0] if stop.args else signal.SIGINT))
    finally:
        server.httpd.server_close()


def stop_now(server, status: int) -> None:
    """End the process at once on Ctrl-C or SIGTERM (status 130 or 143), whatever requests
    are under way.

    The viewer writes nothing, so there is nothing to finish: requests still being served are
    cut off, and the interpreter's teardown is skipped, which walks every object the JIT made
    and took over 20 s on a loaded machine whose idle pages had been swapped out."""
    server.httpd.server_close()
    print("\npatchlight viewer stopped", flush=True)
    sys.stderr.flush()
    os._exit(status)

