"""Inside geometry: the one decision every part makes about a patch, a probe or a point.

A place lies inside geometry when more than a threshold share of the rays it casts first meet
a back face (the back of a wall it sits in, the underside of an object resting on the floor
over it): what it would gather there is darkness no visible surface shows. A back face is the
back of a single-sided triangle (`is_back_face`; a doubleSided material's back is an ordinary
surface). Each caller casts its rays (rays.hemisphere for patches and probes, the whole
sphere for the renderer's points), marks them (`back_faces`, or `is_back_face` inside a
kernel), measures `back_share` and decides with `is_inside` against the one table below.
"""
from __future__ import annotations

import numba as nb
import numpy as np

# More than this share of a place's rays on back faces: it is inside geometry.
INSIDE_SHARE = {
    "patch": 0.5,         # a lightmap patch, by its gather rays
    "patch probe": 0.7,   # a lightmap patch, by a few probe rays before it pays for its gather
                          # (12 or more of 16; its gather decides the borderline rest)
    "probe": 0.5,         # a light-volume probe, by the rays of all six axes
    "probe axis": 0.25,   # one axis of a probe: it looks into geometry (its value is filled in)
    "point": 0.5,         # a renderer's point (camera eye, environment centre), by rays over the
                          # whole sphere: inside a closed object all of them meet back faces,
                          # behind one wall of a box only the small solid angle the box covers
}


def two_sided_triangles(scene) -> np.ndarray:
    """(T,) bool: triangles of `scene` whose material is doubleSided (their back is an ordinary surface)."""
    flags = np.array([m.double_sided for m in scene.materials] or [False], bool)
    return flags[scene.material_ids] if scene.n_triangles else np.zeros(0, bool)


@nb.njit(cache=True, inline="always")
def is_back_face(tri, front, two_sided):
    """A ray's first hit, on triangle `tri` (-1: none) from the front or not, is the back of a
    single-sided triangle (two_sided (T,) bool)."""
    return tri >= 0 and not front and not two_sided[tri]


@nb.njit(cache=True, nogil=True)
def back_faces(tri, front, two_sided):
    """(N,) bool `is_back_face` of N rays' hits: tri (N,) i32, front (N,) bool."""
    out = np.empty(tri.shape[0], np.bool_)
    for i in range(tri.shape[0]):
        out[i] = is_back_face(tri[i], front[i], two_sided)
    return out


def back_share(back: np.ndarray) -> np.ndarray:
    """The share of rays on back faces: back (..., D) bool, D rays per place -> (...,) float."""
    return np.mean(back, axis=-1)


def is_inside(share, kind: str):
    """share (a number or array) of a place's rays on back faces -> inside geometry, for a
    place of `kind` (a key of INSIDE_SHARE)."""
    return share > INSIDE_SHARE[kind]
