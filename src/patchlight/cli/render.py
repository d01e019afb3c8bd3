"""`patchlight render SCENE_OR_BAKE_DIR --model M -o out.png|out.exr`: one picture of a scene
with a runtime lighting model, on the CPU (Embree camera rays, then the NumPy reference of
the GLSL the viewer runs). .exr holds linear radiance; .png the exposed sRGB picture."""
from __future__ import annotations

import time
from pathlib import Path

from ..errors import PatchlightError
from ..shading.models import MODELS, ShadingSettings
from .options import about, add_shading_options, load_target_and_settings
from .values import parse_camera, parse_exposure, parse_point, parse_size, parse_texel


def register(sub) -> None:
    p = sub.add_parser("render", help="render a picture with a runtime lighting model (CPU)", description=__doc__)
    p.add_argument("target", metavar="SCENE_OR_BAKE_DIR",
                   help="a .glb/.gltf file, a built-in scene (room, cornell) or a bake directory")
    p.add_argument("--model", choices=MODELS, default=ShadingSettings.model, help=about("model", ShadingSettings))
    p.add_argument("--camera", nargs=3, metavar=("EX,EY,EZ", "TX,TY,TZ", "FOV"),
                   help="eye, target (metres) and vertical field of view (degrees); +Y up")
    p.add_argument("--size", type=parse_size, default=(1024, 1024), metavar="WxH", help="default 1024x1024")
    p.add_argument("--exposure", default="auto", metavar="K",
                   help="PNG display value 1 - exp(-K radiance), or auto (default)")
    p.add_argument("--envmap-from", metavar="X,Y,Z",
                   help="envmap and hemisphere-radiosity models: render the cube map from this point "
                        "(default: the sky; without one, the scene's centre, or the default camera's eye "
                        "when the centre is inside an object)")
    p.add_argument("--patch", metavar="X,Y",
                   help="instead of a camera picture: the view from the bake's lightmap texel X,Y (column, row), "
                        "its hemicube unfolded (or its stratified rays on the hemisphere) beside the multiplier map")
    add_shading_options(p)
    p.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.png|OUT.exr")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..imaging.exposure import auto_exposure
    from ..render.output import check_output, write_render
    from ..render.renderer import Renderer

    started = time.perf_counter()
    output = check_output(args.output)
    exposure = parse_exposure(args.exposure)
    if args.patch:
        return render_patch(args, output, exposure, started)
    envmap_from = parse_point(args.envmap_from, "--envmap-from") if args.envmap_from else None
    target, settings = load_target_and_settings(args, args.model)
    renderer = Renderer(target, envmap_from)
    camera = parse_camera(args.camera) if args.camera else renderer.default_camera()
    renderer.require_inputs(settings)
    width, height = args.size
    result = renderer.render(settings, camera, width, height)
    if exposure is None:
        exposure = auto_exposure(result.radiance[result.covered])
    write_render(output, result.radiance, exposure)
    print(f"wrote {output} ({width}x{height}, {settings.model}, exposure {exposure:.4g}) "
          f"in {time.perf_counter() - started:.2f} s")
    return 0


PATCH_PICTURE_PIXELS = 256  # a patch view's PNG is scaled up by whole pixels to about this height


def render_patch(args, output: Path, exposure: float | None, started: float) -> int:
    """`render BAKE_DIR --patch X,Y`: the PNG of the view from a patch (patchlight.patchview),
    or its linear radiance picture as .exr."""
    from ..imaging.exposure import auto_exposure
    from ..imaging.io import write_exr, write_png
    from ..patchview import PatchViews, patch_picture
    from ..bakedir import is_bake_dir

    x, y = parse_texel(args.patch)
    if not is_bake_dir(args.target):
        raise PatchlightError(f"--patch: {args.target} is not a bake directory (the view from a patch needs a bake)")
    view = PatchViews(args.target).at(x, y)
    seen = view.seen >= -1  # patches and sky, not back faces or lost hits
    if exposure is None:
        exposure = auto_exposure(view.radiance[seen]) if seen.any() else 1.0
    if output.suffix.lower() == ".exr":
        write_exr(output, view.picture(view.radiance))
    else:
        scale = max(1, PATCH_PICTURE_PIXELS // (2 * view.size if view.method == "hemicube" else 128))
        write_png(output, patch_picture(view, exposure, scale))
    print(f"wrote {output} (texel {x},{y}: {view.method}, {len(view.seen)} rays, gathered light "
          f"{', '.join(f'{c:.4g}' for c in view.gathered)}; exposure {exposure:.4g}) in {time.perf_counter() - started:.2f} s")
    return 0
