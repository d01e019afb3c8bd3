"""The hemisphere-radiosity model: hemisphere lighting with a radiosity ground map, the NumPy
twin of shaders/hemisphere_radiosity.glsl (each function mirrors the GLSL function of the
same name; the steps, units and sources are documented there once).

`GroundMapInputs` holds what the GLSL takes as uniforms: the map texture(s), the planar
mapping rows, the encoding, the sky constant, the offset mode and side vector, and fog.
Without a baked map (`neutral_ground_map`) the model falls back to the article's plain
hemisphere: a one-texel map holding the scene's ground colour, and its sky colour.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..config import setting, validate_fields
from ..errors import PatchlightError, SettingError
from .terms import dot, envmap_color, saturate
from .textures import sample_bilinear

ENCODINGS = ("separate", "alpha", "hsv")      # GLSL RADIOSITY_SEPARATE, RADIOSITY_ALPHA, RADIOSITY_HSV
OFFSET_MODES = ("none", "normal", "side")     # GLSL OFFSET_NONE, OFFSET_NORMAL, OFFSET_SIDE
_WHITE = np.ones((1, 1, 4), np.float32)


@dataclass
class GroundMapInputs:
    """The model's uniforms.

    texture (H, W, 4) float32 linear texels in [0, 1] (alpha 1 for RGB maps); shadow (H, W, 4)
    the separate encoding's shadow map (amount in R), else one white texel; U, V (4,) world
    (x, y, z, 1) -> u, v rows; encoding in ENCODINGS; map_scale radiance of a texel value 1;
    sky_scale (3,); offset_mode in OFFSET_MODES; offset metres; side (3,) unit left-right axis
    of the object, world space; fog_color (3,) radiance; fog_range (start, end) metres, off
    when end <= start."""

    texture: np.ndarray
    U: np.ndarray
    V: np.ndarray
    encoding: str = setting(unit="", meaning="how the map holds the sun's shadows", choices=ENCODINGS)
    map_scale: float = setting(unit="radiance", meaning="the radiance of a texel value 1", lo=0, lo_open=True)
    sky_scale: np.ndarray = setting(unit="radiance", meaning="the sky constant", length=3)
    shadow: np.ndarray = field(default_factory=lambda: _WHITE.copy())
    offset_mode: str = setting("normal", "", "where the map is sampled", choices=OFFSET_MODES)
    offset: float = setting(1.0, "m", "sample offset distance", lo=0.0)
    side: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0], np.float32))
    fog_color: np.ndarray = field(default_factory=lambda: np.zeros(3, np.float32))
    fog_range: tuple[float, float] = (0.0, 0.0)

    @property
    def neutral(self) -> float:
        """radiosity_neutral: the radiance of the listing's neutral value 0.5."""
        return 0.5 * float(self.map_scale)

    def validate(self) -> None:
        validate_fields(self)
        side = np.asarray(self.side, np.float64)
        if abs(np.linalg.norm(side) - 1.0) > 1e-3:
            raise SettingError("side", side.tolist(), "must have unit length")

    def with_options(self, **changes) -> "GroundMapInputs":
        """A copy with some fields changed (offset mode, side, fog ...)."""
        return replace(self, **changes)


def neutral_ground_map(sky, ground) -> GroundMapInputs:
    """The fallback without a baked map: one texel of the ground colour (3,) and the sky
    colour (3,) as the sky term, both incident light; encoding alpha with no shadow."""
    sky = np.asarray(sky, np.float32)
    ground = np.asarray(ground, np.float32)
    scale = float(max(sky.max(), ground.max(), 1e-6))
    texel = np.ones((1, 1, 4), np.float32)
    texel[0, 0, :3] = ground / scale
    return GroundMapInputs(texture=texel, U=np.zeros(4, np.float32), V=np.zeros(4, np.float32), encoding="alpha",
                           map_scale=scale, sky_scale=(sky / scale).astype(np.float32))


def check_ambient(ambient) -> None:
    """The sun modulation divides by the ambient light: every channel must be positive."""
    if not np.all(np.asarray(ambient) > 0):
        raise PatchlightError("hemisphere-radiosity: the ambient light must be positive in every channel "
                              "(it is the neutral level the sun term is measured against)")


def radiosity_sample_point(m: GroundMapInputs, P: np.ndarray, N: np.ndarray) -> np.ndarray:
    """(N, 3) the map sample point of points P with (interpolated) normals N (N, 3)."""
    if m.offset_mode == "normal":
        return P + np.float32(m.offset) * N
    if m.offset_mode == "side":
        side = np.asarray(m.side, P.dtype)
        return P + (np.float32(m.offset) * dot(N, side))[..., None] * side
    return P.copy()


def radiosity_map_uv(m: GroundMapInputs, S: np.ndarray) -> np.ndarray:
    """(N, 2) map coordinates of world points S (N, 3) by the U and V rows."""
    U = np.asarray(m.U, S.dtype)
    V = np.asarray(m.V, S.dtype)
    return np.stack([S @ U[:3] + U[3], S @ V[:3] + V[3]], axis=-1).astype(np.float32)


def radiosity_tween(N: np.ndarray) -> np.ndarray:
    """(N,) the ground's weight 0.5 - 0.5 N.y."""
    return 0.5 - 0.5 * N[..., 1]


def radiosity_shade(m: GroundMapInputs, texel: np.ndarray, shadow: np.ndarray) -> np.ndarray:
    """(N,) the sky's share at texels (N, 4) with separate shadows (N,)."""
    if m.encoding == "hsv":
        return texel[..., :3].mean(axis=-1)
    return texel[..., 3] if m.encoding == "alpha" else shadow


def radiosity_ground(m: GroundMapInputs, texel: np.ndarray, shadow: np.ndarray) -> np.ndarray:
    """(N, 3) the ground colour (map units) at texels (N, 4) with separate shadows (N,)."""
    if m.encoding == "hsv":
        return texel[..., :3].copy()
    amount = texel[..., 3] if m.encoding == "alpha" else shadow
    return texel[..., :3] * amount[..., None]


def radiosity_sky(m: GroundMapInputs, texel: np.ndarray, shadow: np.ndarray) -> np.ndarray:
    """(N, 3) the shadowed sky colour (map units)."""
    return radiosity_shade(m, texel, shadow)[..., None] * np.asarray(m.sky_scale, np.float32)


def radiosity_light(ground: np.ndarray, sky: np.ndarray, tween: np.ndarray) -> np.ndarray:
    """(N, 3) mix(sky, ground, tween)."""
    return sky + (ground - sky) * tween[..., None]


def hemisphere_radiosity(m: GroundMapInputs, P: np.ndarray, N: np.ndarray) -> np.ndarray:
    """(N, 3) R in map units at points P with interpolated normals N (N, 3): steps 1-5."""
    uv = radiosity_map_uv(m, radiosity_sample_point(m, P, N))
    texel = sample_bilinear(m.texture, uv, wrap="clamp")
    shadow = sample_bilinear(m.shadow, uv, wrap="clamp")[:, 0]
    return radiosity_light(radiosity_ground(m, texel, shadow), radiosity_sky(m, texel, shadow),
                           radiosity_tween(N)).astype(np.float32)


def radiosity_sun(diffuse: np.ndarray, ambient) -> np.ndarray:
    """(N, 3) the listing's v0 = 0.5 lit.diffuse / ambient."""
    return 0.5 * diffuse / np.maximum(np.asarray(ambient, np.float32), np.float32(1e-6))


def hemisphere_radiosity_color(m: GroundMapInputs, base: np.ndarray, env: np.ndarray, diffuse: np.ndarray,
                               fresnel: np.ndarray, radiosity: np.ndarray, reflectivity, ambient) -> np.ndarray:
    """(N, 3) radiance, steps 6-8: base colour (N, 3), cube map texels env (N, 4), the light
    sum's diffuse (N, 3) and fresnel (N,), R (N, 3), reflectivity scalar or (N,)."""
    c = envmap_color(base, env / np.float32(m.neutral), fresnel, reflectivity)
    c = 2.0 * c * radiosity
    c = 2.0 * c * radiosity_sun(diffuse, ambient)
    return (np.float32(m.neutral) * c).astype(np.float32)


def fog_factor(m: GroundMapInputs, P: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """(N,) 1 - fog: 1 before fog_range start, 0 from its end, linear in distance between."""
    start, end = (float(x) for x in m.fog_range)
    if end <= start:
        return np.ones(len(P), np.float32)
    d = np.sqrt(dot(P - np.asarray(eye, P.dtype), P - np.asarray(eye, P.dtype)))
    return saturate((np.float32(end) - d) / np.float32(end - start)).astype(np.float32)


def apply_fog(m: GroundMapInputs, radiance: np.ndarray, f: np.ndarray) -> np.ndarray:
    """(N, 3) mix(fog colour, radiance, f)."""
    fog = np.asarray(m.fog_color, np.float32)
    return (fog + (radiance - fog) * f[..., None]).astype(np.float32)
