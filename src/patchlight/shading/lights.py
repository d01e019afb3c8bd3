"""Punctual lights as the shaders see them, and what each delivers to a surface point.

`directional_light`, `point_light`, `spot_light`, `spot_cone`, `inverse_square_falloff`,
`range_falloff` and `incident_light` mirror the GLSL functions of the same names
(light_*.glsl, falloff.glsl, lights.glsl). Units: a light returns incident light
I, so a white diffuse surface facing it shows radiance I N.L; radiant intensity J (W/sr)
gives I = J falloff / pi, a sun of irradiance E gives I = E / pi.
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
