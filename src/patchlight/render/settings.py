"""ShadingSettings for a target from its scene (lights, sky) and the user's overrides.

Lights come from the scene (KHR_lights_punctual) unless given. The ambient, sky and ground
colours come from the scene's sky (`patchlight.shading.environment.sky_incident`): sky and
ground are the incident light of an up- and a down-facing patch, ambient their mean. A scene
without a sky gets DEFAULT_AMBIENT for all three.
"""
from __future__ import annotations

import numpy as np

from ..shading.environment import sky_incident
from ..shading.lights import from_scene_light
from ..shading.models import DEFAULT_AMBIENT, ShadingSettings
from .target import Target


def target_settings(target: Target, model: str = "lambert", lights=None, falloff: str = "inverse-square",
                    ambient=None, sky=None, ground=None, **options) -> ShadingSettings:
    """Settings for `target`. lights: scene Lights (default: the scene's); falloff: for lights
    that name none; ambient, sky, ground: (3,) overrides; options: the other ShadingSettings fields."""
    scene = target.scene
    chosen = scene.lights if lights is None else lights
    punctual = [from_scene_light(light, falloff, f"light {light.name or i}") for i, light in enumerate(chosen)]
    if scene.sky is not None:
        sky_up, ground_down = sky_incident(scene.sky)
    else:
        base = np.full(3, DEFAULT_AMBIENT, np.float32) if ambient is None else np.asarray(ambient, np.float32)
        sky_up = ground_down = base
    sky_up = sky_up if sky is None else np.asarray(sky, np.float32)
    ground_down = ground_down if ground is None else np.asarray(ground, np.float32)
    mean = ((sky_up + ground_down) / 2).astype(np.float32)
    options.setdefault("directional", target.directional)
    settings = ShadingSettings(model=model, lights=punctual, sky=sky_up, ground=ground_down,
                               ambient=mean if ambient is None else np.asarray(ambient, np.float32), **options)
    settings.validate()
    return settings
