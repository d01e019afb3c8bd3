"""Folding static shadows into the ground map: three ways:
separate maps, shadow in alpha, or folded into the colour.

Inputs per texel: the picture B (radiance seen from above, the bake's own shadows in it),
the unshadowed picture B_u = B + rho (1 - vis) I_sun (the sun's blocked share given back),
and the shadow amount s = lum(B) / lum(B_u) in [0, 1]: 1 in the sun, the fraction of light
left in shadow. The runtime ground colour is B (colour x s), its sky colour the sky's
light x s, so shadows darken the sky term too.

| encoding | texture(s)                       | ground at runtime    | sky at runtime                     |
|----------|----------------------------------|----------------------|------------------------------------|
| separate | colour RGB = B_u, shadow R = s   | colour.rgb x shadow  | sky_scale x shadow                 |
| alpha    | RGBA: rgb = B_u, a = s           | rgb x a              | sky_scale x a                      |
| hsv      | RGB: hue, sat of B, V = s        | rgb                  | dot(rgb, 1/3) x sky_scale          |

Texel values are linear and divided by `map_scale` (the radiance of a value of 1): for
separate and alpha the 99.9th percentile of B_u's largest channel, so next to nothing
clips; for hsv the map's average V, which every unshadowed texel then has (V = 1 stored),
while shadowed ones keep the lower V = s. `sky_scale` turns the average into the sky's
light: the sky colour / map_scale for separate and alpha; for hsv divided again by the
mean greyscale of the unshadowed texels. The greyscale of a hue-normalised texel is the
same for every grey but lower for saturated colours, so over saturated ground the sky
term is dimmer: the article's approximation, kept.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..shading.environment import LUMINANCE
from ..shading.hemisphere_radiosity import ENCODINGS  # the runtime model's ids for the encodings

__all__ = ["ENCODINGS", "EncodedMap", "add_noise", "encode", "hsv_to_rgb", "rgb_to_hsv", "shadow_amount"]
SCALE_PERCENTILE = 99.9
UNSHADOWED = 1.0 - 1e-6  # s at or above this counts as unshadowed


@dataclass
class EncodedMap:
    """color (H, W, 3 or 4) float32 in [0, 1], linear; shadow (H, W) float32 or None
    (separate only); map_scale: radiance of a texel value 1; sky_scale (3,) the runtime
    constant of the table above."""

    encoding: str
    color: np.ndarray
    shadow: np.ndarray | None
    map_scale: float
    sky_scale: np.ndarray


def add_noise(image: np.ndarray, amount: float, seed: int) -> np.ndarray:
    """image (H, W, 3) x (1 + amount x uniform(-1, 1)), an independent factor per texel and
    channel, so the noise survives the hsv encoding's brightness normalisation as a flicker
    of hue and saturation (the article adds about 10 %)."""
    rng = np.random.default_rng(seed)
    factor = 1.0 + amount * (2.0 * rng.random(image.shape, np.float32) - 1.0)
    return (image * factor).astype(np.float32)


def shadow_amount(excident: np.ndarray, unshadowed: np.ndarray) -> np.ndarray:
    """(H, W) s = lum(B) / lum(B_u), 1 where B_u is black."""
    lit = unshadowed @ LUMINANCE
    s = np.divide(excident @ LUMINANCE, lit, out=np.ones(lit.shape), where=lit > 0)
    return np.clip(s, 0.0, 1.0).astype(np.float32)


def rgb_to_hsv(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) hue in [0, 1), saturation, value (= max channel) of linear RGB (..., 3) >= 0."""
    rgb = np.asarray(rgb, np.float64)
    v = rgb.max(axis=-1)
    chroma = v - rgb.min(axis=-1)
    s = np.divide(chroma, v, out=np.zeros_like(v), where=v > 0)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    c = np.where(chroma > 0, chroma, 1.0)
    h = np.where(v == r, (g - b) / c, np.where(v == g, 2.0 + (b - r) / c, 4.0 + (r - g) / c))
    h = np.where(chroma > 0, (h / 6.0) % 1.0, 0.0)
    return np.stack([h, s, v], axis=-1)


def hsv_to_rgb(hsv: np.ndarray) -> np.ndarray:
    """(..., 3) linear RGB of hue in [0, 1), saturation, value (..., 3)."""
    h, s, v = (np.asarray(hsv, np.float64)[..., k] for k in range(3))
    k = (np.array([5.0, 3.0, 1.0]) + 6.0 * h[..., None]) % 6.0
    return v[..., None] - (v * s)[..., None] * np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0)


def encode(encoding: str, excident: np.ndarray, unshadowed: np.ndarray, shadow: np.ndarray,
           covered: np.ndarray, sky_light: np.ndarray) -> EncodedMap:
    """The map in `encoding` from B, B_u (H, W, 3), s (H, W), the covered texels (H, W) and
    the sky's incident light on an up-facing patch, (3,) radiance (module docstring).
    Texels with no surface under them are black, shadow 0 included."""
    if encoding == "hsv":
        return _encode_hsv(excident, shadow, covered, sky_light)
    shadow = np.where(covered, shadow, 0.0).astype(np.float32)
    brightest = unshadowed[covered].max(axis=-1) if covered.any() else np.zeros(1)
    scale = float(np.percentile(brightest, SCALE_PERCENTILE)) or 1.0
    color = np.clip(unshadowed / scale, 0.0, 1.0).astype(np.float32)
    color[~covered] = 0.0
    sky_scale = (np.asarray(sky_light, np.float64) / scale).astype(np.float32)
    if encoding == "alpha":
        return EncodedMap("alpha", np.concatenate([color, shadow[..., None]], axis=-1), None, scale, sky_scale)
    return EncodedMap("separate", color, shadow.astype(np.float32), scale, sky_scale)


def _encode_hsv(excident, shadow, covered, sky_light) -> EncodedMap:
    hsv = rgb_to_hsv(excident)
    average_v = float(hsv[..., 2][covered].mean()) if covered.any() else 0.0
    scale = average_v or 1.0
    hsv[..., 2] = shadow  # V / average: 1 unshadowed, s in shadow
    color = np.clip(hsv_to_rgb(hsv), 0.0, 1.0).astype(np.float32)
    color[~covered] = 0.0
    sunny = covered & (shadow >= UNSHADOWED)
    grey = color[sunny].mean() if sunny.any() else color[covered].mean() if covered.any() else 1.0
    sky_scale = (np.asarray(sky_light, np.float64) / scale / max(float(grey), 1e-6)).astype(np.float32)
    return EncodedMap("hsv", color, None, scale, sky_scale)

