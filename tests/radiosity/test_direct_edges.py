"""Direct light as the mean over each texel's area: a hard shadow edge gives each texel it
crosses its lit fraction."""
import numpy as np
import pytest

from patchlight.bake import bake
from patchlight.config import BakeSettings
from patchlight.scene import Light, SceneBuilder

RES = 64
FLOOR_UV = (0.02, 0.6)  # floor uv1 = offset + scale x (x, z)


def _roof_over_floor(angle_deg: float):
    """A unit floor under a roof 0.5 m up whose edge crosses the floor's centre at angle_deg
    to the x axis, lit by a hard sun straight down: the edge's shadow is the edge itself."""
    b = SceneBuilder()
    floor, roof = b.material("floor", (0.5, 0.5, 0.5)), b.material("roof", (0.0, 0.0, 0.0))
    b.quad([[0, 0, 0], [0, 0, 1], [1, 0, 1], [1, 0, 0]], floor, (0, 1, 0))
    a = np.radians(angle_deg)
    along, across = np.array([np.cos(a), 0, np.sin(a)]), np.array([-np.sin(a), 0, np.cos(a)])
    c = np.array([0.5, 0.5, 0.5])
    b.quad([c - 2 * along, c + 2 * along, c + 2 * along + 2 * across, c - 2 * along + 2 * across], roof, (0, -1, 0))
    sun = Light("directional", np.ones(3, np.float32), np.pi, direction=np.array([0, -1, 0], np.float32))
    scene = b.scene("roof", lights=[sun])
    corners = scene.positions.reshape(-1, 3, 3)
    on_floor = np.abs(corners[:, :, 1]).max(axis=1) < 1e-6
    roof_xz = corners[~on_floor][:, :, [0, 2]]
    lo, span = roof_xz.reshape(-1, 2).min(axis=0), np.ptp(roof_xz.reshape(-1, 2), axis=0).max()
    uv = np.where(on_floor[:, None, None], FLOOR_UV[0] + FLOOR_UV[1] * corners[:, :, [0, 2]],
                  0.65 + 0.33 * (corners[:, :, [0, 2]] - lo) / span)
    scene.uv1 = uv.reshape(-1, 2).astype(np.float32)
    return scene, c, across


def _lit_fraction(ty, tx, centre, across, n=256):
    """Exact (to 1/n^2) share of texel (ty, tx)'s floor footprint outside the roof's shadow."""
    g = (np.arange(n) + 0.5) / n
    u, v = (tx + g[None, :]) / RES, (ty + g[:, None]) / RES
    x, z = (u - FLOOR_UV[0]) / FLOOR_UV[1], (v - FLOOR_UV[0]) / FLOOR_UV[1]
    return float(np.mean((x - centre[0]) * across[0] + (z - centre[2]) * across[2] < 0))


@pytest.mark.parametrize("angle", [30.0, 63.4])
def test_each_texel_on_a_hard_sun_edge_holds_its_lit_area_fraction(angle):
    scene, centre, across = _roof_over_floor(angle)
    result = bake(scene, BakeSettings(resolution=RES, passes=1))
    p = result.patches
    lo, hi = FLOOR_UV[0] * RES, (FLOOR_UV[0] + FLOOR_UV[1]) * RES
    whole = (p.texel_x >= np.ceil(lo)) & (p.texel_x + 1 <= np.floor(hi)) & (p.texel_y >= np.ceil(lo)) & (p.texel_y + 1 <= np.floor(hi))
    whole &= np.abs(p.position[:, 1]) < 1e-6
    lit = result.solution.incident[:, 0] / 1.0  # a sun of irradiance pi straight down gives I = 1
    fractions = np.array([_lit_fraction(y, x, centre, across) for y, x in zip(p.texel_y[whole], p.texel_x[whole])])
    edge = (fractions > 0) & (fractions < 1)
    assert edge.sum() > 20
    error = np.abs(lit[whole][edge] - fractions[edge])
    assert error.max() < 0.02, f"worst edge texel off by {error.max():.3f}"
    np.testing.assert_allclose(lit[whole][~edge], np.round(fractions[~edge]), atol=1e-6)
