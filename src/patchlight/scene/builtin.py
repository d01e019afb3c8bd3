"""Built-in scenes, usable anywhere a scene path is: `room` and `cornell`.

- room: the radiosity article's room. An 8 x 3 x 6 m interior behind a 0.4 m thick front
  wall with three windows, two pillars and three alcoves in the back wall; lit only by a
  sun and a blue sky gradient outside the windows. Walls are solid boxes, so some faces lie
  inside others, as in real level geometry.
- cornell: the Cornell box as measured (converted from millimetres to metres), with the
  usual spectral-average reflectances and the emissive ceiling light of radiance (17, 12, 4).
"""
from __future__ import annotations

import numpy as np

from .model import Light, Material, Scene, face_normals
from .sky import Sky


class SceneBuilder:
    """Builds a Scene from oriented quads and boxes: the built-in scenes use it, and so can
    scripts and tests that make scenes procedurally."""

    def __init__(self):
        self.materials: list[Material] = []
        self.positions: list[np.ndarray] = []
        self.material_ids: list[int] = []

    def material(self, name: str, rgb, emissive=(0.0, 0.0, 0.0)) -> int:
        self.materials.append(Material(name=name, base_color=np.array([*rgb, 1.0], np.float32),
                                       emissive=np.array(emissive, np.float32)))
        return len(self.materials) - 1

    def quad(self, corners, material: int, facing) -> None:
        """Add quad (4, 3) as two triangles whose normal points along `facing` (3,)."""
        c = np.asarray(corners, np.float32)
        normal = np.cross(c[1] - c[0], c[2] - c[0])
        if np.dot(normal, facing) < 0:
            c = c[::-1]
        for tri in (c[[0, 1, 2]], c[[0, 2, 3]]):
            self.positions.append(tri)
            self.material_ids.append(material)

    def box(self, lo, hi, material: int, inward: bool = False) -> None:
        """An axis-aligned box with six faces facing out (or in, for a room's shell)."""
        lo, hi = np.asarray(lo, np.float32), np.asarray(hi, np.float32)
        sign = -1.0 if inward else 1.0
        for axis in range(3):
            u, v = [a for a in range(3) if a != axis]
            for side, value in ((-1.0, lo[axis]), (1.0, hi[axis])):
                corners = []
                for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
                    p = np.empty(3, np.float32)
                    p[axis] = value
                    p[u] = (lo[u], hi[u])[a]
                    p[v] = (lo[v], hi[v])[b]
                    corners.append(p)
                facing = np.zeros(3, np.float32)
                facing[axis] = side * sign
                self.quad(corners, material, facing)

    def scene(self, name: str, lights=(), sky=None, camera: dict | None = None) -> Scene:
        """The Scene of every quad added so far (flat normals, planar uv0 in metres)."""
        tris = np.stack(self.positions)  # (T, 3, 3)
        positions = tris.reshape(-1, 3)
        indices = np.arange(len(positions), dtype=np.int32).reshape(-1, 3)
        normal, _ = face_normals(positions, indices)
        normals = np.repeat(normal, 3, axis=0)
        uv0 = _planar_uvs(positions, normals)
        return Scene(positions=positions, normals=normals, uv0=uv0, indices=indices,
                     material_ids=np.array(self.material_ids, np.int32), materials=self.materials,
                     lights=list(lights), sky=sky, name=name, source=name,
                     extras={"camera": camera} if camera else {})


def _planar_uvs(positions: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Texture UVs in metres, projected along each vertex's dominant normal axis."""
    axis = np.abs(normals).argmax(axis=1)
    keep = np.array([[1, 2], [0, 2], [0, 1]])[axis]
    return np.take_along_axis(positions, keep, axis=1).astype(np.float32)


def room() -> Scene:
    """The article's room: three windows in a thick wall, two pillars, alcoves; sun and sky."""
    b = SceneBuilder()
    wall = b.material("plaster", (0.70, 0.68, 0.64))
    floor = b.material("floor", (0.45, 0.32, 0.22))
    pillar = b.material("stone", (0.60, 0.60, 0.62))
    width, height, depth, t = 8.0, 3.0, 6.0, 0.4
    b.box((-t, -t, -t), (width + t, 0.0, depth + t), floor)            # floor slab
    b.box((-t, height, -t), (width + t, height + t, depth + t), wall)   # ceiling slab
    b.box((-t, 0, -t), (0.0, height, depth + t), wall)                  # left wall
    b.box((width, 0, -t), (width + t, height, depth + t), wall)         # right wall
    # back wall (z = depth) with three 0.35 m deep alcoves
    b.box((0, 0, depth), (width, height, depth + t), wall)
    alcoves = [(1.0, 2.0), (3.5, 4.5), (6.0, 7.0)]
    edges = [0.0] + [e for a in alcoves for e in a] + [width]
    for x0, x1 in zip(edges[0::2], edges[1::2]):
        b.box((x0, 0, depth - 0.35), (x1, height, depth), wall)
    for x0, x1 in alcoves:                                               # alcove lintels
        b.box((x0, 2.2, depth - 0.35), (x1, height, depth), wall)
    # front wall (z = 0 .. -t) with three windows 1.4 m wide, sill 0.9 m, head 2.3 m
    windows = [(0.9, 2.3), (3.3, 4.7), (5.7, 7.1)]
    b.box((0, 0, -t), (width, 0.9, 0), wall)
    b.box((0, 2.3, -t), (width, height, 0), wall)
    piers = [0.0] + [e for w in windows for e in w] + [width]
    for x0, x1 in zip(piers[0::2], piers[1::2]):
        b.box((x0, 0.9, -t), (x1, 2.3, 0), wall)
    for x in (2.8, 5.2):                                                 # two pillars
        b.box((x - 0.2, 0, 2.6), (x + 0.2, height, 3.0), pillar)
    sun_dir = np.array([0.35, -0.55, 0.76], np.float32)
    sun = Light("directional", np.array([1.0, 0.95, 0.85], np.float32), 100.0,
                direction=sun_dir / np.linalg.norm(sun_dir), angle=np.radians(0.53), name="sun")
    sky = Sky.gradient(zenith=(1.2, 1.9, 3.6), horizon=(2.6, 2.9, 3.2), ground=(0.5, 0.45, 0.4))
    return b.scene("room", lights=[sun], sky=sky, camera={"eye": [7.6, 2.4, 5.6], "target": [2.0, 0.9, 0.3], "fov": 75.0})


# Cornell box as measured, in millimetres (x, y, z); each quad listed with a point inside
# the box so faces can be oriented towards the viewer's side.
_CORNELL_WALLS = {
    "floor": [(552.8, 0, 0), (0, 0, 0), (0, 0, 559.2), (549.6, 0, 559.2)],
    "ceiling": [(556, 548.8, 0), (556, 548.8, 559.2), (0, 548.8, 559.2), (0, 548.8, 0)],
    "back": [(549.6, 0, 559.2), (0, 0, 559.2), (0, 548.8, 559.2), (556, 548.8, 559.2)],
    "green": [(0, 0, 559.2), (0, 0, 0), (0, 548.8, 0), (0, 548.8, 559.2)],
    "red": [(552.8, 0, 0), (549.6, 0, 559.2), (556, 548.8, 559.2), (556, 548.8, 0)],
}
_CORNELL_LIGHT = [(343, 548.7, 227), (343, 548.7, 332), (213, 548.7, 332), (213, 548.7, 227)]
_CORNELL_BLOCKS = {
    "short": [(130, 65), (82, 225), (240, 272), (290, 114), 165.0],
    "tall": [(423, 247), (265, 296), (314, 456), (472, 406), 330.0],
}


def cornell() -> Scene:
    """The Cornell box in metres, lit only by its emissive ceiling light."""
    b = SceneBuilder()
    white = b.material("white", (0.725, 0.71, 0.68))
    red = b.material("red", (0.63, 0.065, 0.05))
    green = b.material("green", (0.14, 0.45, 0.091))
    light = b.material("light", (0.78, 0.78, 0.78), emissive=(17.0, 12.0, 4.0))
    mm = 1e-3
    centre = np.array([278.0, 274.4, 279.6]) * mm
    colours = {"red": red, "green": green}
    for name, corners in _CORNELL_WALLS.items():
        c = np.array(corners) * mm
        b.quad(c, colours.get(name, white), centre - c.mean(axis=0))
    b.quad(np.array(_CORNELL_LIGHT) * mm, light, (0, -1, 0))
    for *footprint, top in _CORNELL_BLOCKS.values():
        xz = np.array(footprint) * mm
        block_centre = np.array([xz[:, 0].mean(), top * mm / 2, xz[:, 1].mean()])
        top_face = np.array([[x, top * mm, z] for x, z in xz])
        b.quad(top_face, white, (0, 1, 0))
        for i in range(4):
            (x0, z0), (x1, z1) = xz[i], xz[(i + 1) % 4]
            side = np.array([[x0, 0, z0], [x1, 0, z1], [x1, top * mm, z1], [x0, top * mm, z0]])
            b.quad(side, white, side.mean(axis=0) - block_centre)
    return b.scene("cornell", camera={"eye": [0.278, 0.273, -0.8], "target": [0.278, 0.273, 0.0], "fov": 39.3})

