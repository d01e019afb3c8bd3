"""Punctual lights as the shaders see them, and what each delivers to a surface point.

`directional_light`, `point_light`, `spot_light`, `spot_cone`, `inverse_square_falloff`,
`range_falloff` and `incident_light` mirror the GLSL functions of the same names
(light_*.glsl, falloff.glsl, lights.glsl). Units (DESIGN.md): a light returns incident light
I, so a white diffuse surface facing it shows radiance I N.L; radiant intensity J (W/sr)
gives I = J falloff / pi, a sun of irradiance E gives I = E / pi.

Light spec syntax of `--light` (angles in degrees, colours linear RGB, intensity radiometric):
    dir:DX,DY,DZ:R,G,B:E                                  direction of travel, irradiance W/m^2
    point:X,Y,Z:R,G,B:J[:RANGE]                            W/sr, range in metres
    spot:X,Y,Z:DX,DY,DZ:R,G,B:J:OUTER[:INNER[:RANGE]]      cone half-angles, inner defaults to 0
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import FALLOFFS  # in the order of GLSL's FALLOFF_INVERSE_SQUARE, FALLOFF_RANGE
from ..errors import PatchlightError
from .terms import dot, normalize, saturate

LIGHT_KINDS = ("directional", "point", "spot")  # GLSL LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT
MAX_LIGHTS = 8  # GLSL MAX_LIGHTS: the most lights one viewer draw takes
FLOAT32_MAX = float(np.finfo(np.float32).max)  # the shaders and the tracer hold lights in float32


@dataclass
class PunctualLight:
    """One light, ready to shade with. kind in LIGHT_KINDS; position (3,) metres; direction (3,)
    unit, the way the light travels; intensity (3,) colour x intensity (W/m^2 directional,
    W/sr point and spot); range metres, 0 for none (> 0 when falloff is "range"; with
    inverse-square a range > 0 fades the light out to 0 at it); cone cosines for spots."""

    kind: str
    position: np.ndarray
    direction: np.ndarray
    intensity: np.ndarray
    falloff: str = "inverse-square"
    range: float = 0.0
    cos_inner: float = 1.0
    cos_outer: float = 0.0

    def to_json(self) -> dict:
        vectors = {name: np.asarray(getattr(self, name), np.float64).tolist()
                   for name in ("position", "direction", "intensity")}
        return {"kind": self.kind, **vectors, "falloff": self.falloff, "range": float(self.range),
                "cos_inner": float(self.cos_inner), "cos_outer": float(self.cos_outer)}


def inverse_square_falloff(d: np.ndarray, range_: float) -> np.ndarray:
    """falloff.glsl: 1 / d^2, times the window saturate(1 - (d / r)^4)^2 when the light has a
    range r > 0 (exactly 0 from d = r on); plain 1 / d^2 when range_ <= 0 (no range)."""
    f = 1.0 / (d * d)
    if range_ > 0:
        x = d / np.float32(range_)
        x2 = x * x
        window = saturate(1.0 - x2 * x2)
        f = f * (window * window)
    return f


def range_falloff(d: np.ndarray, range_: float) -> np.ndarray:
    """falloff.glsl: saturate(1 - (d / r)^2); exactly 0 from d = r on."""
    x = d / np.float32(range_)
    return saturate(1.0 - x * x)


def spot_cone(L: np.ndarray, direction, cos_inner: float, cos_outer: float) -> np.ndarray:
    """light_spot.glsl: KHR_lights_punctual's smooth cone edge t^2, (...,)."""
    cos_angle = dot(-L, np.asarray(direction, L.dtype))
    t = saturate((cos_angle - np.float32(cos_outer)) / np.float32(max(0.001, cos_inner - cos_outer)))
    return t * t


def directional_light(direction, irradiance, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """light_directional.glsl: (L, I) for points P (..., 3): L = -direction, I = E / pi."""
    L = np.broadcast_to(-np.asarray(direction, P.dtype), P.shape)
    I = np.broadcast_to(np.asarray(irradiance, P.dtype) / np.float32(np.pi), P.shape)
    return L, I


def point_light(position, intensity, range_: float, falloff: str, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """light_point.glsl: (L, I) for points P (..., 3): I = J falloff(d) / pi."""
    to_light = np.asarray(position, P.dtype) - P
    d = np.sqrt(dot(to_light, to_light))
    f = range_falloff(d, range_) if falloff == "range" else inverse_square_falloff(d, range_)
    return to_light / d[..., None], np.asarray(intensity, P.dtype) * (f / np.float32(np.pi))[..., None]


def spot_light(position, direction, intensity, range_: float, falloff: str, cos_inner: float,
               cos_outer: float, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """light_spot.glsl: a point light times its cone, (L, I)."""
    L, I = point_light(position, intensity, range_, falloff, P)
    return L, I * spot_cone(L, direction, cos_inner, cos_outer)[..., None]


def incident_light(light: PunctualLight, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """lights.glsl: (L, I), each (..., 3), of `light` at points P (..., 3)."""
    if light.kind == "directional":
        return directional_light(light.direction, light.intensity, P)
    if light.kind == "point":
        return point_light(light.position, light.intensity, light.range, light.falloff, P)
    return spot_light(light.position, light.direction, light.intensity, light.range, light.falloff,
                      light.cos_inner, light.cos_outer, P)


def from_scene_light(light, falloff: str, where: str) -> PunctualLight:
    """A patchlight.scene.model.Light as a PunctualLight. `falloff` is used unless the light
    names its own; range falloff needs a point or spot light's range (`where` names the light
    in errors). Directional lights have no falloff."""
    chosen = light.falloff or falloff
    if light.kind != "directional":
        _check_falloff(chosen, light.range, where)
    direction = np.asarray(normalize(np.asarray(light.direction, np.float64)), np.float32)
    return PunctualLight(kind=light.kind, position=np.asarray(light.position, np.float32), direction=direction,
                         intensity=np.asarray(light.radiometric, np.float32), falloff=chosen,
                         range=float(light.range or 0.0), cos_inner=math.cos(light.inner_cone),
                         cos_outer=math.cos(light.outer_cone))


def _check_falloff(falloff: str, range_, where: str) -> None:
    if falloff not in FALLOFFS:
        raise PatchlightError(f"{where}: unknown falloff {falloff!r} (choose from {', '.join(FALLOFFS)})")
    if falloff == "range" and not (range_ and range_ > 0):
        raise PatchlightError(f"{where}: range falloff needs a range > 0 metres")


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
    values = [_numbers(f, n, spec) for f, n in zip(fields, shapes[kind])]
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


def _numbers(field: str, count: int, spec: str) -> list[float]:
    try:
        values = [float(x) for x in field.split(",")]
    except ValueError:
        values = []
    if len(values) != count or not all(abs(v) <= FLOAT32_MAX for v in values):  # NaN fails too
        raise PatchlightError(f"--light {spec}: {field!r} should be {count} comma-separated numbers "
                              f"(each within float32's range)")
    return values


def _unit(v, spec: str) -> np.ndarray:
    a = np.asarray(v, np.float64)
    length = float(np.linalg.norm(a))
    if length == 0:
        raise PatchlightError(f"--light {spec}: direction must not be zero")
    return (a / length).astype(np.float32)
