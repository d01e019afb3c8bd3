"""The bake pipeline: Scene -> atlas -> patches -> direct -> gather -> passes -> lightmap.

Each stage is a function of arrays (docs/architecture.md); this module only strings them
together, times them, and writes the results. The CLI and the Python API both call `bake`.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .atlas.patches import Patches
from .config import BakeSettings
from .errors import PatchlightError
from .limits import available_memory
from .progress import Progress
from .radiosity import adaptive
from .radiosity.direct import direct_light
from .radiosity.directional import add_direct, gather_directions, split_maps
from .radiosity.emitters import emitter_light, find_emitters, two_sided_triangles
from .radiosity.gather import Gatherer
from .radiosity.memory import check_bake_memory, form_factor_budget
from .radiosity.solve import FormFactors, Solution, change_to_come, solve
from .rays.tracer import Tracer
from .scene.model import Scene
from .shading.directional import DirectionalLightmap
from .texels import TEXELS_FILE, Texels

FLOAT32_REACH = 1e-5        # relative lift that clears float32 rounding of hit points (2^-24 ~ 6e-8)
INSIDE_BACK_FRACTION = 0.5  # a patch whose rays mostly hit back faces lies inside geometry
PROBE_BACK_FRACTION = 0.7   # ... and one whose 16 probe rays are 12 or more on back faces needs
                            # no gather to tell (the gather decides the borderline rest)
DILATE_TEXELS = 4           # rings grown past chart borders so bilinear filtering never reads black
REFINE_TOLERANCE = 1e-2     # each run of the sampler starts on a solution converged well inside
REFINE_FIRST_PASSES = 100   # its 2-8 % thresholds (at most this many passes), then updates it,
REFINE_PASSES = 2           # warm-started, by a couple of passes per phase


@dataclass
class BakeResult:
    """lightmap: (H, W, 3) f32 incident light, dilated. patches, status (N,) sampler state,
    solution, the (possibly re-indexed) scene with its lightmap UVs, stats for bake.json,
    pass_incident: each pass's incident light (N, 3) float16, and directional: the directional
    lightmap (`BakeSettings.directional`) or None."""

    scene: Scene
    patches: Patches
    lightmap: np.ndarray
    status: np.ndarray
    solution: Solution
    stats: dict = field(default_factory=dict)
    pass_incident: list = field(default_factory=list)
    directional: DirectionalLightmap | None = None

    def pass_images(self) -> list[np.ndarray]:
        """Each pass's lightmap (H, W, 3) f32, filled and dilated as `lightmap` is."""
        return [fill_lightmap(self.patches, I, self.status) for I in self.pass_incident]

    def texels(self) -> Texels:
        """The per-texel arrays of texels.npz."""
        p = self.patches
        return Texels(np.stack(self.pass_images()).astype(np.float16), p.to_image(self.status),
                      p.to_image(p.chart, fill=-1), p.to_image(p.rho), p.to_image(p.emission),
                      p.to_image(self.solution.excident.astype(np.float32)))


def _check_scene(scene: Scene) -> None:
    scene.validate()
    if not scene.has_light():
        kept = " (the lights kept dynamic are not baked)" if len(scene.baked_lights) < len(scene.lights) else ""
        raise PatchlightError(f"{scene.label}: nothing lights the scene{kept} "
                              "(no sun, no lamp, no emissive material, no sky); add one or pass --sky R,G,B")


def _input_warnings(scene: Scene) -> list[str]:
    """One line per thing the importer left out or ignored."""
    where = scene.label
    counted = [(scene.extras.get("skipped_primitives", 0), "point/line primitives skipped"),
               (scene.extras.get("degenerate_triangles", 0), "degenerate triangles skipped")]
    return [f"{where}: {n} {what}" for n, what in counted if n] + list(scene.extras.get("warnings", []))


def _tri_uv1(scene: Scene) -> np.ndarray:
    return np.ascontiguousarray(scene.uv1[scene.indices], np.float32)


def ray_offsets(scene: Scene, patches: Patches) -> np.ndarray:
    """(N,) distance to lift ray origins off each patch: a twentieth of its texel, and never
    less than float32's reach where the patch lies (FLOAT32_REACH of its largest coordinate,
    over a hundred float32 steps, plus a millionth of the scene's size)."""
    lo, hi = scene.bounds()
    reach = FLOAT32_REACH * np.abs(patches.position).max(axis=1) + 1e-6 * float(np.max(hi - lo))
    return np.maximum(0.05 * patches.size, reach).astype(np.float32)


def _gather_adaptive(ff: FormFactors, patches: Patches, direct: np.ndarray, settings: BakeSettings,
                     progress: Progress):
    """Run the adaptive sampler, first at settings.first_accuracy, then at settings.accuracy
    (adaptive.py); returns (status, order): the sampler's interpolation order."""
    n = len(patches)
    status = np.zeros(n, np.int8)
    if settings.adaptive:
        grid, phases = adaptive.sampler_plan(patches)
    else:
        grid, phases = np.arange(n), []
    order = adaptive.flatten(phases)
    with progress.stage("gather", total=n) as advance:
        _compute(ff, grid, status, advance)
        B = None
        for accuracy in (settings.first_accuracy, settings.accuracy) if phases else ():
            adaptive.reopen(status)
            for k, phase in enumerate(phases):
                passes = REFINE_FIRST_PASSES if k == 0 else REFINE_PASSES
                solution = solve(ff, direct, patches.rho, patches.emission, status, order,
                                 passes, max(settings.tolerance, REFINE_TOLERANCE), B)
                B, G = solution.excident, solution.gathered
                for step in phase:
                    _compute(ff, adaptive.decide(step, status, G, accuracy), status, advance)
    return status, order


def _compute(ff: FormFactors, rows: np.ndarray, status: np.ndarray, advance) -> None:
    """Gather patches `rows`, but for those a probe or their own gather finds inside geometry."""
    inside = ff.probe_inside(rows, PROBE_BACK_FRACTION)
    status[rows[inside]] = adaptive.INSIDE
    advance(int(inside.sum()))
    rows = rows[~inside]
    status[rows] = adaptive.COMPUTED
    back = ff.add(rows.astype(np.int64), progress=advance)
    status[rows[back > INSIDE_BACK_FRACTION]] = adaptive.INSIDE


def fill_lightmap(patches: Patches, incident: np.ndarray, status: np.ndarray) -> np.ndarray:
    """(H, W, 3) lightmap: texels inside geometry next to valid ones filled from them (up to
    DILATE_TEXELS rings deep, so bilinear filtering at a joint reads no darkness; deeper ones
    stay black), then grown past chart borders by DILATE_TEXELS rings."""
    from .imaging.dilate import dilate

    image = patches.to_image(incident.astype(np.float32))
    covered = patches.index >= 0
    valid = covered & (patches.to_image(status, fill=adaptive.INSIDE) != adaptive.INSIDE)
    image, valid = dilate(image, valid, texels=DILATE_TEXELS, allowed=covered)
    image[covered & ~valid] = 0.0
    image, _ = dilate(image, covered, texels=DILATE_TEXELS)
    return image


def directional_images(scene: Scene, patches: Patches, status: np.ndarray, gatherer: Gatherer, solution: Solution,
                       per_light: list[np.ndarray], rows: np.ndarray, mode: str, advance) -> np.ndarray:
    """(H, W, C) the directional maps' values (radiosity/directional.py) of patches `rows`,
    filled as the lightmap is."""
    sums = gather_directions(gatherer, solution.excident, rows, advance)
    add_direct(sums, patches, scene.baked_lights, per_light)
    return fill_lightmap(patches, sums.lightmap_values(mode), status)


def stitch_seams(scene: Scene, patches: Patches, status: np.ndarray, images: list[np.ndarray]) -> tuple[list, dict]:
    """The lightmap-space images with their UV chart seams stitched (imaging/stitch.py; texels
    inside geometry and outside the charts only follow), and the seams' relative differences
    before and after (median, p90, max over points every half texel) for bake.json."""
    from .atlas.seams import seam_edges
    from .imaging.stitch import seam_differences, stitch

    uv_a, uv_b = seam_edges(scene.positions, scene.normals, scene.indices, scene.uv1)
    valid = (patches.index >= 0) & (patches.to_image(status, fill=adaptive.INSIDE) != adaptive.INSIDE)
    stitched = [stitch(image, uv_a, uv_b, valid) for image in images]

    def summary(image):
        d = seam_differences(image, uv_a, uv_b)
        return {"median": float(np.median(d)), "p90": float(np.percentile(d, 90)), "max": float(d.max())} if len(d) \
            else {"median": 0.0, "p90": 0.0, "max": 0.0}

    return stitched, {"edges": len(uv_a), "before": summary(images[0]), "after": summary(stitched[0])}


def denoised_incident(patches: Patches, direct: np.ndarray, gathered: np.ndarray, status: np.ndarray) -> np.ndarray:
    """(N, 3) incident light with only its gathered part denoised (by OIDN, chart by chart):
    ray-traced direct light and its sharp shadows stay as they are."""
    from .imaging.denoise import denoise_lightmap

    inside = status == adaptive.INSIDE
    charts = patches.to_image(np.where(inside, -1, patches.chart).astype(np.int32), fill=-1)
    clean = denoise_lightmap(patches.to_image(gathered.astype(np.float32)), charts)
    incident = direct + clean[patches.texel_y, patches.texel_x]
    incident[inside] = 0.0
    return incident


def _join_cluster(address: str | None):
    """The Ray cluster the gather runs on (joined before any work, so a bad address costs
    nothing), or None: the gather runs here."""
    if address is None:
        return None
    from .radiosity.cluster import RayCluster

    return RayCluster(address)


def bake(scene: Scene, settings: BakeSettings | None = None, quiet: bool = True) -> BakeResult:
    """Bake converged radiosity for `scene`; nothing is written (see `write_bake`)."""
    from .atlas.raster import rasterize, texel_points
    from .atlas.uvs import ensure_lightmap_uvs

    settings = settings or BakeSettings()
    settings.validate()
    _check_scene(scene)
    available = available_memory()  # read once, before the bake holds any of it
    cluster = _join_cluster(settings.ray)
    if settings.resolution is not None:
        check_bake_memory(settings.resolution, settings.resolution, settings.texel_samples, available)
    start = time.perf_counter()
    with Progress(quiet) as progress:
        with progress.stage("lightmap UVs"):
            scene, width, height, uv_info = ensure_lightmap_uvs(
                scene, texels_per_unit=settings.texels_per_unit, resolution=settings.resolution,
                padding=settings.padding, densities=settings.density)
        check_bake_memory(width, height, settings.texel_samples, available)
        with progress.stage("patches"):
            patches, _ = rasterize(scene, width, height)
        if len(patches) == 0:
            raise PatchlightError(f"{scene.label}: no lightmap texel is covered by a triangle")
        with progress.stage("tracer"):
            tracer = Tracer(scene.positions, scene.indices)
        offset = ray_offsets(scene, patches)
        size = settings.hemicube_size if settings.gather == "hemicube" else settings.rays
        gatherer = Gatherer(patches, _tri_uv1(scene), two_sided_triangles(scene), tracer, scene.sky, settings.gather,
                            size, offset, settings.seed)
        with progress.stage("direct light"):
            sun_angle = None if settings.sun_angle is None else np.radians(settings.sun_angle)
            points = texel_points(scene, patches, settings.texel_samples)
            lights = [[light] for light in scene.baked_lights] if settings.directional else [scene.baked_lights]
            per_light = [direct_light(points, patches.normal, group, tracer, settings.falloff, sun_angle,
                                      settings.sun_samples, offset) for group in lights]
            direct = np.sum(per_light, axis=0, dtype=np.float32) if per_light else np.zeros((len(patches), 3), np.float32)
            emitters = find_emitters(scene, patches)
            side = math.isqrt(settings.emitter_samples)
            if emitters is not None and side > 0:
                direct += emitter_light(emitters, patches, gatherer.tri_uv1, texel_points(scene, patches, side), offset,
                                        tracer, gatherer.rays_per_patch, settings.seed)
                gatherer.emitters, gatherer.nee_samples = emitters, side * side
        rays_direct = tracer.rays_traced
        gatherer.cluster = cluster
        budget = form_factor_budget(width, height, settings.max_memory, settings.texel_samples, available)
        ff = FormFactors(gatherer, budget)
        gather_start = time.perf_counter()
        status, order = _gather_adaptive(ff, patches, direct, settings, progress)
        gather_seconds = time.perf_counter() - gather_start
        rays_in_gather = ff.rays + ff.rays_regathered + ff.rays_probed  # what the gather stage traced
        pass_incident = []
        with progress.stage("passes", total=settings.passes) as advance:
            def on_pass(k, change, incident):
                advance(1, note=f"pass {k}: change {change:.2e}")
                pass_incident.append(incident.astype(np.float16))

            solution = solve(ff, direct, patches.rho, patches.emission, status, order,
                             settings.passes, settings.tolerance, on_pass=on_pass)
        with progress.stage("lightmap"):
            incident = solution.incident
            if settings.denoise:
                incident = denoised_incident(patches, direct, solution.gathered, status)
            lightmap = fill_lightmap(patches, incident, status)
        images = [lightmap]
        if settings.directional:
            valid = np.flatnonzero(status != adaptive.INSIDE)
            with progress.stage("directional", total=len(valid)) as advance:
                images.append(directional_images(scene, patches, status, gatherer, solution, per_light, valid,
                                                 settings.directional, advance))
        seams = None
        if settings.stitch:
            with progress.stage("seams"):
                images, seams = stitch_seams(scene, patches, status, images)
        lightmap = images[0]
        directional = split_maps(settings.directional, images[1]) if settings.directional else None
    counts = np.bincount(status, minlength=4)
    to_come = change_to_come(solution.changes)
    stats = {
        "resolution": [width, height],
        "patches": len(patches),
        "computed_patches": int(counts[adaptive.COMPUTED]),
        "interpolated_patches": int(counts[adaptive.INTERPOLATED]),
        "inside_geometry_patches": int(counts[adaptive.INSIDE]),
        "gather": settings.gather,
        "rays_per_patch": gatherer.rays_per_patch,
        "rays_traced": rays_direct + ff.rays_probed + ff.rays + ff.rays_regathered,
        "rays_direct": rays_direct,
        "rays_probe": ff.rays_probed,
        "rays_gather": ff.rays,
        "rays_regather": ff.rays_regathered,
        "rays_per_second": rays_in_gather / max(gather_seconds, 1e-9),
        "lost_rays": ff.lost_rays,
        "form_factor_matrix": {"kept": ff.kept, "nonzeros": ff.nnz, "bytes": ff.nbytes, "budget": int(budget)},
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
        "warnings": _input_warnings(scene) + list(uv_info.get("warnings", [])),
    }
    return BakeResult(scene, patches, lightmap, status, solution, stats, pass_incident, directional)


BAKE_MARKER = "bake.json"          # written last: a directory is a bake only with it
BAKE_STALE = ("pass_*.png", "lightmap_sh.exr", "lightmap_dir.exr")  # an older bake's files a new one need not write


def write_bake(result: BakeResult, out_dir: Path, settings: BakeSettings) -> dict:
    """Write lightmap.exr, lightmap.png, adaptive.png, texels.npz, scene.glb, bake.json (and
    the pass pictures) into out_dir as one set (`patchlight.outputs.staged_output`: swapped in whole,
    in one atomic step); returns the summary that bake.json holds."""
    from .outputs import staged_output

    with staged_output(out_dir, stale=BAKE_STALE) as staging:
        return stage_bake(result, staging, out_dir, settings)


def stage_bake(result: BakeResult, staging: Path, out_dir: Path, settings: BakeSettings) -> dict:
    """Write a bake's files into the staging directory of a `staged_output` into out_dir whose
    stale globs include BAKE_STALE; returns the summary."""
    from .imaging.exposure import auto_exposure, exposed_png_pixels
    from .imaging.io import write_bytes, write_exr, write_json, write_png
    from .imaging.lightmap import encode_lightmap
    from .scene.gltf import save_baked_glb

    k = auto_exposure(result.lightmap) if settings.exposure == "auto" else float(settings.exposure)
    pictures = {"lightmap.png": exposed_png_pixels(result.lightmap, k),
                "adaptive.png": adaptive.debug_image(result.patches, result.status)}
    if settings.save_passes:
        pictures.update({f"pass_{i:02d}.png": exposed_png_pixels(image, k)
                         for i, image in enumerate(result.pass_images(), start=1)})
    meta = {"quantity": "incident light I (cosine-weighted mean radiance) = texel x scale", "exposure": k}
    extra = [] if result.directional is None else [result.directional.file_name]
    names = sorted(["lightmap.exr", "scene.glb", TEXELS_FILE, BAKE_MARKER, *pictures, *extra])
    sky = result.scene.sky
    summary = {"scene": result.scene.source, "settings": settings.to_json(), "exposure": k,
               "sky": None if sky is None else sky.to_json(),
               **result.stats, "files": names}
    write_exr(staging / "lightmap.exr", result.lightmap)
    if result.directional is not None:
        result.directional.save(staging)
    write_bytes(staging / TEXELS_FILE, result.texels().to_bytes())
    for name, pixels in pictures.items():
        write_png(staging / name, pixels)
    save_baked_glb(result.scene, staging / "scene.glb", encode_lightmap(result.lightmap), meta, folder=out_dir)
    write_json(staging / BAKE_MARKER, summary)
    return summary
