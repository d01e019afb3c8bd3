"""The lightmap as scene.glb carries it: two images of the same linear quantity I / scale.

- an RGBE Radiance .hdr (`encode_hdr`): HDR, about 0.4 % precision at any brightness (an
  8-bit mantissa per channel, one shared exponent); three.js decodes it with its own
  HDRLoader (`bench/bench_lightmap_encoding.py` measures every candidate through three.js's
  loaders);
- an 8-bit linear PNG: what any glTF viewer can show, precise to scale / 510 absolute.

scale is the lightmap's peak, so the PNG never clips; a renderer multiplies the texel by
scale (and by pi for three.js, whose lightMap is irradiance: MOZ_lightmap's intensity).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .io import encode_hdr, encode_png

MIN_SCALE = 1e-6  # a black lightmap still gets a positive scale


@dataclass(frozen=True)
class EncodedLightmap:
    """hdr: .hdr bytes; png: 8-bit RGB PNG bytes; both hold I / scale, row 0 at v = 0."""

    hdr: bytes
    png: bytes
    scale: float


def encode_lightmap(lightmap: np.ndarray) -> EncodedLightmap:
    """The two images of an (H, W, 3) float incident-light lightmap (module docstring)."""
    values = np.maximum(np.asarray(lightmap, np.float64), 0.0)
    scale = max(float(values.max(initial=0.0)), MIN_SCALE)
    relative = values / scale
    png = encode_png(np.round(np.clip(relative, 0.0, 1.0) * 255.0).astype(np.uint8))
    return EncodedLightmap(encode_hdr(relative.astype(np.float32)), png, scale)
