"""Direct light from the sun, point and spot lights, ray traced (never rendered into
hemicubes: the radiosity article found point lights lost at hemicube edges).

Units (docs/architecture.md): each light adds incident light I = radiance-equivalent of its
irradiance, E / pi. Sun: I = Es max(0, n.l) V / pi. Point and spot: I = Iv cos / d^2 V / pi
(inverse-square, windowed smoothly to 0 at the light's range when it has one), or with the
game falloff `range`: I = Iv cos (1 - (d/r)^2)_+ V / pi.
"""
from __future__ import annotations

import numpy as np

from ..scene.model import Light
from ..rays.tracer import Tracer
from .hemicube import concentric_disk

FALLOFFS = ("inverse-square", "range")


def falloff_factor(d: np.ndarray, light: Light, default: str) -> np.ndarray:
    """(N,) distance attenuation of a point or spot light at distances d (metres)."""
    model = light.falloff or default
    if model == "range":
        r = light.range if light.range else 10.0
        return np.clip(1.0 - (d / r) ** 2, 0.0, 1.0)
    inv = 1.0 / np.maximum(d, 1e-6) ** 2
    if light.range:
        # KHR_lights_punctual's recommended window: reaches 0 smoothly at the range.
        inv = inv * np.clip(1.0 - (d / light.range) ** 4, 0.0, 1.0) ** 2
    return inv


def spot_factor(to_point: np.ndarray, light: Light) -> np.ndarray:
    """(N,) cone attenuation: 1 inside the inner cone, 0 outside the outer, smooth between
    (KHR_lights_punctual's interpolation of the cosine, squared)."""
    cos_d = to_point @ np.asarray(light.direction, np.float64)
    cos_outer, cos_inner = np.cos(light.outer_cone), np.cos(light.inner_cone)
    scale = 1.0 / max(1e-3, cos_inner - cos_outer)
    return np.clip((cos_d - cos_outer) * scale, 0.0, 1.0) ** 2


def _sun_directions(light: Light, angle: float, samples: int) -> np.ndarray:
    """(K, 3) unit directions towards the sun: its centre, or K stratified over its disc."""
    to_sun = -np.asarray(light.direction, np.float64)
    to_sun /= np.linalg.norm(to_sun)
    if angle <= 0 or samples <= 1:
        return to_sun[None]
    s = int(np.sqrt(samples))
    i, j = np.meshgrid(np.arange(s), np.arange(s), indexing="ij")
    x, y = concentric_disk((i.ravel() + 0.5) / s, (j.ravel() + 0.5) / s)
    radius = np.tan(angle / 2)
    helper = np.array([1.0, 0, 0]) if abs(to_sun[0]) < 0.9 else np.array([0, 1.0, 0])
    t = np.cross(to_sun, helper)
    t /= np.linalg.norm(t)
    b = np.cross(to_sun, t)
    dirs = to_sun + radius * (x[:, None] * t + y[:, None] * b)
    return dirs / np.linalg.norm(dirs, axis=1, keepdims=True)


def sun_light(origins, normals, light: Light, tracer: Tracer, angle: float, samples: int) -> np.ndarray:
    """(N, 3) incident light from a directional light with ray-traced (soft) shadows.
    origins (N, K, 3): K points per texel; shadow ray j leaves from point j mod K."""
    dirs = _sun_directions(light, angle, samples)
    k = origins.shape[1]
    rays = max(len(dirs), k)
    visible_cos = np.zeros(len(origins))
    for j in range(rays):
        d = dirs[j % len(dirs)]
        cos = normals @ d
        lit = np.flatnonzero(cos > 0)
        blocked = tracer.occluded(origins[lit, j % k], np.broadcast_to(d, (len(lit), 3)), np.float32(1e30))
        visible_cos[lit] += np.where(blocked, 0.0, cos[lit])
    return (visible_cos / rays)[:, None] * light.radiometric[None] / np.pi


def local_light(origins, normals, light: Light, tracer: Tracer, falloff: str) -> np.ndarray:
    """(N, 3) incident light from a point or spot light with ray-traced shadows, averaged
    over the K points per texel of origins (N, K, 3)."""
    value = np.zeros(len(origins))
    for k in range(origins.shape[1]):
        o = origins[:, k]
        to_light = np.asarray(light.position, np.float64)[None] - o
        d = np.linalg.norm(to_light, axis=1)
        l = to_light / np.maximum(d, 1e-9)[:, None]
        strength = np.einsum("ij,ij->i", normals, l) * falloff_factor(d, light, falloff)
        if light.kind == "spot":
            strength *= spot_factor(-l, light)
        lit = np.flatnonzero(strength > 0)
        blocked = tracer.occluded(o[lit], l[lit], (d[lit] * (1 - 1e-4)).astype(np.float32))
        value[lit] += np.where(blocked, 0.0, strength[lit])
    return (value / origins.shape[1])[:, None] * light.radiometric[None] / np.pi


def direct_light(origins: np.ndarray, normals: np.ndarray, lights: list[Light], tracer: Tracer,
                 falloff: str = "inverse-square", sun_angle: float | None = None,
                 sun_samples: int = 16) -> np.ndarray:
    """(N, 3) f32 incident light I from every light, at points `origins` (N, 3), or (N, K, 3)
    for K points spread over each texel, already lifted off their surfaces, with unit normals
    (N, 3). sun_angle (radians) overrides each sun's."""
    origins = np.asarray(origins, np.float64)
    if origins.ndim == 2:
        origins = origins[:, None, :]
    normals = np.asarray(normals, np.float64)
    total = np.zeros((len(origins), 3))
    for light in lights:
        if light.kind == "directional":
            angle = light.angle if sun_angle is None else sun_angle
            total += sun_light(origins, normals, light, tracer, angle, sun_samples)
        else:
            total += local_light(origins, normals, light, tracer, falloff)
    return total.astype(np.float32)
