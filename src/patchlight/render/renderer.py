"""The CPU renderer: Embree camera rays, then the NumPy reference shading.

Rays go through pixel centres (camera.py). Each hit becomes the varyings the GPU would
interpolate (surface.py) and is shaded by `patchlight.shading.shade_fragments`. As the
viewer culls the back faces of single-sided materials, rays pass through them here.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PatchlightError
from ..rays.inside import back_faces, back_share, is_inside, two_sided_triangles
from ..rays.tracer import Hits, Tracer
from ..shading.environment import ENV_SIZE, environment_from_sky, light_highlight
from ..shading.models import LIGHTMAP_MODELS, Fragments, Lighting, MaterialTable, ShadingSettings, light_surface, shade_fragments
from ..shading.surface import interpolate
from ..shading.terms import normalize
from ..shading.textures import cube_directions
from .camera import Camera, interior_cameras, overview_camera, scene_camera
from .target import Target

ENCLOSED_FRACTION = 0.75  # a centre whose probe rays hit this often is in a room (a box open on one side: 5/6)
PROBE_RAYS = 1024  # rays per probe of a point (inside geometry? enclosed?)
MAX_PASS_THROUGH = 16  # single-sided back faces one ray may pass through before it stops
ENV_MODELS = ("envmap", "hemisphere-radiosity")  # the models that read the environment cube


@dataclass
class RenderResult:
    """radiance (H, W, 3) float32 linear, the sky (or black) where no surface; covered (H, W) bool."""

    radiance: np.ndarray
    covered: np.ndarray


class Renderer:
    """Renders one Target with any settings and camera; keeps the Embree scene and the
    environment cube between calls. envmap_from (3,): where the envmap and hemisphere-radiosity
    models' environment cube is rendered from, or None for the scene's sky, else a point of
    the renderer's choosing (`environment_point`)."""

    def __init__(self, target: Target, envmap_from=None):
        self.target = target
        self.envmap_from = None if envmap_from is None else np.asarray(envmap_from, np.float32)
        self._environments: dict = {}
        surface = target.surface
        self.tracer = Tracer(surface.positions, surface.indices)
        self.two_sided = two_sided_triangles(target.scene)  # the surface's triangles, in order
        lo, hi = target.scene.bounds()
        self.center = ((lo + hi) / 2).astype(np.float32)
        self._epsilon = np.float32(1e-5 * max(float(np.linalg.norm(hi - lo)), 1e-3))
        self._vertex_pairs = None

    # ------------------------------------------------------------------ rays

    def trace(self, origins: np.ndarray, directions: np.ndarray) -> Hits:
        """Closest visible hit of each ray: back faces of single-sided surfaces are passed
        through, as the GPU culls them."""
        hits = self.tracer.intersect(origins, directions)
        culled = self._culled(hits)
        travelled = np.zeros(len(origins), np.float32)
        for _ in range(MAX_PASS_THROUGH):
            redo = np.flatnonzero(culled)
            if redo.size == 0:
                break
            travelled[redo] += hits.t[redo] + self._epsilon
            again = self.tracer.intersect(origins[redo] + directions[redo] * travelled[redo, None], directions[redo])
            for name in ("tri", "u", "v", "t", "normal"):  # front follows from them
                getattr(hits, name)[redo] = getattr(again, name)
            culled[:] = False
            culled[redo] = self._culled(again)
        hits.tri[culled] = -1
        return hits

    # ------------------------------------------------------------------ inside geometry

    def _probe(self, point) -> Hits:
        """First hits of PROBE_RAYS rays from `point` (3,) spread evenly over the sphere."""
        dirs = _sphere_directions(PROBE_RAYS)
        return self.tracer.intersect(np.broadcast_to(np.asarray(point, np.float32), dirs.shape), dirs)

    def inside_share(self, point) -> float:
        """The share of all directions from `point` (3,) whose first hit is the back of a
        single-sided surface: 1 inside a closed object or a solid wall, small outside."""
        return float(back_share(self._culled(self._probe(point))))

    def is_inside(self, point) -> bool:
        """`point` lies inside geometry: most directions from it meet single-sided back faces.
        The one test for the camera's eye, the environment map's centre and default_camera."""
        return bool(is_inside(self.inside_share(point), "point"))

    def on_surface(self, point) -> bool:
        """`point` (3,) lies on a surface: some direction from it meets one within the
        pass-through step, where what it sees has no view vector."""
        hits = self._probe(point)
        return bool(np.any((hits.tri >= 0) & (hits.t <= self._epsilon)))

    def require_outside(self, point, where: str, remedy: str = "") -> None:
        """PatchlightError (one line, `where` names the point, `remedy` the way out) when
        `point` is inside geometry."""
        share = self.inside_share(point)
        if is_inside(share, "point"):
            raise PatchlightError(f"{where} is inside geometry: {100 * share:.0f}% of the directions from it "
                                  f"meet the back of a single-sided surface{remedy}")

    def default_camera(self) -> Camera:
        """The scene's own camera; else, when the scene's centre is enclosed (a room, a box
        open on one side), a view from near a wall whose eye is not inside geometry; else an
        overview from outside."""
        camera = scene_camera(self.target.scene)
        if camera is not None:
            return camera
        lo, hi = self.target.scene.bounds()
        hits = self._probe(self.center)
        hit_share = np.count_nonzero((hits.tri >= 0) & (hits.t > self._epsilon)) / PROBE_RAYS  # a surface
        # through the centre (a lone plane) encloses nothing
        inside = is_inside(back_share(self._culled(hits)), "point")
        enclosed = hit_share >= ENCLOSED_FRACTION and not inside
        candidates = (interior_cameras(lo, hi) if enclosed else []) + [overview_camera(lo, hi)]
        for camera in candidates:
            if not self.is_inside(camera.eye):
                return camera
        return candidates[-1]

    def _culled(self, hits: Hits) -> np.ndarray:
        return back_faces(hits.tri, hits.front, self.two_sided)

    # ------------------------------------------------------------------ shading

    def fragments(self, hits: Hits, settings: ShadingSettings, eye: np.ndarray, materials: MaterialTable) -> Fragments:
        """The varyings of the rays that hit (surface_vertex.glsl's outputs, interpolated)."""
        s = self.target.surface
        sel = hits.tri >= 0
        tri = hits.tri[sel]
        u, v = hits.u[sel], hits.v[sel]
        bary = np.stack([1 - u - v, u, v], axis=1).astype(np.float32)
        corners = s.indices[tri]
        frags = Fragments(position=interpolate(s.positions, corners, bary),
                          normal=interpolate(s.normals, corners, bary),
                          tangent=interpolate(s.tangents, corners, bary) if settings.normal_map else None,
                          uv0=interpolate(s.uv0, corners, bary),
                          uv1=interpolate(s.uv1, corners, bary) if settings.model in LIGHTMAP_MODELS else None,
                          color=interpolate(s.colors, corners, bary), material=s.material_ids[tri],
                          front=hits.front[sel])
        if settings.per_vertex and settings.model != "unlit":
            lighting, pair_of_corner = self.vertex_lighting(settings, eye, materials)
            frags.vertex_lighting = lighting.interpolate(pair_of_corner[tri], bary)
        return frags

    def vertex_lighting(self, settings: ShadingSettings, eye: np.ndarray,
                        materials: MaterialTable) -> tuple[Lighting, np.ndarray]:
        """surface_vertex.glsl under PER_VERTEX: the light sum at every (vertex, material) pair
        (a vertex shared by two materials is lit once with each), and (T, 3) the pair of each
        triangle corner."""
        s = self.target.surface
        if self._vertex_pairs is None:
            n_mat = max(len(materials.shininess), 1)
            keys = s.indices.astype(np.int64) * n_mat + s.material_ids[:, None]
            unique, inverse = np.unique(keys, return_inverse=True)
            self._vertex_pairs = (unique // n_mat, unique % n_mat, inverse.reshape(s.indices.shape))
        vertex, material, pair_of_corner = self._vertex_pairs
        P = s.positions[vertex]
        N = normalize(s.normals[vertex])
        V = normalize(np.asarray(eye, np.float32) - P)
        lighting = light_surface(settings, P, N, V, np.float32(1.0), materials.shininess[material],
                                 materials.reflectivity[material])
        return lighting, pair_of_corner

    def shade_rays(self, settings: ShadingSettings, origins: np.ndarray,
                   directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Radiance (N, 3) and covered (N,) along rays that all start at origins[0], a point
        the caller has found outside geometry."""
        settings.validate()
        eye = np.asarray(origins[0], np.float32)
        self.require_inputs(settings)
        env = self.environment(settings) if settings.model in ENV_MODELS else None
        materials = MaterialTable.from_materials(self.target.scene.materials, settings.reflectivity)
        hits = self.trace(origins, directions)
        frags = self.fragments(hits, settings, eye, materials)
        covered = hits.tri >= 0
        radiance = np.zeros((len(origins), 3), np.float32)
        radiance[covered] = shade_fragments(settings, frags, materials, eye, self.target.lightmap, env)
        if self.target.scene.sky is not None:  # the sky behind, as the viewer draws it
            radiance[~covered] = self.target.scene.sky.radiance(directions[~covered])
        return radiance, covered

    def render(self, settings: ShadingSettings, camera: Camera, width: int, height: int) -> RenderResult:
        """Linear radiance seen by `camera` on a width x height image."""
        where = "the camera at ({:g}, {:g}, {:g})".format(*camera.eye)
        self.require_outside(camera.eye, where, " (choose another `camera`)")
        radiance, covered = self.shade_rays(settings, *camera.rays(width, height))
        return RenderResult(radiance.reshape(height, width, 3), covered.reshape(height, width))

    def require_inputs(self, settings: ShadingSettings) -> None:
        """PatchlightError when the model needs data the target lacks."""
        if settings.model in LIGHTMAP_MODELS and self.target.lightmap is None:
            raise PatchlightError(f"{self.target.name}: `model` {settings.model} needs a bake directory with "
                                  f"lightmap.exr (write one with `patchlight bake`)")
        if settings.model == "lightmap-directional" and settings.directional is None:
            raise PatchlightError(f"{self.target.name}: `model` lightmap-directional needs a bake with directional "
                                  f"maps (baked with `directional` sh or dominant)")

    # ------------------------------------------------------------------ environment

    @property
    def sky_is_environment(self) -> bool:
        """The environment cube is the scene's sky (so the viewer may draw it behind the scene)."""
        return self.target.scene.sky is not None and self.envmap_from is None

    def environment(self, settings: ShadingSettings, size: int = ENV_SIZE) -> np.ndarray:
        """The environment cube map (6, size, size, 4) of the envmap and hemisphere-radiosity
        models, made once per set of lights and surroundings: the scene's sky when it has one
        and no envmap_from was given, else the scene seen from `environment_point()` with the
        lightmap model (a bake) or Lambert, the sky or black behind. A holds the suns'
        highlight (shading.environment.light_highlight)."""
        key = (size, repr([light.to_json() for light in settings.lights]),
               *(np.asarray(v, np.float32).tobytes() for v in (settings.ambient, settings.sky, settings.ground)))
        if key not in self._environments:
            self._environments[key] = self._make_environment(settings, size)
        return self._environments[key]

    def sky_cube(self, settings: ShadingSettings, size: int = ENV_SIZE) -> np.ndarray | None:
        """(6, size, size, 4) the sky this renderer fills misses with, as a cube map (the
        environment cube itself when that is the sky), or None without a sky."""
        if self.sky_is_environment:
            return self.environment(settings, size)
        sky = self.target.scene.sky
        return None if sky is None else environment_from_sky(sky, [], size)

    def environment_point(self) -> np.ndarray:
        """(3,) where the environment cube is rendered from when it is not the sky:
        envmap_from when given; else the scene's centre, or, when that is inside geometry (a
        closed object such as a single-sided sphere) or on a surface (a lone plane), the
        default camera's eye. A
        PatchlightError naming `envmap_from` and `sky` when the point is inside geometry."""
        if self.envmap_from is not None:
            where = "`envmap_from` {:g},{:g},{:g}".format(*self.envmap_from)
            self.require_outside(self.envmap_from, where, "; choose a point in the open")
            return self.envmap_from
        if not self.is_inside(self.center) and not self.on_surface(self.center):
            return self.center
        eye = np.asarray(self.default_camera().eye, np.float32)
        if self.is_inside(eye):
            raise PatchlightError("the environment map: the scene's centre ({:g}, {:g}, {:g}) and the default "
                                  "camera's eye ({:g}, {:g}, {:g}) are inside geometry; render it from a point in "
                                  "the open with `envmap_from` X,Y,Z or reflect a sky (`sky` R,G,B)"
                                  .format(*self.center, *eye))
        return eye

    def _make_environment(self, settings: ShadingSettings, size: int) -> np.ndarray:
        if self.sky_is_environment:
            return environment_from_sky(self.target.scene.sky, settings.lights, size)
        point = self.environment_point()
        dirs = cube_directions(size).reshape(-1, 3)
        inner = ShadingSettings(model="lightmap" if self.target.lightmap is not None else "lambert",
                                lights=settings.lights, ambient=settings.ambient, sky=settings.sky,
                                ground=settings.ground)
        radiance, _ = self.shade_rays(inner, np.broadcast_to(point, dirs.shape), dirs)
        alpha = light_highlight(dirs, settings.lights)
        return np.concatenate([radiance, alpha[:, None]], axis=1).reshape(6, size, size, 4).astype(np.float32)


def _sphere_directions(n: int) -> np.ndarray:
    """(n, 3) float32 unit vectors spread evenly over the sphere (a Fibonacci lattice)."""
    i = np.arange(n) + 0.5
    y = 1 - 2 * i / n
    r = np.sqrt(1 - y * y)
    phi = i * np.pi * (3 - np.sqrt(5))
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=1).astype(np.float32)
