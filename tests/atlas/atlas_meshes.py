"""Small test scenes for the atlas tests: quad, cube, UV sphere, needle triangles."""
from __future__ import annotations

import numpy as np

from patchlight.scene.model import Material, Scene, vertex_normals


def make_scene(positions, indices, uv1=None, uv0=None, normals=None, materials=None, material_ids=None,
               colors=None):
    positions = np.asarray(positions, np.float32)
    indices = np.asarray(indices, np.int32)
    return Scene(positions=positions,
                 normals=vertex_normals(positions, indices) if normals is None else np.asarray(normals, np.float32),
                 uv0=np.zeros((len(positions), 2), np.float32) if uv0 is None else np.asarray(uv0, np.float32),
                 indices=indices,
                 material_ids=np.zeros(len(indices), np.int32) if material_ids is None else material_ids,
                 materials=[Material()] if materials is None else materials,
                 uv1=None if uv1 is None else np.asarray(uv1, np.float32), colors=colors)


def quad_scene(size=2.0, normals=None, **kwargs):
    """A size x size square in the y = 0 plane, normal +Y, uv0 = uv1 = [0,1]^2 with u along +x, v along +z."""
    positions = [[0, 0, 0], [size, 0, 0], [size, 0, size], [0, 0, size]]
    uv = [[0, 0], [1, 0], [1, 1], [0, 1]]
    return make_scene(positions, [[0, 2, 1], [0, 3, 2]], uv1=uv, uv0=uv,
                      normals=np.tile([0, 1, 0], (4, 1)) if normals is None else normals, **kwargs)


def cube_scene(size=1.0):
    """A closed cube of 8 shared vertices and 12 triangles (outward winding)."""
    positions = [[x, y, z] for x in (0, size) for y in (0, size) for z in (0, size)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    indices = [tri for a, b, c, d in quads for tri in ((a, b, c), (a, c, d))]
    return make_scene(positions, indices)


def sphere_scene(segments=24, rings=12, radius=1.0):
    """A closed UV sphere (poles welded), outward winding."""
    theta = np.linspace(0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    positions = np.concatenate([[[0, 1, 0]], ring, [[0, -1, 0]]]) * radius
    bottom = len(positions) - 1
    indices = []
    for j in range(segments):
        k = (j + 1) % segments
        indices.append((0, 1 + k, 1 + j))
        for i in range(rings - 2):
            a, b = 1 + i * segments + j, 1 + i * segments + k
            c, d = a + segments, b + segments
            indices += [(a, b, d), (a, d, c)]
        last = 1 + (rings - 2) * segments
        indices.append((bottom, last + j, last + k))
    return make_scene(positions, indices)


def needle_scene(count=200, seed=1, resolution=16):
    """count needle triangles scattered in uv1 [0,1]^2, each much thinner than a texel at the
    given resolution; world positions are uv1 lifted to the y = 0 plane (1 m per UV unit)."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(0.05, 0.95, (count, 2))
    angle = rng.uniform(0, np.pi, count)
    length = rng.uniform(0.2, 3.0, count) / resolution
    direction = np.stack([np.cos(angle), np.sin(angle)], 1)
    side = np.stack([-direction[:, 1], direction[:, 0]], 1) * rng.uniform(1e-4, 0.05, (count, 1)) / resolution
    end = np.clip(start + direction * length[:, None], 0, 1)
    uv = np.stack([start, end, np.clip(start + 0.5 * (end - start) + side, 0, 1)], 1).reshape(-1, 2)
    positions = np.stack([uv[:, 0], np.zeros(len(uv)), uv[:, 1]], 1)
    return make_scene(positions, np.arange(len(uv)).reshape(-1, 3), uv1=uv,
                      normals=np.tile([0, 1, 0], (len(uv), 1)))
