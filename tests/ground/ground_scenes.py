"""Small scenes with known light for the ground map tests.

`solved(builder)` lights every surface with the same incident light I0 (a one-texel lightmap
that every lightmap UV reads), so the map's texels have known values: B = rho I0.
"""
from __future__ import annotations

import numpy as np

from patchlight.scene.builtin import SceneBuilder
from patchlight.scene.model import Light
from patchlight.scene.sky import Sky
from patchlight.solved import SolvedScene

I0 = 1.0            # incident light on every surface
GREY = (0.5, 0.5, 0.5)
SUN_ES = 10.0 * np.pi  # sun irradiance: I_sun = 10 cos on a horizontal patch
SKY = (0.2, 0.3, 0.6)


def sun(direction=(1.0, -1.0, 0.0)) -> Light:
    d = np.asarray(direction, np.float32)
    return Light("directional", np.ones(3, np.float32), SUN_ES, direction=d / np.linalg.norm(d), name="sun")


def ground(b: SceneBuilder, half: float = 10.0, rgb=GREY) -> None:
    """A horizontal ground quad over [-half, half]^2 at y = 0."""
    m = b.material("ground", rgb)
    b.quad([(-half, 0, -half), (half, 0, -half), (half, 0, half), (-half, 0, half)], m, (0, 1, 0))


def pole(b: SceneBuilder, x=0.0, z=0.0, height=10.0, rgb=(0.8, 0.0, 0.0)) -> None:
    m = b.material("pole", rgb)
    b.box((x - 0.2, 0.0, z - 0.2), (x + 0.2, height, z + 0.2), m)


def fence(b: SceneBuilder, x0=2.0, x1=6.0, z=5.0, height=1.0, rgb=(0.0, 0.0, 0.8)) -> None:
    """One single-sided vertical quad along x at `z`, facing +z."""
    m = b.material("fence", rgb)
    b.quad([(x0, 0, z), (x1, 0, z), (x1, height, z), (x0, height, z)], m, (0, 0, 1))


def patches(b: SceneBuilder, colours, y=0.01, size=4.0) -> None:
    """Coloured squares on the ground along x, centred on z = 0, `size` metres each."""
    start = -size * len(colours) / 2
    for k, rgb in enumerate(colours):
        m = b.material(f"patch {k}", rgb)
        x0 = start + k * size
        b.quad([(x0, y, -size / 2), (x0 + size, y, -size / 2), (x0 + size, y, size / 2), (x0, y, size / 2)], m, (0, 1, 0))


def solved(b: SceneBuilder, lights=(), sky=SKY, name="test") -> SolvedScene:
    scene = b.scene(name, lights=list(lights), sky=None if sky is None else Sky.uniform(sky))
    scene.uv1 = np.zeros((len(scene.positions), 2), np.float32)
    return SolvedScene(scene, np.full((1, 1, 3), I0, np.float32), name)
