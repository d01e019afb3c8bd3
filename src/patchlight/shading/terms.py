"""The lighting terms, one function per GLSL function of the same name in `patchlight/shaders/`.

Vectors are float arrays (..., 3) of unit length unless said otherwise; scalars per point are
(...,). Every function broadcasts like the GLSL it mirrors and keeps float32 float32. The
formulas and their sources are documented once, in the GLSL chunk named in each docstring.
"""
from __future__ import annotations

import numpy as np

from ..imaging.color import linear_to_srgb
from ..imaging.exposure import expose


def saturate(x):
    """common.glsl: clamp to [0, 1]."""
    return np.clip(x, 0.0, 1.0)


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(...,) dot products of (..., 3) vectors (GLSL's dot)."""
    return np.einsum("...i,...i->...", a, b)


def normalize(v: np.ndarray) -> np.ndarray:
    """(..., 3) unit vectors (GLSL's normalize)."""
    return v / np.sqrt(dot(v, v))[..., None]


def reflect(i: np.ndarray, n: np.ndarray) -> np.ndarray:
    """GLSL's reflect: i - 2 (n.i) n."""
    return i - 2.0 * dot(n, i)[..., None] * n


def lambert_diffuse(N: np.ndarray, L: np.ndarray) -> np.ndarray:
    """lambert.glsl: saturate(N.L), (...,)."""
    return saturate(dot(N, L))


def phong_specular(N: np.ndarray, L: np.ndarray, V: np.ndarray, shininess) -> np.ndarray:
    """phong.glsl: saturate(R.V)^n with R = normalize(2 saturate(N.L) N - L), (...,)."""
    R = normalize(2.0 * saturate(dot(N, L))[..., None] * N - L)
    return saturate(dot(R, V)) ** shininess


def blinn_phong_specular(N: np.ndarray, L: np.ndarray, V: np.ndarray, shininess) -> np.ndarray:
    """blinn_phong.glsl: saturate(N.H)^n with H = normalize(L + V), (...,)."""
    H = normalize(L + V)
    return saturate(dot(N, H)) ** shininess


def self_shadow(N: np.ndarray, L: np.ndarray) -> np.ndarray:
    """self_shadow.glsl: S = saturate(4 N.L), (...,)."""
    return saturate(4.0 * dot(N, L))


def hemisphere_light(N: np.ndarray, sky, ground) -> np.ndarray:
    """hemisphere.glsl: mix(ground, sky, 0.5 + 0.5 N.y), (..., 3); sky, ground (3,) linear RGB."""
    w = (0.5 + 0.5 * N[..., 1])[..., None]
    sky = np.asarray(sky, N.dtype)
    ground = np.asarray(ground, N.dtype)
    return ground + (sky - ground) * w


def fresnel_term(N: np.ndarray, V: np.ndarray, reflectivity) -> np.ndarray:
    """envmap.glsl: reflectivity (1 - saturate(N.V)), (...,)."""
    return reflectivity * (1.0 - saturate(dot(N, V)))


def reflect_view(N: np.ndarray, V: np.ndarray) -> np.ndarray:
    """envmap.glsl: reflect(-V, N), the eye ray mirrored off the surface, (..., 3)."""
    return reflect(-V, N)


def envmap_color(lit_color: np.ndarray, env: np.ndarray, fresnel: np.ndarray, reflectivity) -> np.ndarray:
    """envmap.glsl: mix(lit, env.rgb, fresnel) + env.a reflectivity; env (..., 4), result (..., 3)."""
    f = fresnel[..., None]
    k = np.asarray(reflectivity, lit_color.dtype)[..., None]
    return lit_color + (env[..., :3] - lit_color) * f + env[..., 3:4] * k


def decode_normal(t: np.ndarray) -> np.ndarray:
    """normal_map.glsl: 2 t - 1, texel values in [0, 1] to a tangent-space vector."""
    return 2.0 * t - 1.0


def perturb_normal(N: np.ndarray, tangent: np.ndarray, n: np.ndarray) -> np.ndarray:
    """normal_map.glsl: tangent-space n (..., 3) to world space in the frame (T, B, N).

    tangent (..., 4): xyz the interpolated tangent, w the handedness; N the front face's
    normal (a back face negates the result: glTF negates T, B and N alike)."""
    t = tangent[..., :3]
    T = normalize(t - N * dot(N, t)[..., None])
    sign = np.where(tangent[..., 3] < 0.0, -1.0, 1.0).astype(N.dtype)[..., None]
    B = np.cross(N, T) * sign
    return normalize(T * n[..., 0:1] + B * n[..., 1:2] + N * n[..., 2:3])


def display_encode(radiance: np.ndarray, exposure: float) -> np.ndarray:
    """display.glsl: sRGB encoding of the film exposure 1 - exp(-k x); values in [0, 1]."""
    return linear_to_srgb(expose(radiance, exposure))
