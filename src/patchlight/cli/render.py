"""`patchlight render SCENE_OR_BAKE_DIR --model M -o out.png|out.exr`: one picture of a scene
with a runtime lighting model, on the CPU (Embree camera rays, then the NumPy reference of
the GLSL the viewer runs). .exr holds linear radiance; .png the exposed sRGB picture."""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ..errors import PatchlightError
from ..config import FALLOFFS
from ..shading.models import MODELS
from ..shading.hemisphere_radiosity import OFFSET_MODES
from .bake import parse_rgb, sky_from_args
from .parser import finite_number

MAX_SIZE = 16384
MAX_PIXELS = 1 << 24  # 4096 x 4096: the renderer keeps ~100 bytes per pixel, several times over


def parse_size(text: str) -> tuple[int, int]:
    """'WxH' -> (width, height), each in 1..MAX_SIZE, at most MAX_PIXELS in all."""
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WxH, e.g. 1024x768, got {text!r}") from None
    if not (1 <= width <= MAX_SIZE and 1 <= height <= MAX_SIZE):
        raise argparse.ArgumentTypeError(f"{text}: width and height must lie in 1..{MAX_SIZE}")
    if width * height > MAX_PIXELS:
        raise argparse.ArgumentTypeError(f"{text}: more than {MAX_PIXELS} pixels (4096x4096)")
    return width, height


def add_shading_options(p: argparse.ArgumentParser) -> None:
    """Options shared by `render` and `view`: lights, surroundings and the model options."""
    p.add_argument("--light", action="append", metavar="SPEC",
                   help="replace the scene's lights (repeatable): dir:DX,DY,DZ:R,G,B:E | "
                        "point:X,Y,Z:R,G,B:J[:RANGE] | spot:X,Y,Z:DX,DY,DZ:R,G,B:J:OUTER[:INNER[:RANGE]] "
                        "(E in W/m^2, J in W/sr, angles in degrees)")
    p.add_argument("--falloff", choices=FALLOFFS, default="inverse-square",
                   help="point/spot falloff for lights that name none (default %(default)s)")
    sky = p.add_mutually_exclusive_group()  # the flags of cli.bake.add_scene_options, read by its sky_from_args
    sky.add_argument("--sky", type=parse_rgb, metavar="R,G,B", help="replace the scene's sky: uniform radiance")
    sky.add_argument("--sky-gradient", type=parse_rgb, nargs=3, metavar=("ZENITH", "HORIZON", "GROUND"),
                     help="replace the scene's sky: radiance at the zenith, the horizon and below it")
    sky.add_argument("--sky-image", type=Path, metavar="FILE",
                     help="replace the scene's sky: an equirectangular .exr or .hdr")
    p.add_argument("--ambient", type=parse_rgb, metavar="R,G,B",
                   help="ambient incident light (default: from the sky, else 0.05 grey)")
    p.add_argument("--reflectivity", type=finite_number, metavar="K", help="envmap reflectivity of every material (0..1)")
    p.add_argument("--specular", action="store_true", help="lightmap model: add the lights' Blinn-Phong highlight")
    p.add_argument("--normal-map", nargs="?", const=True, default=False, type=Path, metavar="PNG",
                   help="tangent-space normal maps, colour alpha as gloss: the materials' own, or this image "
                        "(e.g. from `patchlight normalmap`) for every material")
    p.add_argument("--per-vertex", action="store_true", help="light at the vertices and interpolate")
    p.add_argument("--volume", type=Path, metavar="DIR",
                   help="ambient-cube model: the light volume (default: the bake directory's, if it holds one)")
    p.add_argument("--naive-weights", action="store_true", help="ambient-cube model: weight the axes by saturate(N)")
    p.add_argument("--offset-mode", choices=OFFSET_MODES, metavar="normal|side|none",
                   help="hemisphere-radiosity model: where a ground map directory's map is sampled, offset along "
                        "the normal, its left-right part only, or not at all (default: the map's groundmap.json)")


def register(sub) -> None:
    p = sub.add_parser("render", help="render a picture with a runtime lighting model (CPU)", description=__doc__)
    p.add_argument("target", metavar="SCENE_OR_BAKE_DIR",
                   help="a .glb/.gltf file, a built-in scene (room, cornell) or a bake directory")
    p.add_argument("--model", choices=MODELS, default="lambert", help="lighting model (default %(default)s)")
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


def load_target_and_settings(args, model: str | None):
    """The target the arguments name and its ShadingSettings (exposure left at 1). A ground
    map directory names its bake, with the map as the hemisphere-radiosity model's. model None:
    lightmap when the target has one (a bake), else lambert."""
    from ..ground.viewer import view_target
    from ..render.settings import target_settings
    from ..render.target import load_target
    from ..shading.lights import parse_light_spec
    from ..volumes.viewer import find_volume

    spec, ground_map = view_target(args.target, args.offset_mode)
    target = load_target(spec)
    sky = sky_from_args(args)
    if sky is not None:
        target.scene.sky = sky
    lights = None if args.light is None else [parse_light_spec(spec) for spec in args.light]
    if isinstance(args.normal_map, Path):
        use_normal_map(target, args.normal_map)
    if args.normal_map and all(m.normal_texture is None for m in target.scene.materials):
        raise PatchlightError(f"--normal-map: no material of {target.name} has a normal texture")
    if model is None:
        model = "lightmap" if target.lightmap is not None else "lambert"
    settings = target_settings(target, model=model, lights=lights, falloff=args.falloff, ambient=args.ambient,
                               per_vertex=args.per_vertex, normal_map=bool(args.normal_map),
                               lightmap_specular=args.specular, reflectivity=args.reflectivity,
                               ground_map=ground_map, volume=find_volume(args.volume, target.bake_dir),
                               ambient_cube_naive=args.naive_weights)
    return target, settings


def use_normal_map(target, path: Path) -> None:
    """Give every material of `target` the normal map image at `path` (RGB, stored values)."""
    from ..imaging.io import read_image

    image = read_image(path)
    if image.shape[2] < 3:
        raise PatchlightError(f"--normal-map {path}: a normal map needs RGB channels, the image has {image.shape[2]}")
    for material in target.scene.materials:
        material.normal_texture = np.ascontiguousarray(image[..., :3])


def parse_point(text: str, where: str):

    try:
        point = np.array([float(v) for v in text.split(",")])
    except ValueError:
        point = np.zeros(0)
    if point.shape != (3,) or not np.all(np.isfinite(point)):
        raise PatchlightError(f"{where} {text}: expected X,Y,Z")
    return point


def parse_exposure(text: str) -> float | None:
    """None for auto, else a positive float."""
    if text == "auto":
        return None
    try:
        k = float(text)
    except ValueError:
        k = float("nan")
    if not (k > 0 and k < float("inf")):
        raise PatchlightError(f"--exposure {text}: expected a positive number or auto")
    return k


def run(args) -> int:
    from ..imaging.exposure import auto_exposure
    from ..render.camera import parse_camera
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
    from ..patchview import PatchViews, parse_texel, patch_picture
    from ..solved import is_bake_dir

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
