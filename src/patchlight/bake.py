"""The bake pipeline: Scene -> atlas -> patches -> direct -> gather -> passes -> lightmap.

Each stage is a function of arrays (docs/architecture.md); this module only strings them
together and times them; `patchlight.bakedir` writes the results. The CLI and the Python API
both call `bake`.
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from .atlas.lightmap import LightmapFill, denoised_incident, stitch_seams, valid_texels
from .atlas.patches import Patches
from .config import BakeSettings
from .errors import PatchlightError
from .limits import available_memory
from .progress import Progress
from .radiosity import adaptive
from .radiosity.direct import texel_direct_light
from .radiosity.directional import add_direct, add_emitters, gather_directions, split_maps
from .radiosity.emitters import emitter_light, find_emitters, samples_per_texel
from .radiosity.gather import Gatherer, load_first_kernel
from .radiosity.memory import (check_bake_memory, estimate_peak_bytes, estimate_seconds, form_factor_budget,
                               peak_resident_bytes)
from .radiosity.sampling import gather_adaptive, walled_inside
from .radiosity.solve import FormFactors, Solution, change_to_come, solve
from .rays.tracer import Tracer
from .scene.model import Scene
from .shading.directional import DirectionalLightmap

COMPILED = ("this bake compiled patchlight's kernels for this machine (the first bake since they were "
            "installed or changed), about a minute; later bakes load them from numba's cache")


@dataclass
class BakeResult:
    """lightmap: (H, W, 3) f32 incident light, dilated. patches, status (N,) sampler state,
    solution, fill: how the patches' values became the lightmap (for the passes' images),
    the (possibly re-indexed) scene with its lightmap UVs, stats for bake.json,
    pass_incident: each pass's incident light (N, 3) float16, walled (N,) bool: the inside
    texels left dark (`walled_inside`), and directional: the directional lightmap
    (`BakeSettings.directional`) or None."""

    scene: Scene
    patches: Patches
    lightmap: np.ndarray
    status: np.ndarray
    solution: Solution
    fill: LightmapFill
    stats: dict = field(default_factory=dict)
    pass_incident: list = field(default_factory=list)
    walled: np.ndarray | None = None
    directional: DirectionalLightmap | None = None

    def pass_images(self):
        """Each pass's lightmap (H, W, 3) f32, filled and dilated as `lightmap` is, one at a
        time (a generator: a large lightmap's passes never sit in memory at full precision)."""
        return (self.fill.image(I) for I in self.pass_incident)

    @property
    def valid(self) -> np.ndarray:
        """(H, W) bool: the lightmap's texels with light of their own (not inside geometry)."""
        return valid_texels(self.patches, self.status == adaptive.INSIDE)


def _check_scene(scene: Scene) -> None:
    scene.validate()
    if not scene.has_light():
        kept = " (the lights kept dynamic are not baked)" if len(scene.baked_lights) < len(scene.lights) else ""
        raise PatchlightError(f"{scene.label}: nothing lights the scene{kept} "
                              "(no sun, no lamp, no emissive material, no sky); add one or pass `sky` R,G,B")


def _input_warnings(scene: Scene) -> list[str]:
    """One line per thing the importer left out or ignored."""
    where = scene.label
    counted = [(scene.extras.get("skipped_primitives", 0), "point/line primitives skipped"),
               (scene.extras.get("degenerate_triangles", 0), "degenerate triangles skipped")]
    return [f"{where}: {n} {what}" for n, what in counted if n] + list(scene.extras.get("warnings", []))


def _texels_per_atlas(patches: Patches, atlases: dict) -> list[int]:
    """How many texels of each atlas hold a patch (a surface covers them), atlas by atlas."""
    rows = patches.texel_y // atlases["height"]
    return np.bincount(rows, minlength=atlases["count"]).tolist()


def directional_images(scene: Scene, patches: Patches, points, fill: LightmapFill, gatherer: Gatherer,
                       solution: Solution, per_light: list[np.ndarray], rows: np.ndarray, mode: str,
                       advance) -> np.ndarray:
    """(H, W, C) the directional maps' values (radiosity/directional.py) of patches `rows`,
    filled as the lightmap is (`fill`); points: the direct stage's atlas.raster.TexelPoints."""
    sampled = gatherer.emitters is not None and gatherer.nee_samples > 0
    seen = solution.reflected if sampled else solution.excident
    sums = gather_directions(gatherer, seen, rows, advance)
    add_direct(sums, patches, scene.baked_lights, per_light)
    if sampled:
        side = math.isqrt(gatherer.nee_samples)
        add_emitters(sums, gatherer.emitters, patches, gatherer.tri_uv1, points, side, gatherer.offset,
                     gatherer.tracer, gatherer.seed)
    return fill.image(sums.lightmap_values(mode))


def _load_jit(cached: list[bool]) -> None:
    """`load_first_kernel` on a thread while the UVs are made (the main thread only waits for
    xatlas's child then), its answer appended to `cached`; the bake's own call of that kernel
    raises whatever this one meets."""
    try:
        cached.append(load_first_kernel())
    except Exception:
        pass


def _join_cluster(address: str | None):
    """The Ray cluster the gather runs on (joined before any work, so a bad address costs
    nothing), or None: the gather runs here."""
    if address is None:
        return None
    from .radiosity.cluster import RayCluster

    return RayCluster(address)


def bake(scene: Scene, settings: BakeSettings | None = None, quiet: bool = True) -> BakeResult:
    """Bake converged radiosity for `scene`; nothing is written (see `patchlight.bakedir.write_bake`)."""
    from .atlas.raster import TexelPoints, rasterize
    from .atlas.uvs import ensure_lightmap_uvs

    settings = settings or BakeSettings()
    settings.validate()
    _check_scene(scene)
    available = available_memory()  # read once, before the bake holds any of it
    cluster = _join_cluster(settings.ray)
    directional = bool(settings.directional)
    if settings.resolution is not None:
        check_bake_memory(settings.resolution, settings.resolution, available, directional)
    start = time.perf_counter()
    with Progress(quiet) as progress:
        with progress.stage("lightmap UVs"):
            cached = []  # did numba's cache hold the kernels (`load_first_kernel`)?
            loading = threading.Thread(target=_load_jit, args=(cached,), daemon=True)
            loading.start()
            scene, width, height, uv_info = ensure_lightmap_uvs(
                scene, texels_per_unit=settings.texels_per_unit, resolution=settings.resolution,
                padding=settings.padding, densities=settings.density, max_atlas=settings.max_atlas)
            loading.join()
        check_bake_memory(width, height, available, directional)
        with progress.stage("patches"):
            patches, _ = rasterize(scene, width, height)
        if len(patches) == 0:
            raise PatchlightError(f"{scene.label}: no lightmap texel is covered by a triangle")
        with progress.stage("tracer"):
            tracer = Tracer(scene.positions, scene.indices)
        size = settings.hemicube_size if settings.gather == "hemicube" else settings.rays
        gatherer = Gatherer(scene, patches, tracer, settings.gather, size, settings.seed)
        offset = gatherer.offset
        with progress.stage("direct light"):
            sun_angle = None if settings.sun_angle is None else np.radians(settings.sun_angle)
            lights = [[light] for light in scene.baked_lights] if settings.directional else [scene.baked_lights]
            points = TexelPoints(scene, patches)
            per_light = [texel_direct_light(points, patches, group,
                                            tracer, settings.falloff, sun_angle, settings.sun_samples, offset,
                                            settings.texel_samples) for group in lights]
            direct = per_light[0].copy() if per_light else np.zeros((len(patches), 3), np.float32)
            for more in per_light[1:]:  # in order, as np.sum over the lights would add them
                direct += more
            emitters = find_emitters(scene, patches)
            samples = samples_per_texel(settings.emitter_samples)
            if emitters is not None and samples > 0:
                side = math.isqrt(samples)
                direct += emitter_light(emitters, patches, gatherer.tri_uv1, points, side, offset, tracer,
                                        gatherer.rays_per_patch, settings.seed)
                gatherer.emitters, gatherer.nee_samples = emitters, samples
        rays_direct = tracer.rays_traced
        gatherer.cluster = cluster
        budget = form_factor_budget(width, height, settings.max_memory, available, directional)
        ff = FormFactors(gatherer, budget)
        gather_start = time.perf_counter()
        status, order, sampled = gather_adaptive(ff, patches, direct, settings, progress)
        gather_seconds = time.perf_counter() - gather_start
        inside = status == adaptive.INSIDE
        rays_before_walls = tracer.rays_traced
        walled = walled_inside(patches, inside, tracer, offset)
        rays_walls = tracer.rays_traced - rays_before_walls  # between texels found inside
        rays_in_gather = ff.rays + ff.rays_regathered + ff.rays_probed  # what the gather stage traced
        pass_incident = []
        with progress.stage("passes", total=settings.passes) as advance:
            def on_pass(k, change, half):
                advance(1, note=f"pass {k}: change {change:.2e}")
                pass_incident.append(half)

            solution = solve(ff, direct, patches.rho, patches.emission, status, order,
                             settings.passes, settings.tolerance, start=sampled, on_pass=on_pass)
        with progress.stage("lightmap"):
            incident = solution.incident
            if settings.denoise:
                incident = denoised_incident(patches, direct, solution.gathered, inside)
            fill = LightmapFill.of(patches, inside, walled)
            lightmap = fill.image(incident)
        images = [lightmap]
        if settings.directional:
            valid = np.flatnonzero(~inside)
            with progress.stage("directional", total=len(valid)) as advance:
                images.append(directional_images(scene, patches, points, fill, gatherer, solution, per_light,
                                                 valid, settings.directional, advance))
        seams = None
        if settings.stitch:
            with progress.stage("seams"):
                images, seams = stitch_seams(scene, patches, inside, images)
        lightmap = images[0]
        maps = split_maps(settings.directional, images[1]) if settings.directional else None
    counts = np.bincount(status, minlength=4)
    to_come = change_to_come(solution.changes)
    stats = {
        "resolution": [width, height],
        "atlases": {**uv_info["atlases"], "texels_used": _texels_per_atlas(patches, uv_info["atlases"])},
        "patches": len(patches),
        "computed_patches": int(counts[adaptive.COMPUTED]),
        "interpolated_patches": int(counts[adaptive.INTERPOLATED]),
        "inside_geometry_patches": int(counts[adaptive.INSIDE]),
        "walled_inside_patches": int(walled.sum()),
        "gather": settings.gather,
        "rays_per_patch": gatherer.rays_per_patch,
        "rays_traced": rays_direct + ff.rays_probed + ff.rays + ff.rays_regathered + rays_walls,
        "rays_direct": rays_direct,
        "rays_walls": rays_walls,
        "rays_probe": ff.rays_probed,
        "rays_gather": ff.rays,
        "rays_regather": ff.rays_regathered,
        "rays_per_second": rays_in_gather / max(gather_seconds, 1e-9),
        "lost_rays": ff.lost_rays,
        "form_factor_matrix": {"kept": ff.kept, "entries": ff.entries, "bytes": ff.nbytes, "budget": int(budget)},
        "memory": {"estimated_peak_bytes": estimate_peak_bytes(width, height, budget, directional),
                   "peak_resident_bytes": peak_resident_bytes()},
        "estimated_seconds": estimate_seconds(width, height, bool(settings.directional)),
        "passes": len(solution.changes),
        "pass_changes": solution.changes,
        "change_to_come": to_come if math.isfinite(to_come) else None,  # None: not known yet
        "converged": to_come < settings.tolerance,
        "seconds_per_stage": dict(progress.seconds),
        "cpu_utilisation_per_stage": progress.utilisation(),
        "seconds_total": time.perf_counter() - start,
        "uv": uv_info,
        "seams": seams,
        "ray": None if cluster is None else cluster.to_json(),
        "warnings": _input_warnings(scene) + list(uv_info.get("warnings", [])) + ([] if all(cached) else [COMPILED]),
    }
    return BakeResult(scene, patches, lightmap, status, solution, fill, stats, pass_incident, walled, maps)
