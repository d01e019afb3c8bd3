"""Directional lightmaps baked (BakeSettings.directional sh or dominant; the formats and the runtime
model are `patchlight.shading.directional`'s).

Once the passes have converged, every valid texel looks again through the gather's own rays
(same pattern, same turn per patch) at the solved excident light B and the sky, and each
light's direct share arrives from its direction (the sun's, or towards the lamp). Emitters:
when the direct stage samples them (next-event estimation), their samples give their light
and its directions, at full weight, and the rays see only B - E; otherwise the rays see their
emission in B. Each piece of light is projected:

- L1 SH of radiance: a ray of weight w (the pattern's weights sum to 1 and stand for
  cos dw / pi) carries solid angle dw = pi w / cos, so c += L dw (Y00, Y1 w_dir). The 1/cos
  of grazing rays makes that noisy (a uniform sky came out up to 12 % off at 1024 rays), so
  the part of L that a + b cos fits (least squares over the rays' weights) is projected
  exactly and only the rest goes through the rays: light even around the normal costs no
  noise, and the noise scales with how uneven the rest is. A lamp
  whose incident light is I from a direction at cosine cos is a radiance delta of irradiance
  E = pi I / cos: c += E (Y00, Y1 l).
- dominant direction: the luminance-weighted mean of the incident-light pieces' directions,
  sum lum(I_piece) dir / sum lum(I_piece), whose length is its share.

F holds no directions (it would take four times its memory), hence the second look: it costs
one more gather of every valid texel, traced straight into these sums and never stored.
"""
from __future__ import annotations

import numpy as np

from ..atlas.patches import Patches
from ..atlas.raster import TexelPoints
from ..shading.directional import LUMINANCE, Y00, Y1, DirectionalLightmap
from . import _kernels
from .emitters import next_event_rays
from .gather import Gatherer

MIN_COS = 1e-4  # grazing rays: cosines below this count as this, bounding their solid angle
EMITTER_CHUNK = 4096  # texels whose emitter samples are traced at a time


class DirectionalSums:
    """Per-patch sums: sh (N, 4, 3) L1 coefficients; dominant (N, 4) luminance-weighted
    direction (xyz) and total luminance (w)."""

    def __init__(self, n: int):
        self.sh = np.zeros((n, 4, 3))
        self.dominant = np.zeros((n, 4))

    def add_sh(self, rows: np.ndarray, irradiance: np.ndarray, dirs: np.ndarray) -> None:
        """K pieces of radiance x solid angle per patch, irradiance (R, K, 3), arriving along
        unit dirs (R, K, 3) at distinct patches rows (R,)."""
        self.sh[rows, 0] += Y00 * irradiance.sum(axis=1)
        self.sh[rows, 1:] += Y1 * np.einsum("rka,rkc->rac", dirs, irradiance)

    def add_dominant(self, rows: np.ndarray, incident: np.ndarray, dirs: np.ndarray) -> None:
        """K pieces of incident light per patch, I (R, K, 3), arriving along unit dirs (R, K, 3)
        at distinct patches rows (R,)."""
        lum = incident @ LUMINANCE                                       # (R, K)
        self.dominant[rows, :3] += np.einsum("rk,rka->ra", lum, dirs)
        self.dominant[rows, 3] += lum.sum(axis=1)

    def lightmap_values(self, mode: str) -> np.ndarray:
        """(N, C) per-patch values of the mode's maps: 12 for sh (L0, L1x, L1y, L1z x RGB), 3 for dominant."""
        if mode == "sh":
            return self.sh.reshape(len(self.sh), 12).astype(np.float32)
        total = np.maximum(self.dominant[:, 3:], 1e-12)
        return (self.dominant[:, :3] / total).astype(np.float32)


def gather_directions(gatherer: Gatherer, B: np.ndarray, rows: np.ndarray, advance=None) -> DirectionalSums:
    """The sums of what the gather's rays from patches `rows` (distinct) see (B (N, 3) at
    patch hits, the sky at misses), chunk by chunk on the tracer's threads
    (`_kernels.directional_sums`: each chunk's rays go straight into its patches' sums; no
    chunk keeps its rays' light or directions)."""
    sums = DirectionalSums(len(gatherer.patches))
    weights = gatherer.weights.astype(np.float64)
    cos = gatherer.dirs[:, 2].astype(np.float64)  # local z = cos
    solid_angle = np.pi * weights / np.maximum(cos, MIN_COS)
    moments = np.linalg.inv([[weights.sum(), weights @ cos], [weights @ cos, weights @ cos ** 2]])
    B = np.ascontiguousarray(B, np.float64)
    basis, luminance = np.array([Y00, Y1]), LUMINANCE.astype(np.float64)

    def chunk(part, seen, dirs):
        sky = np.asarray(gatherer.sky_seen(seen, dirs), np.float64)
        _kernels.directional_sums(part.astype(np.int64), seen, dirs, B, sky, weights, cos,
                                  solid_angle, moments, gatherer.patches.normal, basis, luminance,
                                  sums.sh, sums.dominant)
        if advance is not None:
            advance(len(part))

    gatherer.look_rows(rows, chunk)
    return sums


def add_direct(sums: DirectionalSums, patches: Patches, lights, per_light: list[np.ndarray]) -> None:
    """Add each light's direct incident light (per_light: (N, 3) per light) from its direction."""
    for light, incident in zip(lights, per_light):
        if light.kind == "directional":
            to_light = np.broadcast_to(-np.asarray(light.direction, np.float64), (len(patches), 3))
        else:
            to_light = np.asarray(light.position, np.float64) - patches.position
        to_light = to_light / np.maximum(np.linalg.norm(to_light, axis=1, keepdims=True), 1e-30)
        lit = np.flatnonzero(np.asarray(incident).max(axis=1) > 0)
        cos = np.maximum(np.einsum("ij,ij->i", patches.normal[lit], to_light[lit]), MIN_COS)
        I = np.asarray(incident, np.float64)[lit, None]
        sums.add_sh(lit, np.pi * I / cos[:, None, None], to_light[lit, None])
        sums.add_dominant(lit, I, to_light[lit, None])


def add_emitters(sums: DirectionalSums, emitters, patches: Patches, tri_uv1: np.ndarray, points: TexelPoints,
                 side: int, lift: np.ndarray, tracer, seed: int) -> None:
    """Add the emitters' direct light from the directions it arrives along: the direct stage's
    next-event samples (from a side x side grid of `points` over each texel), each at
    full weight (no MIS share: the gather's rays then count no emission, `gather_directions`
    with B - E)."""
    normal = np.asarray(patches.normal, np.float64)
    rows = np.arange(len(patches), dtype=np.int64)
    k = side * side
    for start in range(0, len(rows), EMITTER_CHUNK):
        part = rows[start:start + EMITTER_CHUNK]
        ray, origins, live_dirs, tmax, live_value = next_event_rays(emitters, patches, tri_uv1, points, side, lift, part,
                                                                    0.0, seed)
        live_value[tracer.occluded(origins, live_dirs, tmax)] = 0.0
        dirs = np.zeros((len(part) * k, 3))
        value = np.zeros((len(part) * k, 3))
        dirs[ray], value[ray] = live_dirs, live_value
        dirs, value = dirs.reshape(len(part), k, 3), value.reshape(len(part), k, 3)
        cos = np.maximum(np.einsum("rka,ra->rk", dirs, normal[part]), MIN_COS)
        sums.add_sh(part, np.pi * value / cos[..., None], dirs)
        sums.add_dominant(part, value, dirs)


def split_maps(mode: str, images: np.ndarray) -> DirectionalLightmap:
    """(H, W, C) images of `lightmap_values` -> the DirectionalLightmap."""
    h, w = images.shape[:2]
    maps = images.reshape(h, w, -1, 3).transpose(2, 0, 1, 3) if mode == "sh" else images[None]
    return DirectionalLightmap(mode, np.ascontiguousarray(maps))
