"""Small procedural scenes for the shading, renderer and viewer tests.

`showcase_target()` exercises every model and option at once: a textured, normal-mapped
UV sphere (single-sided, gloss in the colour alpha), a double-sided ground quad, a box with
vertex colours, lightmap UVs with a smooth float lightmap, a gradient sky and one light of
each kind.
"""
from __future__ import annotations

import math

import numpy as np

from patchlight.shading.directional import DirectionalLightmap
from patchlight.render.target import Target
from patchlight.scene.model import Light, Material, Scene
from patchlight.scene.sky import Sky


def uv_sphere(lat: int, lon: int, radius: float = 1.0, center=(0.0, 0.0, 0.0)):
    """positions, normals (V, 3), uv (V, 2), indices (T, 3) of a UV sphere, outward faces.
    u follows longitude (seam vertices doubled), v runs from the north pole (0) to the south (1)."""
    theta = np.linspace(0, math.pi, lat + 1)
    phi = np.linspace(0, 2 * math.pi, lon + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    normals = np.stack([np.sin(t) * np.sin(p), np.cos(t), np.sin(t) * np.cos(p)], axis=-1).reshape(-1, 3)
    uv = np.stack([p / (2 * math.pi), t / math.pi], axis=-1).reshape(-1, 2)
    tris = []
    for i in range(lat):
        for j in range(lon):
            a, b = i * (lon + 1) + j, i * (lon + 1) + j + 1
            c, d = a + lon + 1, b + lon + 1
            if i > 0:
                tris.append((a, c, b))
            if i < lat - 1:
                tris.append((b, c, d))
    positions = normals * radius + np.asarray(center)
    return (positions.astype(np.float32), normals.astype(np.float32), uv.astype(np.float32),
            np.array(tris, np.int32))


def _quad(corners, normal, uv_scale=1.0):
    c = np.asarray(corners, np.float32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32) * uv_scale
    return c, np.tile(np.asarray(normal, np.float32), (4, 1)), uv, np.array([[0, 1, 2], [0, 2, 3]], np.int32)


def _box(lo, hi):
    parts = []
    lo, hi = np.asarray(lo, np.float32), np.asarray(hi, np.float32)
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        for sign, value in ((-1, lo[axis]), (1, hi[axis])):
            corners = []
            for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
                q = np.empty(3, np.float32)
                q[axis], q[u], q[v] = value, (lo[u], hi[u])[a], (lo[v], hi[v])[b]
                corners.append(q)
            normal = np.zeros(3, np.float32)
            normal[axis] = sign
            if np.dot(np.cross(corners[1] - corners[0], corners[2] - corners[0]), normal) < 0:
                corners = corners[::-1]
            parts.append(_quad(corners, normal))
    return parts


def scene_from_parts(parts, materials, part_material, lights=(), sky=None, uv1_boxes=None, colors=None) -> Scene:
    """One Scene from (positions, normals, uv, indices) parts; uv1_boxes: per part (u0, v0, u1, v1)."""
    positions, normals, uv0, uv1, indices, mats = [], [], [], [], [], []
    base = 0
    for k, (p, n, uv, idx) in enumerate(parts):
        positions.append(p)
        normals.append(n)
        uv0.append(uv)
        if uv1_boxes is not None:
            u0, v0, u1, v1 = uv1_boxes[k]
            span = np.maximum(uv.max(axis=0) - uv.min(axis=0), 1e-6)
            uv1.append((uv - uv.min(axis=0)) / span * [u1 - u0, v1 - v0] + [u0, v0])
        indices.append(idx + base)
        mats.append(np.full(len(idx), part_material[k], np.int32))
        base += len(p)
    return Scene(positions=np.concatenate(positions).astype(np.float32),
                 normals=np.concatenate(normals).astype(np.float32), uv0=np.concatenate(uv0).astype(np.float32),
                 indices=np.concatenate(indices).astype(np.int32), material_ids=np.concatenate(mats),
                 materials=list(materials), lights=list(lights), sky=sky,
                 uv1=None if uv1_boxes is None else np.concatenate(uv1).astype(np.float32),
                 colors=colors, name="test", source="test")


def sphere_target(lat=32, lon=64, lights=(), material=None, sky=None) -> Target:
    """A unit UV sphere at the origin with one material."""
    scene = scene_from_parts([uv_sphere(lat, lon)], [material or Material(name="sphere")], [0], lights, sky)
    return Target.from_scene(scene)


def closed_sphere_under_a_sun(camera: dict | None = None, lat=16, lon=32) -> Target:
    """A closed single-sided sphere, a sun and no sky (`patchlight view sphere.glb`): its
    bounding-box centre is inside it. camera: the scene's own {eye, target, fov}, if any."""
    sun = Light("directional", np.ones(3, np.float32), 3.0, direction=np.array([0.0, -1.0, 0.0], np.float32))
    target = sphere_target(lat, lon, [sun])
    if camera is not None:
        target.scene.extras = {"camera": camera}
    return target


def color_texture(size=32) -> np.ndarray:
    """(size, 2 size, 4) linear RGBA: smooth colour bands, alpha (gloss) high in the top half."""
    y, x = np.mgrid[0:size, 0:2 * size] + 0.5
    u, v = x / (2 * size), y / size
    r = 0.55 + 0.35 * np.sin(2 * math.pi * 3 * u)
    g = 0.5 + 0.3 * np.cos(2 * math.pi * 2 * v)
    b = 0.45 + 0.25 * np.sin(2 * math.pi * (u + v))
    gloss = np.clip(1.2 - 1.4 * v, 0.05, 1.0)
    return np.stack([r, g, b, gloss], axis=-1).astype(np.float32)


def normal_texture(size=32) -> np.ndarray:
    """(size, 2 size, 3) tangent-space normals in [0, 1]: smooth bumps, tilted up to ~35 degrees."""
    y, x = np.mgrid[0:size, 0:2 * size] + 0.5
    u, v = x / (2 * size), y / size
    nx = 0.5 * np.sin(2 * math.pi * 4 * u)
    ny = 0.5 * np.sin(2 * math.pi * 3 * v)
    n = np.stack([nx, ny, np.ones_like(nx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return (0.5 * n + 0.5).astype(np.float32)


def lightmap_image(width=64, height=32) -> np.ndarray:
    """(H, W, 3) smooth positive incident light."""
    y, x = np.mgrid[0:height, 0:width] + 0.5
    u, v = x / width, y / height
    return np.stack([0.6 + 0.4 * np.sin(6 * u), 0.5 + 0.3 * np.cos(5 * v), 0.4 + 0.3 * u * v],
                    axis=-1).astype(np.float32)


def showcase_lights() -> list[Light]:
    return [
        Light("directional", np.array([1.0, 0.95, 0.9], np.float32), 5.0,
              direction=np.array([-0.4, -0.8, -0.45], np.float32) / np.linalg.norm([-0.4, -0.8, -0.45])),
        Light("point", np.array([0.4, 0.6, 1.0], np.float32), 40.0, position=np.array([2.0, 1.5, 1.0], np.float32),
              range=6.0, name="blue point"),
        Light("spot", np.array([1.0, 0.5, 0.3], np.float32), 60.0, position=np.array([-1.5, 2.5, 2.0], np.float32),
              direction=np.array([0.45, -0.75, -0.5], np.float32) / np.linalg.norm([0.45, -0.75, -0.5]),
              range=8.0, inner_cone=0.25, outer_cone=0.5, name="orange spot"),
    ]


def showcase_scene(lat=24, lon=48) -> Scene:
    sphere_mat = Material(name="sphere", base_color=np.array([1.0, 0.9, 0.8, 1.0], np.float32),
                          base_color_texture=color_texture(), normal_texture=normal_texture(),
                          shininess=24.0, reflectivity=0.6)
    ground_mat = Material(name="ground", base_color=np.array([0.6, 0.6, 0.55, 1.0], np.float32),
                          double_sided=True, shininess=8.0, reflectivity=0.2)
    box_mat = Material(name="box", base_color=np.array([0.8, 0.8, 0.8, 1.0], np.float32),
                       emissive=np.array([0.05, 0.02, 0.0], np.float32), shininess=16.0, reflectivity=0.4)
    parts = [uv_sphere(lat, lon),
             _quad([[-3, -1, 3], [3, -1, 3], [3, -1, -3], [-3, -1, -3]], [0, 1, 0], uv_scale=2.0),
             *_box([1.3, -1.0, -1.6], [2.1, -0.2, -0.8])]
    part_material = [0, 1] + [2] * 6
    boxes = [(0.0, 0.0, 0.5, 1.0), (0.5, 0.0, 1.0, 0.5)] + [(0.5 + 0.08 * k, 0.55, 0.56 + 0.08 * k, 0.95)
                                                            for k in range(6)]
    scene = scene_from_parts(parts, [sphere_mat, ground_mat, box_mat], part_material, showcase_lights(),
                             Sky.gradient([0.05, 0.1, 0.3], [0.2, 0.22, 0.25], [0.08, 0.06, 0.05]), boxes)
    n = len(scene.positions)
    rng = np.random.default_rng(4)
    scene.colors = np.ones((n, 4), np.float32)
    box_vertices = np.unique(scene.indices[scene.material_ids == 2])
    scene.colors[box_vertices, :3] = rng.uniform(0.5, 1.0, (len(box_vertices), 3))
    return scene


def directional_maps(mode: str, width=64, height=32) -> DirectionalLightmap:
    """Smooth directional data beside lightmap_image(): light mostly from a direction that
    turns across the map, L1 up to 0.8 of its largest length (sh), share 0.3..0.9 (dominant)."""
    y, x = np.mgrid[0:height, 0:width] + 0.5
    u, v = x / width, y / height
    d = np.stack([np.sin(4 * u), 0.6 + 0.4 * np.cos(3 * v), np.cos(5 * u * v)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    if mode == "dominant":
        return DirectionalLightmap(mode, (d * (0.3 + 0.6 * u)[..., None])[None])
    c0 = lightmap_image(width, height) * 3.0
    l1 = [0.8 * np.sqrt(3) * c0 * d[..., k:k + 1] for k in range(3)]
    return DirectionalLightmap(mode, np.stack([c0, *l1]))


def showcase_target(lat=24, lon=48, directional: str = "sh") -> Target:
    target = Target.from_scene(showcase_scene(lat, lon), lightmap_image())
    target.directional = directional_maps(directional)
    return target


SHOWCASE_CAMERA = ((3.2, 2.0, 4.2), (0.2, -0.3, 0.0), 40.0)
