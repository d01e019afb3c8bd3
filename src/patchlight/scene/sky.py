"""The sky outside the scene: radiance by direction, for rays that escape.

Three models, all in radiance units (W/(m^2 sr)), linear RGB, +Y up:
- uniform:  L(w) = c
- gradient: above the horizon L = horizon + (zenith - horizon) * w.y; below it L = ground.
  An up-facing unoccluded patch then receives I = horizon + 2/3 (zenith - horizon).
- image:    an equirectangular map, u = 0.5 + atan2(w.x, -w.z) / 2pi, v = acos(w.y) / pi
            (v = 0 the zenith row at the top; -Z, glTF's forward, at the centre column).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _rgb(value) -> np.ndarray:
    arr = np.asarray(value, np.float32).reshape(3)
    return arr


@dataclass
class Sky:
    """kind: "uniform" | "gradient" | "image". colors: (3, 3) zenith, horizon, ground rows
    (uniform uses row 0). image: (H, W, 3) float32 linear radiance or None."""

    kind: str
    colors: np.ndarray
    image: np.ndarray | None = None

    @classmethod
    def uniform(cls, rgb) -> "Sky":
        c = _rgb(rgb)
        return cls("uniform", np.stack([c, c, c]))

    @classmethod
    def gradient(cls, zenith, horizon, ground) -> "Sky":
        return cls("gradient", np.stack([_rgb(zenith), _rgb(horizon), _rgb(ground)]))

    @classmethod
    def from_image(cls, image: np.ndarray) -> "Sky":
        return cls("image", np.zeros((3, 3), np.float32), np.ascontiguousarray(image[..., :3], np.float32))

    def is_black(self) -> bool:
        if self.kind == "image":
            return not np.any(self.image > 0)
        return not np.any(self.colors > 0)

    def radiance(self, directions: np.ndarray) -> np.ndarray:
        """(N, 3) radiance seen along unit directions (N, 3)."""
        d = np.asarray(directions, np.float32)
        if self.kind == "uniform":
            return np.broadcast_to(self.colors[0], (len(d), 3)).copy()
        if self.kind == "gradient":
            y = d[:, 1:2]
            zenith, horizon, ground = self.colors
            above = horizon + (zenith - horizon) * np.clip(y, 0, 1)
            return np.where(y >= 0, above, ground).astype(np.float32)
        h, w, _ = self.image.shape
        u = 0.5 + np.arctan2(d[:, 0], -d[:, 2]) / (2 * np.pi)
        v = np.arccos(np.clip(d[:, 1], -1, 1)) / np.pi
        x = np.clip((u * w).astype(np.int64), 0, w - 1)
        y = np.clip((v * h).astype(np.int64), 0, h - 1)
        return self.image[y, x]

    def to_json(self) -> dict:
        if self.kind == "image":
            return {"kind": "image", "size": list(self.image.shape[:2])}
        return {"kind": self.kind, "zenith": self.colors[0].tolist(),
                "horizon": self.colors[1].tolist(), "ground": self.colors[2].tolist()}
