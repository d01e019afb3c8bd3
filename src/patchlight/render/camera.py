"""The pinhole camera shared by the CPU renderer and the viewer.

Eye and target in world metres, vertical field of view in degrees, +Y up; one ray through
the centre of each pixel, row 0 at the top of the image. This is three.js's
PerspectiveCamera looking at the target with up (0, 1, 0), so both render the same view.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import setting, validate_fields
from ..errors import SettingError

DEFAULT_FOV = 45.0  # degrees
_VIEW_DIRECTION = np.array([0.45, 0.35, 0.82])  # default eye offset from the target, before scaling
INTERIOR_EYE = 0.8  # an interior view's eye sits this fraction of the way from the centre to a wall
INTERIOR_FOV = 60.0  # degrees


@dataclass
class Camera:
    """A pinhole camera (table: docs/settings.md)."""

    eye: np.ndarray = setting(unit="m", meaning="where the camera is", length=3)
    target: np.ndarray = setting(unit="m", meaning="the point it looks at; +Y is up", length=3)
    fov: float = setting(DEFAULT_FOV, "degrees", "vertical field of view", lo=0, hi=180, lo_open=True, hi_open=True,
                         typical="45-60")

    def validate(self) -> None:
        """SettingError for a camera that cannot see."""
        self.basis()

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, up, forward) unit vectors, float64; SettingError for a camera that cannot see."""
        validate_fields(self)
        forward = np.asarray(self.target, np.float64) - np.asarray(self.eye, np.float64)
        length = np.linalg.norm(forward)
        if length == 0:
            raise SettingError("eye", [float(v) for v in self.eye], "is the target's point: eye and target must differ")
        forward /= length
        right = np.cross(forward, [0.0, 1.0, 0.0])
        if np.linalg.norm(right) < 1e-9:
            raise SettingError("eye", [float(v) for v in self.eye], "looks straight up or down at the target; +Y is "
                               "up, so tilt the view a little")
        right /= np.linalg.norm(right)
        return right, np.cross(right, forward), forward

    def rays(self, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """Origins and unit directions (height * width, 3) float32, row-major from the top row."""
        right, up, forward = self.basis()
        half_h = math.tan(math.radians(self.fov) / 2)
        half_w = half_h * width / height
        x = ((np.arange(width) + 0.5) / width * 2 - 1) * half_w
        y = (1 - (np.arange(height) + 0.5) / height * 2) * half_h
        d = forward + x[None, :, None] * right + y[:, None, None] * up
        d = (d / np.linalg.norm(d, axis=-1, keepdims=True)).reshape(-1, 3).astype(np.float32)
        return np.broadcast_to(np.asarray(self.eye, np.float32), d.shape), d

    def to_json(self) -> dict:
        return {"eye": [float(v) for v in self.eye], "target": [float(v) for v in self.target], "fov": float(self.fov)}


def scene_camera(scene) -> Camera | None:
    """The camera the scene names in extras["camera"] = {eye, target, fov}, or None."""
    given = scene.extras.get("camera") if isinstance(scene.extras, dict) else None
    if not given:
        return None
    return Camera(np.asarray(given["eye"], np.float64), np.asarray(given["target"], np.float64),
                  float(given.get("fov", DEFAULT_FOV)))


def overview_camera(lo: np.ndarray, hi: np.ndarray) -> Camera:
    """A three-quarter view from outside the bounds (lo, hi) that fits their sphere in the frame."""
    center = (np.asarray(lo, np.float64) + hi) / 2
    radius = max(float(np.linalg.norm(np.asarray(hi, np.float64) - lo)) / 2, 1e-3)
    distance = radius / math.sin(math.radians(DEFAULT_FOV) / 2) * 1.05
    offset = _VIEW_DIRECTION / np.linalg.norm(_VIEW_DIRECTION) * distance
    return Camera(center + offset, center, DEFAULT_FOV)


def interior_cameras(lo: np.ndarray, hi: np.ndarray) -> list[Camera]:
    """Views of an enclosed space from near each of its four walls towards its centre."""
    center = (np.asarray(lo, np.float64) + hi) / 2
    half = (np.asarray(hi, np.float64) - lo) / 2
    cameras = []
    for axis, sign in ((2, -1), (2, 1), (0, -1), (0, 1)):
        eye = center.copy()
        eye[axis] += sign * INTERIOR_EYE * half[axis]
        cameras.append(Camera(eye, center, INTERIOR_FOV))
    return cameras
