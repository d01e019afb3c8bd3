"""Small scenes for the light-volume tests, solved without a bake where the lightmap's value
is the known answer (a constant), or baked at a low resolution where the radiosity matters."""
from __future__ import annotations

import numpy as np

from patchlight.scene import Light, SceneBuilder, Sky
from patchlight.solved import SolvedScene


def constant_solved(scene, incident) -> SolvedScene:
    """`scene` with a lightmap of constant incident light (3,) everywhere."""
    scene.uv1 = np.full((len(scene.positions), 2), 0.5, np.float32)
    return SolvedScene(scene, np.broadcast_to(np.asarray(incident, np.float32), (2, 2, 3)).copy(), scene.name)


def speck_under_sky(radiance) -> SolvedScene:
    """Nothing but a tiny far-away quad (the tracer needs a triangle) under a uniform sky."""
    b = SceneBuilder()
    m = b.material("speck", (0.5, 0.5, 0.5))
    b.quad([[100, 0, 100], [100.01, 0, 100], [100.01, 0, 100.01], [100, 0, 100.01]], m, (0, 1, 0))
    return constant_solved(b.scene("speck", sky=Sky.uniform(radiance)), (0, 0, 0))


def floor(half: float, rgb=(0.5, 0.5, 0.5), lights=(), sky=None):
    """A square floor of side 2 half at y = 0, facing up."""
    b = SceneBuilder()
    m = b.material("floor", rgb)
    b.quad([[-half, 0, -half], [half, 0, -half], [half, 0, half], [-half, 0, half]], m, (0, 1, 0))
    return b.scene("floor", lights=list(lights), sky=sky)


def sun(direction_to_sun, irradiance: float) -> Light:
    d = -np.asarray(direction_to_sun, np.float32)
    return Light("directional", np.ones(3, np.float32), irradiance, direction=d / np.linalg.norm(d), name="sun")
