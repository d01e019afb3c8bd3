"""The level as the ground map's camera sees it: polygons too high above the ground are left out, and vertical ones are
turned to face up so that, say, the sides of fences colour the map.

- The ground beneath a point is the lowest upward-facing surface on the vertical line
  through it (a ray cast up from below the level against upward-facing triangles only).
- A triangle is left out when any corner lies more than `max_height` above the ground
  beneath that corner: a tall pole, a tree canopy, a grandstand. A corner with no ground
  beneath counts as on the ground.
- A kept triangle is vertical when |n.y| < VERTICAL_NY. It is turned up by a rotation of
  90 degrees about the line where its plane meets the ground (height h, the lowest ground
  beneath its corners): corner p goes to (p.xz - (p.y - h) n_h, h), n_h its horizontal
  normal. A proper rotation, so the face that looked sideways now looks up (it falls
  backwards, behind its foot): an object beside a fence whose sample point is offset towards
  the fence crosses the fence line and reads the colour of the side facing it. Barycentric
  coordinates are unchanged, so a hit on the turned triangle reads the original's light.
- Turned triangles lie over everything else in the map (`fallen` below): under a roof they
  would otherwise be hidden. Downward-facing triangles show their backs to the camera and
  are dropped.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..rays.tracer import Tracer
from ..scene.model import Scene, face_normals

VERTICAL_NY = 0.2   # |n.y| below this: a wall, fence or pole side (within ~11.5 degrees of vertical)
CORNER_INSET = 1e-3  # ground rays start this fraction of the way from a corner to the centroid,
                     # so they never pass exactly through a shared vertex


@dataclass
class MapGeometry:
    """Triangles for the top-down camera, in two layers.

    flat_positions (F*3, 3) / flat_source (F,): kept upward-facing triangles as they are;
    fallen_positions (R*3, 3) / fallen_source (R,): kept vertical triangles turned face up.
    *_source index the scene's triangles (same barycentrics). Counts for the stats."""

    flat_positions: np.ndarray
    flat_source: np.ndarray
    fallen_positions: np.ndarray
    fallen_source: np.ndarray
    left_out: int
    dropped_downward: int

    @staticmethod
    def tracer(positions: np.ndarray) -> Tracer | None:
        """A tracer over one layer (None when it is empty)."""
        if len(positions) == 0:
            return None
        return Tracer(positions, np.arange(len(positions), dtype=np.int32).reshape(-1, 3))


def ground_below(up_tracer: Tracer | None, points: np.ndarray, floor_y: float) -> np.ndarray:
    """(N,) float64 height of the lowest upward-facing surface on the vertical through each
    point (N, 3), NaN where there is none. `up_tracer` holds upward-facing triangles only;
    rays start at floor_y, below everything."""
    heights = np.full(len(points), np.nan)
    if up_tracer is None or len(points) == 0:
        return heights
    origins = np.array(points, np.float64)
    origins[:, 1] = floor_y
    up = np.broadcast_to(np.array([0.0, 1.0, 0.0], np.float32), origins.shape)
    hits = up_tracer.intersect(origins.astype(np.float32), up)
    hit = hits.tri >= 0
    heights[hit] = floor_y + hits.t[hit].astype(np.float64)
    return heights


def turn_face_up(corners: np.ndarray, normals: np.ndarray, pivot_y: np.ndarray) -> np.ndarray:
    """(R, 3, 3) corners of vertical triangles (R, 3, 3) with unit normals (R, 3) rotated 90
    degrees about their line at height pivot_y (R,) so that they face +Y."""
    n_h = normals * np.array([1.0, 0.0, 1.0])
    n_h /= np.linalg.norm(n_h, axis=1, keepdims=True)
    rise = corners[..., 1] - pivot_y[:, None]                          # (R, 3)
    turned = corners - rise[..., None] * n_h[:, None, :]
    turned[..., 1] = pivot_y[:, None]
    return turned


def prepare_map_geometry(scene: Scene, max_height: float) -> MapGeometry:
    """Split the scene's triangles into the map's two layers (module docstring)."""
    tris = scene.triangle_vertices().astype(np.float64)                # (T, 3, 3)
    normal, area = face_normals(scene.positions, scene.indices)
    normal = normal.astype(np.float64)
    valid = area > 0
    upward = valid & (normal[:, 1] >= VERTICAL_NY)
    vertical = valid & (np.abs(normal[:, 1]) < VERTICAL_NY)
    lo, _ = scene.bounds()
    floor_y = float(lo[1]) - 1.0

    up_tracer = MapGeometry.tracer(tris[upward].reshape(-1, 3))
    candidates = np.flatnonzero(upward | vertical)
    corners = tris[candidates]
    centroid = corners.mean(axis=1, keepdims=True)
    probes = (corners + CORNER_INSET * (centroid - corners)).reshape(-1, 3)
    ground = ground_below(up_tracer, probes, floor_y).reshape(-1, 3)
    height = np.where(np.isnan(ground), 0.0, corners[..., 1] - ground)
    keep = candidates[height.max(axis=1) <= max_height]

    kept_vertical = keep[vertical[keep]]
    kept_flat = keep[upward[keep]]
    rows = np.searchsorted(candidates, kept_vertical)
    pivot = np.nanmin(np.where(np.isnan(ground[rows]), tris[kept_vertical][..., 1], ground[rows]), axis=1)
    fallen = turn_face_up(tris[kept_vertical], normal[kept_vertical], pivot)
    return MapGeometry(flat_positions=tris[kept_flat].reshape(-1, 3).astype(np.float32),
                       flat_source=kept_flat.astype(np.int32),
                       fallen_positions=fallen.reshape(-1, 3).astype(np.float32),
                       fallen_source=kept_vertical.astype(np.int32),
                       left_out=int(len(candidates) - len(keep)),
                       dropped_downward=int(np.count_nonzero(valid & (normal[:, 1] <= -VERTICAL_NY))))
