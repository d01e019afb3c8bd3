"""Exact form factors for the radiosity tests."""
import numpy as np


def point_form_factor(p, normal, polygon):
    """Exact form factor from a differential area at p (unit normal) to a polygon (K, 3):
    Lambert's contour integral, (1 / 2 pi) sum over edges of angle x n . (unit edge normal)."""
    r = polygon - p
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    total = 0.0
    for a, b in zip(r, np.roll(r, -1, axis=0)):
        c = np.cross(a, b)
        total += np.arccos(np.clip(a @ b, -1, 1)) * (normal @ c) / np.linalg.norm(c)
    return abs(total) / (2 * np.pi)
