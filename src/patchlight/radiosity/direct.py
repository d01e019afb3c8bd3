"""Direct light from the sun, point and spot lights, ray traced (never rendered into
hemicubes: the radiosity article found point lights lost at hemicube edges).

Units (docs/architecture.md): each light adds incident light I = radiance-equivalent of its
irradiance, E / pi. Sun: I = Es max(0, n.l) V / pi. Point and spot: I = Iv cos / d^2 V / pi
(inverse-square, the physical law, windowed to zero at a light's range when it has one), or
with the game falloff `range`: I = Iv cos (1 - (d/r)^2)_+ V / pi; spot cones as
KHR_lights_punctual. Point and spot lights use the runtime's own functions
(shading.lights), so a baked lamp and the same lamp in the shaders give the same light.
"""
from __future__ import annotations

import numpy as np

from ..scene.model import Light
from ..rays.tracer import Tracer
from ..shading.lights import from_scene_light, incident_light
from .hemicube import concentric_disk


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
    origins (N, K, 3): K shadow-ray origins per texel; shadow ray j leaves from point j mod K."""
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


def local_light(points, origins, normals, light: Light, tracer: Tracer, falloff: str) -> np.ndarray:
    """(N, 3) incident light from a point or spot light with ray-traced shadows, averaged
    over the K points per texel of points (N, K, 3). The light is evaluated at the points
    themselves; shadow rays leave from `origins` (N, K, 3), the points lifted. The
    falloff and cone are the runtime models' own (shading.lights, the NumPy twin of the
    GLSL), so baked and real-time light agree."""
    lamp = from_scene_light(light, falloff, f"light {light.name or light.kind!r}")
    value = np.zeros((len(points), 3))
    for k in range(points.shape[1]):
        L, I = incident_light(lamp, points[:, k])
        strength = np.maximum(np.einsum("ij,ij->i", normals, L), 0.0)[:, None] * I
        lit = np.flatnonzero(strength.max(axis=1) > 0)
        to_lamp = lamp.position - origins[lit, k]
        d = np.linalg.norm(to_lamp, axis=1)
        blocked = tracer.occluded(origins[lit, k], to_lamp / d[:, None], (d * (1 - 1e-4)).astype(np.float32))
        value[lit] += np.where(blocked[:, None], 0.0, strength[lit])
    return value / points.shape[1]


def direct_light(points: np.ndarray, normals: np.ndarray, lights: list[Light], tracer: Tracer,
                 falloff: str = "inverse-square", sun_angle: float | None = None,
                 sun_samples: int = 16, lift=0.0) -> np.ndarray:
    """(N, 3) f32 incident light I from every light at `points` (N, 3), or (N, K, 3) for K
    points spread over each texel, with unit normals (N, 3). Shadow rays leave from the
    points lifted by `lift` metres along the normal (a scalar or (N,)), so that they clear
    their own surface; the light itself is evaluated on the surface. sun_angle (radians)
    overrides each sun's."""
    points = np.asarray(points, np.float64)
    if points.ndim == 2:
        points = points[:, None, :]
    normals = np.asarray(normals, np.float64)
    lift = np.broadcast_to(np.asarray(lift, np.float64), (len(points),))[:, None, None]
    origins = points + lift * normals[:, None]
    total = np.zeros((len(points), 3))
    for light in lights:
        if light.kind == "directional":
            angle = light.angle if sun_angle is None else sun_angle
            total += sun_light(origins, normals, light, tracer, angle, sun_samples)
        else:
            total += local_light(points, origins, normals, light, tracer, falloff)
    return total.astype(np.float32)
