"""The sky outside the scene: radiance by direction, for rays that escape.

Three models, all in radiance units (W/(m^2 sr)), linear RGB, +Y up:
- uniform:  L(w) = c
- gradient: above the horizon L = horizon + (zenith - horizon) * w.y; below it L = ground.
  An up-facing unoccluded patch then receives I = horizon + 2/3 (zenith - horizon).
- image:    an equirectangular map, u = 0.5 + atan2(w.x, -w.z) / 2pi, v = acos(w.y) / pi
            (v = 0 the zenith row at the top; -Z, glTF's forward, at the centre column).
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numba as nb
import numpy as np

from .model import check_light_values


def _rgb(value) -> np.ndarray:
    arr = np.asarray(value, np.float32).reshape(3)
    return arr


def _shortest(rgb) -> list[float]:
    """float32 values as the shortest decimals that read back to them (0.4, not 0.4000000059604645)."""
    return [float(str(np.float32(v))) for v in rgb]


@nb.njit(cache=True, nogil=True)
def _colour_radiance(gradient, colors, d):
    """Sky.radiance of a uniform sky (colors[0]) or, when `gradient`, of the gradient of the
    colors (3, 3) zenith, horizon, ground, in float32 along d (N, 3) f32."""
    out = np.empty((d.shape[0], 3), np.float32)
    zero, one = np.float32(0.0), np.float32(1.0)
    for i in range(d.shape[0]):
        y = d[i, 1]
        for c in range(3):
            if not gradient:
                out[i, c] = colors[0, c]
            elif y >= zero:
                out[i, c] = colors[1, c] + (colors[0, c] - colors[1, c]) * min(max(y, zero), one)
            else:
                out[i, c] = colors[2, c]
    return out


@dataclass
class Sky:
    """kind: "uniform" | "gradient" | "image". colors: (3, 3) zenith, horizon, ground rows
    (uniform uses row 0). image: (H, W, 3) float32 linear radiance or None. source: the file an
    image sky was read from, when known (what `to_extras` records)."""

    kind: str
    colors: np.ndarray
    image: np.ndarray | None = None
    source: str | None = None

    @classmethod
    def uniform(cls, rgb) -> "Sky":
        c = _rgb(rgb)
        return cls("uniform", np.stack([c, c, c]))

    @classmethod
    def gradient(cls, zenith, horizon, ground) -> "Sky":
        return cls("gradient", np.stack([_rgb(zenith), _rgb(horizon), _rgb(ground)]))

    @classmethod
    def from_image(cls, image: np.ndarray, source=None) -> "Sky":
        return cls("image", np.zeros((3, 3), np.float32), np.ascontiguousarray(image[..., :3], np.float32),
                   None if source is None else str(source))

    def validate(self, where: str) -> None:
        """One line when a radiance is not finite or out of range (`check_light_values`)."""
        check_light_values(self.image if self.kind == "image" else self.colors, f"{where}: sky radiance")

    def is_black(self) -> bool:
        if self.kind == "image":
            return not np.any(self.image > 0)
        return not np.any(self.colors > 0)

    def radiance(self, directions: np.ndarray) -> np.ndarray:
        """(N, 3) f32 radiance seen along unit directions (N, 3)."""
        d = np.ascontiguousarray(directions, np.float32).reshape(-1, 3)
        if self.kind != "image":  # a nogil kernel: the gather's threads call it side by side
            return _colour_radiance(self.kind == "gradient", np.ascontiguousarray(self.colors, np.float32), d)
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

    def to_extras(self, folder=None) -> dict | None:
        """The sky as glTF `extras.patchlight.sky`, the form `patchlight.scene.gltf` reads back
        to an equal Sky: {"uniform": rgb}, {"gradient": {zenith, horizon, ground}} or
        {"image": path} (relative to `folder`, the glTF file's directory, when it has one; else
        absolute).  None for an image sky whose file is unknown."""
        if self.kind == "uniform":
            return {"uniform": _shortest(self.colors[0])}
        if self.kind == "gradient":
            return {"gradient": {name: _shortest(row) for name, row in zip(("zenith", "horizon", "ground"), self.colors)}}
        if self.source is None:
            return None
        source = Path(self.source).absolute()
        if folder is not None:
            try:
                return {"image": Path(os.path.relpath(source, Path(folder).absolute())).as_posix()}
            except ValueError:  # another drive
                pass
        return {"image": source.as_posix()}
