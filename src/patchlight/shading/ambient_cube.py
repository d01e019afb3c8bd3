"""The `ambient-cube` model's terms: one function per GLSL function of the same name in
`patchlight/shaders/ambient_cube.glsl`, where the formulas and their sources are documented.

`volume` is a `patchlight.volumes.LightVolume`: cube (6, NZ, NY, NX, 3) incident light in axis
order +X, +Y, +Z, -X, -Y, -Z on the grid (origin, spacing, dims). Points are (N, 3) world
metres, normals (N, 3) unit; results keep float32.
"""
from __future__ import annotations

import numpy as np

from .terms import saturate


def ambient_cube_weights(N: np.ndarray, naive: bool = False) -> np.ndarray:
    """ambient_cube.glsl: the signed weights w (N, 3) of the six axes: saturate(w) weights +X,
    +Y, +Z and saturate(-w) weights -X, -Y, -Z. Squared with the sign kept (N^2 sign(N)),
    or the naive N itself."""
    if naive:
        return N.copy()
    return N * N * np.sign(N)


def ambient_cube_cell(volume, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ambient_cube.glsl: the grid cell holding points P (N, 3), clamped to the grid: corner
    indices i0, i1 (N, 3) int (x, y, z) and the fractions f (N, 3) of the way from i0 to i1."""
    grid = volume.grid
    dims = np.asarray(grid.dims, np.int64)
    origin = np.asarray(grid.origin, np.float32)
    spacing = np.asarray(grid.spacing, np.float32)
    g = np.clip((P.astype(np.float32) - origin) / spacing, 0.0, (dims - 1).astype(np.float32))
    i0 = np.minimum(np.floor(g).astype(np.int64), np.maximum(dims - 2, 0))
    i1 = np.minimum(i0 + 1, dims - 1)
    return i0, i1, (g - i0).astype(np.float32)


def ambient_cube_probe(volume, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """ambient_cube.glsl: texel (x, y, z) (N,) each of the volume's 3D texture, NX x NY x 6 NZ:
    axis a's probes fill the slices z in [a NZ, (a + 1) NZ). (N, 3)."""
    _, nz, ny, nx, _ = volume.cube.shape
    return volume.cube.reshape(6 * nz, ny, nx, 3)[z, y, x]


def ambient_cube_axis(volume, axis: int, i0: np.ndarray, i1: np.ndarray, f: np.ndarray) -> np.ndarray:
    """ambient_cube.glsl: axis `axis`'s incident light (N, 3), trilinear between the cell's
    eight probes."""
    nz = volume.grid.dims[2]
    x0, y0, x1, y1 = i0[:, 0], i0[:, 1], i1[:, 0], i1[:, 1]
    z0, z1 = i0[:, 2] + axis * nz, i1[:, 2] + axis * nz
    fx, fy, fz = (f[:, k:k + 1] for k in range(3))

    def probe(x, y, z):
        return ambient_cube_probe(volume, x, y, z)

    near = _mix(_mix(probe(x0, y0, z0), probe(x1, y0, z0), fx), _mix(probe(x0, y1, z0), probe(x1, y1, z0), fx), fy)
    far = _mix(_mix(probe(x0, y0, z1), probe(x1, y0, z1), fx), _mix(probe(x0, y1, z1), probe(x1, y1, z1), fx), fy)
    return _mix(near, far, fz).astype(np.float32)


def _mix(a, b, t):
    """GLSL's mix: a (1 - t) + b t."""
    return a * (1 - t) + b * t


def ambient_cube_light(volume, P: np.ndarray, N: np.ndarray, naive: bool = False) -> np.ndarray:
    """ambient_cube.glsl: incident light (N, 3) at points P on surfaces of normal N: the six
    interpolated axis values weighted by ambient_cube_weights."""
    i0, i1, f = ambient_cube_cell(volume, P)
    w = ambient_cube_weights(N.astype(np.float32), naive)
    weights = np.concatenate([saturate(w), saturate(-w)], axis=1)  # (N, 6) in axis order
    light = np.zeros((len(P), 3), np.float32)
    for axis in range(6):
        light += weights[:, axis:axis + 1] * ambient_cube_axis(volume, axis, i0, i1, f)
    return light


def sky_volume(sky, ground, ambient):
    """The model's volume when none was baked: one probe whose +Y axis receives `sky`, -Y
    `ground` and the four sides `ambient` ((3,) incident light each, as the hemisphere and
    ambient models use them), so ambient-cube then lights like a hemisphere light."""
    from ..volumes.grid import ProbeGrid
    from ..volumes.volume import LightVolume

    cube = np.empty((6, 1, 1, 1, 3), np.float32)
    cube[:] = np.asarray(ambient, np.float32)
    cube[1], cube[4] = np.asarray(sky, np.float32), np.asarray(ground, np.float32)
    return LightVolume(ProbeGrid((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (1, 1, 1)), cube, np.zeros((1, 1, 1), bool))


def volume_texture(volume) -> np.ndarray:
    """(6 NZ, NY, NX, 4) float32 RGBA texels of the 3D texture ambient_cube.glsl reads (alpha 1)."""
    _, nz, ny, nx, _ = volume.cube.shape
    rgba = np.ones((6 * nz, ny, nx, 4), np.float32)
    rgba[..., :3] = volume.cube.reshape(6 * nz, ny, nx, 3)
    return rgba
