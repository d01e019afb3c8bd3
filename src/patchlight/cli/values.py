"""Parsers of flag values: text in, numbers or objects out, or a one-line PatchlightError
naming the flag (argparse type functions raise argparse.ArgumentTypeError instead). Every
list of comma-separated numbers goes through `numbers`.

Light spec syntax of `--light` (angles in degrees, colours linear RGB, intensity radiometric):
    dir:DX,DY,DZ:R,G,B:E                                  direction of travel, irradiance W/m^2
    point:X,Y,Z:R,G,B:J[:RANGE]                            W/sr, range in metres
    spot:X,Y,Z:DX,DY,DZ:R,G,B:J:OUTER[:INNER[:RANGE]]      cone half-angles, inner defaults to 0
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from ..errors import PatchlightError
from ..scene.model import MAX_LIGHT
from ..shading.lights import FLOAT32_MAX

MAX_SIZE = 16384  # --size: largest picture width or height
MAX_PIXELS = 1 << 24  # 4096 x 4096: the renderer keeps ~100 bytes per pixel, several times over


def numbers(text: str, n: int, what: str, form: str | None = None, whole: bool = False) -> list:
    """The n comma-separated finite numbers in `text` (ints when `whole`), else PatchlightError
    "<what>: expected <form>" (form by default: "n comma-separated numbers")."""
    try:
        values = [int(v) if whole else float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise PatchlightError(f"{what}: expected {form or f'{n} comma-separated numbers'}")
    return values


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


def parse_rgb(text: str) -> tuple[float, float, float]:
    """'R,G,B' -> three floats in 0..MAX_LIGHT, or a one-line error."""
    message = f"expected R,G,B (three numbers in 0..{MAX_LIGHT:g}), got {text!r}"
    try:
        values = tuple(numbers(text, 3, "R,G,B"))
    except PatchlightError:
        raise argparse.ArgumentTypeError(message) from None
    if not all(0 <= v <= MAX_LIGHT for v in values):
        raise argparse.ArgumentTypeError(message)
    return values


def parse_point(text: str, where: str) -> np.ndarray:
    """'X,Y,Z' -> (3,) float64 for flag `where`."""
    return np.array(numbers(text, 3, f"{where} {text}", "X,Y,Z"))


def parse_texel(text: str, where: str = "--patch") -> tuple[int, int]:
    """'X,Y' -> (x, y) whole texel coordinates >= 0."""
    x, y = numbers(text, 2, f"{where} {text}", "X,Y (a lightmap texel's column and row)", whole=True)
    if x < 0 or y < 0:
        raise PatchlightError(f"{where} {text}: texel coordinates are >= 0")
    return x, y


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


def parse_dims(text: str) -> tuple[int, ...]:
    """--dims 'NX,NY,NZ' -> three whole numbers (their range: volumes.grid.GridSettings)."""
    return tuple(numbers(text, 3, f"--dims {text}", "NX,NY,NZ (three whole numbers >= 1)", whole=True))


def parse_bounds(text: str) -> tuple[float, ...]:
    """'X0,Y0,Z0,X1,Y1,Z1' -> six numbers (what they may be: volumes.grid.GridSettings)."""
    return tuple(numbers(text, 6, f"--bounds {text}", "X0,Y0,Z0,X1,Y1,Z1 (six numbers, metres)"))


def parse_area(text: str):
    """--area 'X0,Z0,X1,Z1' (metres) -> patchlight.ground.mapping.GroundArea (what it may be:
    ground.groundmap.GroundMapSettings)."""
    from ..ground.mapping import GroundArea

    return GroundArea(*numbers(text, 4, f"--area {text}", "X0,Z0,X1,Z1 (four numbers, metres)"))


def parse_camera(values: list[str]):
    """patchlight.render.camera.Camera from `--camera EX,EY,EZ TX,TY,TZ FOV`."""
    from ..render.camera import Camera

    if len(values) != 3:
        raise PatchlightError("--camera takes three values: EX,EY,EZ TX,TY,TZ FOV")
    what = f"--camera {' '.join(values)}"
    eye, target = (np.array(numbers(v, 3, what, "eye and target of three finite numbers each")) for v in values[:2])
    (fov,) = numbers(values[2], 1, what, "EX,EY,EZ TX,TY,TZ FOV numbers")
    camera = Camera(eye, target, fov)
    camera.basis()
    return camera


def parse_light_spec(spec: str, falloff: str = "inverse-square"):
    """A patchlight.scene.model.Light from a `--light` spec (syntax in the module docstring)."""
    from ..scene.model import Light

    kind, *fields = spec.split(":")
    shapes = {"dir": (3, 3, 1), "point": (3, 3, 1, 1), "spot": (3, 3, 3, 1, 1, 1, 1)}
    required = {"dir": 3, "point": 3, "spot": 5}
    if kind not in shapes:
        raise PatchlightError(f"--light {spec}: unknown light kind {kind!r} (dir, point or spot)")
    if not required[kind] <= len(fields) <= len(shapes[kind]):
        raise PatchlightError(f"--light {spec}: {kind} takes {required[kind]} to {len(shapes[kind])} "
                              f"':'-separated fields, got {len(fields)}")
    values = [_light_numbers(f, n, spec) for f, n in zip(fields, shapes[kind])]
    first = 2 if kind == "spot" else 1  # the colour field; the intensity follows it
    color, (strength,) = values[first], values[first + 1]
    if min(color) < 0 or strength < 0:
        raise PatchlightError(f"--light {spec}: colour and intensity must not be negative")
    if len(values) == len(shapes[kind]) and kind != "dir" and not values[-1][0] > 0:
        raise PatchlightError(f"--light {spec}: the range must be > 0 metres (leave it out for none)")
    if kind == "dir":
        direction, color, (irradiance,) = values
        return Light("directional", np.array(color, np.float32), irradiance,
                     direction=_unit(direction, spec), name=spec)
    if kind == "point":
        position, color, (intensity,), *rest = values
        return Light("point", np.array(color, np.float32), intensity, position=np.array(position, np.float32),
                     range=rest[0][0] if rest else None, name=spec)
    position, direction, color, (intensity,), (outer,), *rest = values
    inner = rest[0][0] if rest else 0.0
    if not 0 <= inner <= outer <= 90:
        raise PatchlightError(f"--light {spec}: spot angles need 0 <= inner <= outer <= 90 degrees")
    return Light("spot", np.array(color, np.float32), intensity, position=np.array(position, np.float32),
                 direction=_unit(direction, spec), range=rest[1][0] if len(rest) > 1 else None,
                 inner_cone=math.radians(inner), outer_cone=math.radians(outer), name=spec)


def _light_numbers(field: str, count: int, spec: str) -> list[float]:
    form = f"{field!r} as {count} comma-separated numbers (each within float32's range)"
    values = numbers(field, count, f"--light {spec}", form)
    if not all(abs(v) <= FLOAT32_MAX for v in values):
        raise PatchlightError(f"--light {spec}: expected {form}")
    return values


def _unit(v, spec: str) -> np.ndarray:
    a = np.asarray(v, np.float64)
    length = float(np.linalg.norm(a))
    if length == 0:
        raise PatchlightError(f"--light {spec}: direction must not be zero")
    return (a / length).astype(np.float32)
