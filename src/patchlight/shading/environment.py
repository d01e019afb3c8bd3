"""Light from the surroundings for the ambient, hemisphere and envmap models.

- `sky_incident(sky)`: the incident light I of an up-facing and a down-facing patch
  under the sky: the hemisphere model's sky and ground colours, exact at the two poles. Their
  mean is the ambient colour: the hemisphere term averaged over all normal directions.
- `environment_from_sky(sky, lights, size)`: the envmap model's cube map: RGB the sky's
  radiance, A the suns' specular highlight (`light_highlight`), as the article's cube map
  keeps "a specular highlight in the alpha channel".
"""
from __future__ import annotations

import numpy as np

from .lights import PunctualLight, incident_light
from .terms import dot, saturate
from .textures import cube_directions

ENV_SIZE = 64  # cube face texels; 64 resolves a sky gradient and a highlight of exponent 64
HIGHLIGHT_EXPONENT = 64.0  # sharpness of the lights' highlight in the cube map's alpha
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 weights of linear RGB: the luminance of a colour
_QUADRATURE = (64, 128)  # cos(theta) x phi midpoints per hemisphere


def sky_incident(sky) -> tuple[np.ndarray, np.ndarray]:
    """(sky_up, ground_down), each (3,): the cosine-weighted mean radiance that an up-facing and
    a down-facing patch receive from `sky` (patchlight.scene.sky.Sky). A uniform sky L gives L."""
    n_mu, n_phi = _QUADRATURE
    mu = (np.arange(n_mu) + 0.5) / n_mu
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2 * np.pi
    m, p = np.meshgrid(mu, phi, indexing="ij")
    r = np.sqrt(1 - m * m)
    weight = (m / m.sum()).reshape(-1, 1)
    result = []
    for sign in (1.0, -1.0):
        dirs = np.stack([r * np.cos(p), sign * m, r * np.sin(p)], axis=-1).reshape(-1, 3)
        result.append((sky.radiance(dirs.astype(np.float32)) * weight).sum(axis=0).astype(np.float32))
    return result[0], result[1]


def light_highlight(directions: np.ndarray, lights: list[PunctualLight]) -> np.ndarray:
    """(N,) the suns' highlight in a mirror, along unit directions (N, 3): the sum over
    directional lights of luminance(I) saturate(d.L)^HIGHLIGHT_EXPONENT. Like the article's
    static cube map it holds only light from infinitely far away, so it does not depend on
    where the map is seen from, and point lights (whose direction does) are left out."""
    out = np.zeros(len(directions), np.float32)
    origin = np.zeros((1, 3), np.float32)
    for light in lights:
        if light.kind == "directional":
            L, I = incident_light(light, origin)
            out += float(I[0] @ LUMINANCE) * saturate(dot(directions, L[0])) ** HIGHLIGHT_EXPONENT
    return out


def environment_from_sky(sky, lights: list[PunctualLight], size: int = ENV_SIZE) -> np.ndarray:
    """(6, size, size, 4) float32 cube map: RGB sky radiance (black without a sky), A highlight."""
    dirs = cube_directions(size).reshape(-1, 3)
    rgb = sky.radiance(dirs) if sky is not None else np.zeros((len(dirs), 3), np.float32)
    alpha = light_highlight(dirs, lights)
    return np.concatenate([rgb, alpha[:, None]], axis=1).reshape(6, size, size, 4).astype(np.float32)
