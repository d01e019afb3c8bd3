"""The `ambient-cube` model's terms: one function per GLSL function of the same name in
`patchlight/shaders/ambient_cube.glsl`, where the formulas and their sources are documented.

`volume` is a `patchlight.volumes.LightVolume`: cube (6, NZ, NY, NX, 3) incident light in axis
order +X, +Y, +Z, -X, -Y, -Z on the grid (origin, spacing, dims), and validity (NZ, NY, NX)
the probes' weights (0 inside geometry, 1 in the open). Points are (N, 3) world
metres, normals (N, 3) unit; results keep float32.
"""
from __future__ import annotations

import numpy as np

from .terms import saturate

MIN_VALID_WEIGHT = 1e-3  # below this share of valid probes in a cell, plain trilinear blends in (ambient_cube_corners)


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
    _, _, ny, nx, _ = volume.cube.shape
    return np.take(volume.cube.reshape(-1, 3), (z * ny + y) * nx + x, axis=0)  # one flat gather, twice as fast


def ambient_cube_validity(volume, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """ambient_cube.glsl: the validity (N,) of probe (x, y, z) (N,) each, z in [0, NZ): the
    texture's alpha, the same in every axis' slice."""
    return volume.validity[z, y, x]


def ambient_cube_corners(volume, i0: np.ndarray, i1: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ambient_cube.glsl: the weights of the cell's eight probes, (near, far) (N, 4) each: near
    at z = i0.z, far at i1.z, each in the order (x0, y0), (x1, y0), (x0, y1), (x1, y1).
    Trilinear weights t times validity v, normalised: probes inside geometry drop out. Where
    the valid weight s = sum t v falls below MIN_VALID_WEIGHT, plain trilinear blends in,
    t (v + a) with a = MIN_VALID_WEIGHT - s, so where all eight are invalid it is plain
    trilinear, and the result is continuous (patchlight.volumes.io, "Sampling")."""
    one = np.float32(1)
    fx, fy, fz = f[:, 0:1], f[:, 1:2], f[:, 2:3]
    tx = np.concatenate([one - fx, fx, one - fx, fx], axis=1)
    txy = tx * np.concatenate([one - fy, one - fy, fy, fy], axis=1)
    t_near, t_far = txy * (one - fz), txy * fz
    x = np.stack([i0[:, 0], i1[:, 0], i0[:, 0], i1[:, 0]], axis=1)
    y = np.stack([i0[:, 1], i0[:, 1], i1[:, 1], i1[:, 1]], axis=1)
    v_near = ambient_cube_validity(volume, x, y, i0[:, 2:3])
    v_far = ambient_cube_validity(volume, x, y, i1[:, 2:3])
    valid = (t_near * v_near).sum(axis=1, keepdims=True) + (t_far * v_far).sum(axis=1, keepdims=True)
    plain = np.maximum(np.float32(MIN_VALID_WEIGHT) - valid, np.float32(0))
    total = valid + plain  # >= MIN_VALID_WEIGHT: the trilinear weights sum to 1
    return (t_near * (v_near + plain) / total).astype(np.float32), (t_far * (v_far + plain) / total).astype(np.float32)


def ambient_cube_axis(volume, axis: int, i0: np.ndarray, i1: np.ndarray, near: np.ndarray,
                      far: np.ndarray) -> np.ndarray:
    """ambient_cube.glsl: axis `axis`'s incident light (N, 3), the cell's eight probes weighted
    by ambient_cube_corners' (near, far)."""
    nz = volume.grid.dims[2]
    x0, y0, x1, y1 = i0[:, 0], i0[:, 1], i1[:, 0], i1[:, 1]
    light = np.zeros((len(i0), 3), np.float32)
    for z, w in ((i0[:, 2] + axis * nz, near), (i1[:, 2] + axis * nz, far)):
        for k, (x, y) in enumerate(((x0, y0), (x1, y0), (x0, y1), (x1, y1))):
            light += w[:, k:k + 1] * ambient_cube_probe(volume, x, y, z)
    return light


def ambient_cube_light(volume, P: np.ndarray, N: np.ndarray, naive: bool = False) -> np.ndarray:
    """ambient_cube.glsl: incident light (N, 3) at points P on surfaces of normal N: the six
    axis values interpolated between the cell's probes by validity (ambient_cube_corners),
    weighted by ambient_cube_weights."""
    i0, i1, f = ambient_cube_cell(volume, P)
    near, far = ambient_cube_corners(volume, i0, i1, f)
    return _weighted_axes(N, naive, lambda axis: ambient_cube_axis(volume, axis, i0, i1, near, far))


def sky_cube(sky, ground, ambient) -> np.ndarray:
    """(6, 3) float32 axis values of the model when no volume was baked, the sky as one probe:
    +Y receives `sky`, -Y `ground` and the four sides `ambient` ((3,) incident light each, as
    the hemisphere and ambient models use them), so ambient-cube then lights like a
    hemisphere light. The viewer uploads them as a one-probe volume
    (patchlight.volumes.sky_volume)."""
    cube = np.empty((6, 3), np.float32)
    cube[:] = np.asarray(ambient, np.float32)
    cube[1], cube[4] = np.asarray(sky, np.float32), np.asarray(ground, np.float32)
    return cube


def sky_cube_light(cube: np.ndarray, N: np.ndarray, naive: bool = False) -> np.ndarray:
    """ambient_cube_light of a one-probe volume of axis values cube (6, 3) (sky_cube): there
    every point reads the probe itself, so only the normal's weights matter. (N, 3)."""
    return _weighted_axes(N, naive, lambda axis: cube[axis])


def _weighted_axes(N: np.ndarray, naive: bool, axis_light) -> np.ndarray:
    """sum over the six axes of ambient_cube_weights(N) times axis_light(axis) ((N, 3) or (3,))."""
    w = ambient_cube_weights(N.astype(np.float32), naive)
    weights = np.concatenate([saturate(w), saturate(-w)], axis=1)  # (N, 6) in axis order
    light = np.zeros((len(N), 3), np.float32)
    for axis in range(6):
        light += weights[:, axis:axis + 1] * axis_light(axis)
    return light


def volume_texture(volume) -> np.ndarray:
    """(6 NZ, NY, NX, 4) float32 RGBA texels of the 3D texture ambient_cube.glsl reads: RGB the
    axis' incident light, alpha the probe's validity (repeated in each axis' slices)."""
    _, nz, ny, nx, _ = volume.cube.shape
    rgba = np.empty((6 * nz, ny, nx, 4), np.float32)
    rgba[..., :3] = volume.cube.reshape(6 * nz, ny, nx, 3)
    rgba[..., 3] = np.tile(volume.validity, (6, 1, 1))
    return rgba
