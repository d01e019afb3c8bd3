"""Gathering directions: the hemicube with its multiplier map, and stratified cosine rays.

Both return directions in the patch's local frame (z = the normal) and one weight per
direction; the weights sum to 1, so the weighted sum of the radiance seen is the incident
light I of docs/architecture.md (a uniform environment of radiance L gives I = L).

Hemicube of size N: the front face is N x N pixels over [-1, 1]^2 at z = 1; each of the four
side faces is N x N/2 pixels over [-1, 1] x [0, 1] (the half above the patch's plane).
"""
from __future__ import annotations

import numpy as np


def _face_pixels(n: int, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel-centre coordinates (a, b) of an n-wide face, `rows` rows from b = 0 (or -1) up."""
    step = 2.0 / n
    a = -1.0 + step * (np.arange(n) + 0.5)
    b = a if rows == n else step * (np.arange(rows) + 0.5)
    bb, aa = np.meshgrid(b, a, indexing="ij")
    return aa.ravel(), bb.ravel()


def hemicube_directions(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Unnormalised pixel-centre vectors (P, 3) of a size-n hemicube and each pixel's face
    axis (P, 3): the direction its virtual camera looks along. P = 3 n^2."""
    if n < 2 or n % 2:
        raise ValueError("hemicube size must be an even number >= 2")
    a, b = _face_pixels(n, n)
    vecs = [np.stack([a, b, np.ones_like(a)], 1)]
    axes = [np.tile([0.0, 0.0, 1.0], (len(a), 1))]
    a, up = _face_pixels(n, n // 2)
    one = np.ones_like(a)
    for axis in ([1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]):
        if axis[0]:
            v = np.stack([axis[0] * one, a, up], 1)
        else:
            v = np.stack([a, axis[1] * one, up], 1)
        vecs.append(v)
        axes.append(np.tile(np.asarray(axis, float), (len(a), 1)))
    return np.concatenate(vecs), np.concatenate(axes)


def perspective_compensation(vecs: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """(P,) cos^3 of the angle between each pixel's ray and its face's camera axis: the
    solid angle a pixel subtends, relative to the face centre's (corners see less)."""
    r = np.linalg.norm(vecs, axis=1)
    return (np.einsum("ij,ij->i", vecs, axes) / r) ** 3


def lambert(vecs: np.ndarray) -> np.ndarray:
    """(P,) cosine between each pixel's ray and the patch normal (+z): Lambert's law."""
    return vecs[:, 2] / np.linalg.norm(vecs, axis=1)


def multiplier_map(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Directions (P, 3) unit, local frame, and the article's multiplier map (P,):
    perspective compensation x Lambert's cosine, normalised to sum to 1."""
    vecs, axes = hemicube_directions(n)
    weights = perspective_compensation(vecs, axes) * lambert(vecs)
    dirs = vecs / np.linalg.norm(vecs, axis=1, keepdims=True)
    return dirs.astype(np.float32), (weights / weights.sum()).astype(np.float32)


def delta_form_factors(n: int) -> np.ndarray:
    """(P,) analytic delta form factors of the hemicube pixels (Cohen & Greenberg):
    front dA / (pi (x^2 + y^2 + 1)^2), side z dA / (pi (y^2 + z^2 + 1)^2), dA = (2/n)^2."""
    vecs, axes = hemicube_directions(n)
    r2 = np.einsum("ij,ij->i", vecs, vecs)
    cos_axis_times_z = np.where(axes[:, 2] == 1, 1.0, vecs[:, 2])
    return cos_axis_times_z * (2.0 / n) ** 2 / (np.pi * r2 ** 2)


def stratified_directions(rays: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """About `rays` cosine-weighted directions (local frame), one per cell of a jittered
    a x b grid on the unit square (a = floor(sqrt(rays)), b = rays // a) mapped through the
    concentric disk, with equal weights 1 / (a b)."""
    a = max(1, int(np.sqrt(rays)))
    b = max(1, rays // a)
    i, j = np.meshgrid(np.arange(a), np.arange(b), indexing="ij")
    u = (i.ravel() + rng.random(a * b)) / a
    v = (j.ravel() + rng.random(a * b)) / b
    x, y = concentric_disk(u, v)
    z = np.sqrt(np.maximum(0.0, 1.0 - x * x - y * y))
    dirs = np.stack([x, y, z], 1).astype(np.float32)
    return dirs, np.full(a * b, 1.0 / (a * b), np.float32)


def concentric_disk(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shirley-Chiu concentric map of the unit square onto the unit disk (area preserving)."""
    a, b = 2 * u - 1, 2 * v - 1
    first = np.abs(a) > np.abs(b)
    safe_a = np.where(a == 0, 1, a)
    safe_b = np.where(b == 0, 1, b)
    r = np.where(first, a, b)
    phi = np.where(first, (np.pi / 4) * (b / safe_a), np.pi / 2 - (np.pi / 4) * (a / safe_b))
    r = np.where((a == 0) & (b == 0), 0, r)
    return r * np.cos(phi), r * np.sin(phi)
