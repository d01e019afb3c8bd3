"""The lightmap as scene.glb carries it: two images of the same linear quantity I / scale.

- an RGBE Radiance .hdr (`encode_hdr`): HDR, about 0.4 % precision at any brightness (an
  8-bit mantissa per channel, one shared exponent); three.js decodes it with its own
  HDRLoader (`bench/bench_lightmap_encoding.py` measures every candidate through three.js's
  loaders);
- an 8-bit linear PNG: what any glTF viewer can show, precise to scale / 510 absolute.

scale is the lightmap's peak, so the PNG never clips; a renderer multiplies the texel by
scale (and by pi for three.js, whose lightMap is irradiance: MOZ_lightmap's intensity).

A directional lightmap (`encode_directional`) goes beside it as one half-float EXR per layer
(L0, L1x, L1y, L1z of L1 spherical harmonics, or the dominant direction x its share): signed
values, which neither .hdr nor PNG hold, 2^-11 relative precision, decoded by three.js's own
EXRLoader (`bench/bench_directional_encoding.py` measured the candidates). The SH layers are
divided by the lightmap's scale (so they lie near 1, far inside half's range); the dominant
direction is stored as it is (scale 1).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .bands import banded
from .io import encode_exr, encode_hdr, encode_png

MIN_SCALE = 1e-6  # a black lightmap still gets a positive scale


@dataclass(frozen=True)
class EncodedLightmap:
    """hdr: .hdr bytes; png: 8-bit RGB PNG bytes; both hold I / scale, row 0 at v = 0."""

    hdr: bytes
    png: bytes
    scale: float


def encode_lightmap(lightmap: np.ndarray, scale: float | None = None) -> EncodedLightmap:
    """The two images of an (H, W, 3) float incident-light lightmap (module docstring); scale:
    the one several atlases share (values above it clip in the PNG), else the lightmap's peak."""
    lightmap = np.asarray(lightmap)
    scale = lightmap_scale(lightmap) if scale is None else scale

    def relative(rows):
        return np.maximum(np.asarray(rows, np.float64), 0.0) / scale

    png = encode_png(banded(lambda rows: np.round(np.clip(relative(rows), 0.0, 1.0) * 255.0), lightmap, np.uint8))
    return EncodedLightmap(encode_hdr(banded(relative, lightmap, np.float32)), png, scale)


def lightmap_scale(lightmap: np.ndarray) -> float:
    """The scale of an (H, W, 3) lightmap's encoding: its peak (at least MIN_SCALE)."""
    return max(float(np.max(lightmap, initial=0.0)), MIN_SCALE)


@dataclass(frozen=True)
class EncodedDirectional:
    """mode "sh" or "dominant"; layers: their names ("L0", ... or "" for the dominant direction);
    exr: one half-float EXR per layer holding the values / scale, row 0 at v = 0."""

    mode: str
    layers: tuple[str, ...]
    exr: tuple[bytes, ...]
    scale: float


def encode_directional(mode: str, layers: dict[str, np.ndarray], scale: float) -> EncodedDirectional:
    """The EXRs of a directional lightmap's (H, W, 3) layers (module docstring); `scale`: the
    lightmap's (EncodedLightmap.scale), which divides the SH layers."""
    divisor = scale if mode == "sh" else 1.0
    return EncodedDirectional(mode, tuple(layers), tuple(encode_exr(np.asarray(values, np.float64) / divisor, half=True)
                                                         for values in layers.values()), divisor)
