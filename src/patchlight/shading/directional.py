"""Directional lightmaps: what a texel stores beside the incident light I, and the
`lightmap-directional` model's evaluation (the NumPy twin of lightmap_directional.glsl).

Two modes (BakeSettings.directional):

- "sh": L1 spherical harmonics of the incident radiance L (W m^-2 sr^-1) over the texel's
  hemisphere, per colour channel: c0 = integral L Y00, c1 = integral L (Y1x, Y1y, Y1z) with
  Y00 = 1 / (2 sqrt(pi)), Y1 = sqrt(3 / (4 pi)) (x, y, z) in world axes. Their
  clamped-cosine convolution gives the incident light (our I, irradiance / pi) a normal n
  sees: sh(n) = Y00 c0 + (2/3) Y1(n) . c1 (Ramamoorthi and Hanrahan's A0 = pi, A1 = 2 pi / 3,
  divided by pi). Stored as layers L0, L1x, L1y, L1z, each R, G, B (files: patchlight.bakedir).
- "dominant": the luminance-weighted mean direction the light arrives from, a vector whose
  length is its share (1: all light from one direction, 0: evenly spread), as Unity's
  directional mode. Stored as RGB = x, y, z.

The model keeps the plain lightmap exactly where the normal is the surface's own normal N0 and
redistributes it elsewhere: sh: I x max(sh(n), 0) / sh(N0) (I itself where sh(N0) is 0);
dominant: I x (0.5 + 0.5 n.d) /
(0.5 + 0.5 N0.d) (the half-Lambert rebalance). Under a single sun of irradiance Es at angle
theta, L1 gives sh(n) = Es (1/4 + cos(theta) / 2) / pi where the exact light is Es
max(cos(theta), 0) / pi: L1 cannot do better than this projection, whose error is at most
Es / (4 pi) (at cos 1 and cos 0). Specular (with LIGHTMAP_SPECULAR): the dominant direction
as a light of strength share x I, Blinn-Phong, limited by the gloss; the punctual lights add
nothing (their light is in the maps, so their highlight is this one)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import DIRECTIONAL_MODES, setting, validate_fields
from .terms import blinn_phong_specular
from .textures import sample_bilinear

MODES = DIRECTIONAL_MODES
Y00 = 0.28209479177387814  # 1 / (2 sqrt(pi))
Y1 = 0.4886025119029199    # sqrt(3 / (4 pi))
SH_LAYERS = ("L0", "L1x", "L1y", "L1z")
LUMINANCE = np.array([0.2126, 0.7152, 0.0722], np.float32)
FLOOR = 1e-6  # the smallest denominator of a rebalance, as the shader's


@dataclass
class DirectionalLightmap:
    """mode "sh": maps (4, H, W, 3) f32 = L0, L1x, L1y, L1z per colour channel; mode
    "dominant": maps (1, H, W, 3) f32 = the dominant direction times its share."""

    mode: str = setting(unit="", meaning="what the maps hold", choices=MODES)
    maps: np.ndarray = setting(unit="", meaning="the maps (K, H, W, 3)")

    def __post_init__(self):
        validate_fields(self)
        self.maps = np.asarray(self.maps, np.float32)

    def texels(self, uv1: np.ndarray) -> np.ndarray:
        """(K, N, 3) the maps at lightmap UVs uv1 (N, 2), bilinear, edges clamped (as the lightmap)."""
        return np.stack([sample_bilinear(m, uv1, wrap="clamp")[:, :3] for m in self.maps])


def sh_light(texels: np.ndarray, n: np.ndarray) -> np.ndarray:
    """lightmap_directional.glsl: the L1 incident light (N, 3) a unit normal n (N, 3) sees."""
    return Y00 * texels[0] + (2.0 / 3.0) * Y1 * (texels[1] * n[:, :1] + texels[2] * n[:, 1:2] + texels[3] * n[:, 2:])


def directional_light(mode: str, texels: np.ndarray, baked: np.ndarray, N: np.ndarray, N0: np.ndarray) -> np.ndarray:
    """lightmap_directional.glsl: the lightmap's I (N, 3) redistributed for the (normal-mapped)
    normal N, equal to I at the surface normal N0 (both (N, 3) unit)."""
    if mode == "sh":  # where L1 saw no light (I from emitters its rays missed), I as it is
        at_n0 = sh_light(texels, N0)
        return baked * np.where(at_n0 > FLOOR, np.maximum(sh_light(texels, N), 0.0) / np.maximum(at_n0, FLOOR), 1.0)
    d = texels[0]
    rebalance = (0.5 + 0.5 * np.einsum("ij,ij->i", N, d)) / np.maximum(0.5 + 0.5 * np.einsum("ij,ij->i", N0, d), FLOOR)
    return baked * rebalance[:, None]


def dominant_direction(mode: str, texels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """lightmap_directional.glsl: unit direction (N, 3) the light mostly comes from and its
    share (N,) in [0, 1]. For sh: the luminance of L1 over sqrt(3) x that of L0 (1 for one
    direction)."""
    if mode == "sh":
        vector = np.einsum("kic,c->ik", texels[1:], LUMINANCE)
        total = np.sqrt(3.0) * (texels[0] @ LUMINANCE)
    else:
        vector = texels[0]
        total = np.ones(len(vector), np.float32)
    length = np.linalg.norm(vector, axis=1)
    share = np.clip(length / np.maximum(total, FLOOR), 0.0, 1.0)
    return vector / np.maximum(length, FLOOR)[:, None], share


def directional_specular(mode: str, texels: np.ndarray, baked: np.ndarray, N, V, gloss, shininess) -> np.ndarray:
    """lightmap_directional.glsl: the dominant direction's Blinn-Phong highlight (N, 3), as a
    light of share x I, limited by the gloss."""
    L, share = dominant_direction(mode, texels)
    return (np.minimum(blinn_phong_specular(N, L, V, shininess), gloss) * share)[:, None] * baked
