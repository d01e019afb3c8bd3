"""Five pinhole cameras at a patch, unfolded as the radiosity article draws a hemicube: the
independent geometry the view from a patch is checked against (tests/radiosity, tests/viewer)."""
from __future__ import annotations

import numpy as np


def frame_of(view) -> np.ndarray:
    """(3, 3) the patch's turned frame (rows: tangent, bitangent, normal) that maps a
    PatchView's local pattern onto its world directions (least squares)."""
    frame, *_ = np.linalg.lstsq(view.local.astype(np.float64), view.directions.astype(np.float64), rcond=None)
    return frame


def pinhole_cross(n: int, frame: np.ndarray) -> np.ndarray:
    """(2n, 2n, 3) world directions through the pixel centres of five pinhole cameras at a
    patch (frame rows: tangent, bitangent, normal), unfolded into the article's cross: the
    front camera in the middle, each side camera's half above the surface folded out about
    its edge with the front one; zeros in the corners."""
    h = n // 2
    centre = -1 + (np.arange(n) + 0.5) * 2 / n      # front face: x right, y up (top row +y)
    out_of_plane = 1 - (np.arange(h) + 0.5) * 2 / n  # side faces: z falls from 1 to 0 outwards
    d = np.zeros((2 * n, 2 * n, 3))
    d[h:h + n, h:h + n] = np.stack(np.broadcast_arrays(centre[None, :], centre[::-1, None], 1.0), -1)
    d[h:h + n, h + n:] = np.stack(np.broadcast_arrays(1.0, centre[::-1, None], out_of_plane[None, :]), -1)
    d[h:h + n, :h] = np.stack(np.broadcast_arrays(-1.0, centre[::-1, None], out_of_plane[None, ::-1]), -1)
    d[:h, h:h + n] = np.stack(np.broadcast_arrays(centre[None, :], 1.0, out_of_plane[::-1, None]), -1)
    d[h + n:, h:h + n] = np.stack(np.broadcast_arrays(centre[None, :], -1.0, out_of_plane[:, None]), -1)
    return d @ frame


def cpu_hemicube(renderer, settings, view) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(radiance (2N, 2N, 3), covered (2N, 2N), cross (2N, 2N)) of the CPU renderer along the
    pinhole cameras' rays from the view's origin; zeros outside the cross."""
    dirs = pinhole_cross(view.size, frame_of(view))
    cross = np.linalg.norm(dirs, axis=-1) > 0
    unit = (dirs[cross] / np.linalg.norm(dirs[cross], axis=-1, keepdims=True)).astype(np.float32)
    radiance, covered = renderer.shade_rays(settings, np.broadcast_to(view.origin.astype(np.float32), unit.shape), unit)
    out = np.zeros(cross.shape + (3,), np.float32)
    hit = np.zeros(cross.shape, bool)
    out[cross], hit[cross] = radiance, covered
    return out, hit, cross
