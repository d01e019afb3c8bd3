"""Radiosity ground maps for hemisphere lighting:
a top-down picture of the lit level that moving objects look up as their ground colour,
with static sun shadows folded in.

Stages (each timed): prepare (leave out high polygons, turn vertical ones up), look down
(one ray per texel, the bake's light at the hit), shadows (rays to the sun per texel),
encode (noise, shadow amount, one of three encodings), then `write_groundmap` writes the
files (files.py). The first two need only the level's geometry: `plan_groundmap` runs them
on a scene before it is baked, so a map that cannot be made (an area with no ground under
it) is refused before the bake, and `make_groundmap` reuses the plan when the baked scene
has the same triangles.

The settings (GroundMapSettings) are declared with their units and ranges on the fields.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import bakedir
from ..config import setting, validate_fields
from ..errors import PatchlightError, SettingError
from ..rays.tracer import Tracer
from ..scene.model import Scene
from ..shading.hemisphere_radiosity import OFFSET_MODES
from ..solved import SolvedScene
from . import encode as enc
from ..imaging.io import write_png
from ..outputs import staged_output
from .files import FORMAT, VERSION, to_bytes, write_manifest, write_map_files
from .mapping import MAX_SIZE, GroundArea, square_area
from .picture import Footprint, cast_down, look_down, sun_shadow, the_sun
from .prepare import MapGeometry, ground_below, prepare_map_geometry

SIDE_VECTOR = ("the moving object's local +X axis (glTF: +Y up, the front faces +Z) in world space, unit "
               "length; mode side moves the sample point by offset x (N . side) side, mode normal by "
               "offset x N (Listing 1 keeps the offset in the vector's length: VS_RADIOSITY_SIDE = "
               "sqrt(offset) x side)")
STALE_FILES = ("shadow.png", "shadow.dds", "variant_*.png")  # an older map's files the new one may lack
NO_BAKE = ("no bake recorded (written from Python without bake_dir or bake): `patchlight render` and `view` "
           "cannot show this map; write it again with write_groundmap(..., bake_dir=DIR) or bake=(result, "
           "settings), or with `patchlight groundmap`")
MAPPING_NOTE = ("u = U . (x, y, z, 1), v = V . (x, y, z, 1); +X to the right, +Z down the picture, "
                "v = 0 is the image's top row (glTF's UV convention); texels are linear, value 1 = map_scale")


@dataclass
class GroundMapSettings:
    """What map is made, and what its json tells the runtime (table: docs/settings.md)."""

    size: int = setting(1024, "texels", "map width = height", lo=1, hi=MAX_SIZE, whole=True, typical="512-2048")
    area: GroundArea | None = setting(None, "m", "x0, z0, x1, z1 covered by the map", none="the level, squared")
    max_height: float = setting(3.0, "m", "leave out polygons higher above the ground", lo=0, lo_open=True,
                                typical="2-5")
    noise: float = setting(0.1, "ratio", "random texel noise, per channel", lo=0.0, hi=1.0, typical="0.1")
    shadows: str = setting("hsv", "", "the sun's shadows: a separate map, in alpha, or folded into one RGB map "
                           "(encode.py)", choices=enc.ENCODINGS)
    seed: int = setting(1, "int", "the noise's seed", lo=0, whole=True)
    offset: float = setting(1.0, "m", "runtime sample offset distance, recorded in the json", lo=0.0, typical="1")
    offset_mode: str = setting("normal", "", "runtime offset mode, recorded in the json: along the normal, its "
                               "left-right part only, or none", choices=OFFSET_MODES)
    sun_angle: float | None = setting(None, "degrees", "the sun's angular diameter (0 = hard shadows)", lo=0, hi=90,
                                      hi_open=True, typical="0.53 (the real sun)", none="the bake's, else the light's")

    def validate(self) -> None:
        validate_fields(self)
        area = self.area
        if area is not None and not (area.x1 > area.x0 and area.z1 > area.z0):
            raise SettingError("area", tuple(area.to_json()), "needs X1 > X0 and Z1 > Z0")


@dataclass
class GroundMap:
    """A baked ground map. encoded: the texels (encode.EncodedMap); area; sky_light (3,)
    the sky's incident light on an up-facing patch (radiance); sun: (direction (3,),
    I_sun on the ground (3,)) or None; shadowed: share of covered texels in shadow;
    coverage: share of texels with a surface under them; seconds per stage; warnings;
    bake_dir: the bake directory (absolute) the solved scene was read from, or None; and
    what any encoding is made from: excident B, unshadowed B_u (H, W, 3) with noise, shadow
    amount s and covered (H, W); path (K, 3): the loop the viewer's cars drive, the scene's
    extras["path"] or `car_loop`."""

    encoded: enc.EncodedMap
    area: GroundArea
    settings: GroundMapSettings
    sky_light: np.ndarray
    sun: tuple | None
    shadowed: float
    coverage: float
    excident: np.ndarray
    unshadowed: np.ndarray
    shadow: np.ndarray
    covered: np.ndarray
    path: np.ndarray | None = None
    seconds: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    bake_dir: str | None = None  # the bake directory the solved scene was read from (absolute), if any

    def encode(self, encoding: str) -> enc.EncodedMap:
        """The same map in another encoding."""
        return enc.encode(encoding, self.excident, self.unshadowed, self.shadow, self.covered, self.sky_light)


def _sky_light(solved: SolvedScene, excident: np.ndarray, covered: np.ndarray, warnings: list) -> np.ndarray:
    """(3,) incident light from the sky on an unoccluded up-facing patch; without a sky the
    map's mean radiance (so the sky term is neutral), with a warning."""
    from ..shading.environment import sky_incident

    sky = solved.scene.sky
    if sky is not None and not sky.is_black():
        return sky_incident(sky)[0]
    warnings.append(f"{solved.source}: no sky; the sky colour is taken as the map's mean radiance")
    return excident[covered].mean(axis=0).astype(np.float32)


@dataclass
class GroundPlan:
    """What a map needs of the level's geometry alone (`plan_groundmap`): the area, the map
    geometry (prepare.py), where each texel's ray lands (picture.Footprint), the share of
    covered texels, and what it was made from (settings, the scene's triangle corners (T, 3, 3))
    so `make_groundmap` reuses it only for the same level and settings."""

    area: GroundArea
    where: str
    geometry: MapGeometry
    footprint: Footprint
    coverage: float
    settings: GroundMapSettings
    triangles: np.ndarray
    seconds: dict = field(default_factory=dict)

    def fits(self, scene: Scene, settings: GroundMapSettings) -> bool:
        """This plan is the one plan_groundmap(scene, settings) would make."""
        s = self.settings
        return ((s.size, s.area, s.max_height) == (settings.size, settings.area, settings.max_height)
                and np.array_equal(self.triangles, scene.triangle_vertices()))


def plan_groundmap(scene: Scene, settings: GroundMapSettings | None = None) -> GroundPlan:
    """Check the settings and prepare the map of `scene`, lit or not: prepare its geometry and
    cast the downward rays. PatchlightError, before any light is needed, when no ground lies
    under the area."""
    settings = settings or GroundMapSettings()
    settings.validate()
    seconds: dict[str, float] = {}
    lo, hi = scene.bounds()
    area = settings.area or square_area(lo, hi)
    where = f"`area` {','.join(f'{v:g}' for v in area.to_json())}" if settings.area else scene.label

    clock = time.perf_counter()
    geometry = prepare_map_geometry(scene, settings.max_height)
    seconds["prepare"] = time.perf_counter() - clock

    clock = time.perf_counter()
    footprint = cast_down(geometry, area, settings.size)
    seconds["look down"] = time.perf_counter() - clock
    if not footprint.covered.any():
        raise PatchlightError(f"{where}: no ground under the area (no upward-facing surface within "
                              f"{settings.max_height:g} m of the ground lies in x {area.x0:g}..{area.x1:g}, "
                              f"z {area.z0:g}..{area.z1:g}; the level spans x {lo[0]:g}..{hi[0]:g}, "
                              f"z {lo[2]:g}..{hi[2]:g})")
    return GroundPlan(area, where, geometry, footprint, float(footprint.covered.mean()), settings,
                      scene.triangle_vertices(), seconds)


def make_groundmap(solved: SolvedScene, settings: GroundMapSettings | None = None,
                   plan: GroundPlan | None = None) -> GroundMap:
    """Bake the ground map of a solved scene (module docstring). Nothing is written. plan: the
    scene's plan_groundmap, made before its bake; used when it fits the solved scene and these
    settings, else the plan is made again."""
    settings = settings or GroundMapSettings()
    settings.validate()
    scene = solved.scene
    if plan is None or not plan.fits(scene, settings):
        plan = plan_groundmap(scene, settings)
    seconds = dict(plan.seconds)
    warnings: list[str] = []
    lo, hi = scene.bounds()
    area, where, geometry = plan.area, plan.where, plan.geometry
    if plan.coverage < 1.0:
        warnings.append(f"{where}: {100 * (1 - plan.coverage):.1f}% of the map has no surface under it (black texels)")

    clock = time.perf_counter()
    picture = look_down(solved, plan.footprint)
    covered = picture.covered
    seconds["look down"] += time.perf_counter() - clock

    clock = time.perf_counter()
    sun = the_sun(scene.lights)
    excident = picture.excident
    if sun is None:
        warnings.append(f"{scene.label}: no sun (directional light), so no static shadows")
        unshadowed = excident
        sun_info = None
    else:
        lift = max(1e-4 * float(np.max(hi - lo)), 1e-3)
        above = np.array([(area.x0 + area.x1) / 2, float(hi[1]) + 1.0, (area.z0 + area.z1) / 2])
        sun_angle = None if settings.sun_angle is None else np.radians(settings.sun_angle)
        blocked, sun_ground = sun_shadow(Tracer(scene.positions, scene.indices), picture.ground, sun, lift, above,
                                         sun_angle)
        unshadowed = excident + picture.reflectance * blocked
        sun_info = (np.asarray(sun.direction, np.float32), sun_ground)
    shadow = np.where(covered, enc.shadow_amount(excident, unshadowed), 1.0).astype(np.float32)
    seconds["shadows"] = time.perf_counter() - clock

    clock = time.perf_counter()
    noise_seed = settings.seed
    excident = enc.add_noise(excident, settings.noise, noise_seed)
    unshadowed = enc.add_noise(unshadowed, settings.noise, noise_seed)
    sky_light = _sky_light(solved, excident, covered, warnings)
    encoded = enc.encode(settings.shadows, excident, unshadowed, shadow, covered, sky_light)
    seconds["encode"] = time.perf_counter() - clock
    shadowed = float(np.mean(shadow[covered] < enc.UNSHADOWED))
    path = scene.extras.get("path") if isinstance(scene.extras, dict) else None
    path = car_loop(geometry, area) if path is None else np.asarray(path, np.float64)
    bake_dir = str(Path(solved.source).resolve()) if bakedir.is_bake_dir(solved.source) else None
    return GroundMap(encoded, area, settings, np.asarray(sky_light, np.float32), sun_info, shadowed, plan.coverage,
                     excident, unshadowed, shadow, covered, path, seconds, warnings, bake_dir)


def car_loop(geometry, area: GroundArea, points: int = 96) -> np.ndarray:
    """(points, 3) the closed loop the viewer's cars drive when the scene names none (its
    extras["path"]): an ellipse over the middle of the map, at the height of the ground beneath
    (0 where there is none)."""
    t = np.linspace(0, 2 * np.pi, points, endpoint=False)
    cx, cz = (area.x0 + area.x1) / 2, (area.z0 + area.z1) / 2
    rx, rz = 0.3 * (area.x1 - area.x0), 0.3 * (area.z1 - area.z0)
    loop = np.stack([cx + rx * np.cos(t), np.zeros_like(t), cz + rz * np.sin(t)], axis=1)
    floor_y = float(geometry.flat_positions[:, 1].min()) - 1.0 if len(geometry.flat_positions) else 0.0
    heights = ground_below(MapGeometry.tracer(geometry.flat_positions), loop, floor_y)
    loop[:, 1] = np.nan_to_num(heights, nan=0.0)
    return loop


def write_groundmap(ground_map: GroundMap, out_dir, source: str, bake_dir: str | None = None,
                    bake: tuple | None = None) -> dict:
    """Write the map files (files.py: the map in its encoding as PNG and DDS, the other two
    encodings as PNG) and groundmap.json into out_dir, as one set: staged, then moved in with
    groundmap.json last, so a reader never meets a manifest naming missing or older files.
    Returns the manifest.

    Which bake the manifest names (`patchlight render` and `view` show the map over it):
    bake_dir, the bake it came from (relative to out_dir, or absolute); else, with bake, a
    (BakeResult, BakeSettings) made in memory, that bake written into out_dir in the same set
    (staged with the map's files; bake.json and groundmap.json removed first and moved in
    last, in that order); else the bake directory the solved scene was read from, if any. With none,
    the manifest names no bake and says so in its warnings: the map's files serve an engine,
    but render and view refuse the directory."""
    if bake_dir is not None and bake is not None:
        raise ValueError("write_groundmap: give bake_dir or bake, not both")
    clock = time.perf_counter()
    e = ground_map.encoded
    out_dir = Path(out_dir)
    warnings = list(ground_map.warnings)
    if bake is not None:
        bake_dir = "."
    elif bake_dir is None and ground_map.bake_dir is not None:
        bake_dir = os.path.relpath(ground_map.bake_dir, out_dir.resolve())
    elif bake_dir is None:
        warnings.append(NO_BAKE)
    stale = STALE_FILES + (bakedir.STALE if bake is not None else ())
    with staged_output(out_dir, stale=stale) as staging:
        files = {"color": write_map_files(staging, "groundmap", to_bytes(e.color))}
        if e.shadow is not None:
            files["shadow"] = write_map_files(staging, "shadow", _grey(e.shadow))
        variants = {}
        for encoding in enc.ENCODINGS:
            if encoding != e.encoding:
                variants[encoding] = _write_variant(staging, ground_map.encode(encoding))
        ground_map.seconds["write"] = time.perf_counter() - clock
        manifest = _manifest(ground_map, source, bake_dir, files, variants, warnings)
        write_manifest(staging, manifest)
        if bake is not None:
            bakedir.stage_bake(bake[0], staging, out_dir, bake[1])
    return manifest


def _grey(shadow: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 grey picture of a shadow amount (H, W) in [0, 1]."""
    return to_bytes(np.repeat(shadow[..., None], 3, axis=-1))


def _write_variant(out_dir: Path, encoded: enc.EncodedMap) -> dict:
    """variant_<encoding>.png (and the separate encoding's shadow) and its manifest entry."""
    stem = f"variant_{encoded.encoding}"
    write_png(out_dir / f"{stem}.png", to_bytes(encoded.color))
    files = {"color": {"png": f"{stem}.png"}}
    if encoded.shadow is not None:
        write_png(out_dir / f"{stem}_shadow.png", _grey(encoded.shadow))
        files["shadow"] = {"png": f"{stem}_shadow.png"}
    return {"files": files, "map_scale": encoded.map_scale, "sky_scale": encoded.sky_scale}


def _manifest(ground_map: GroundMap, source: str, bake_dir: str | None, files: dict, variants: dict,
              warnings: list) -> dict:
    e = ground_map.encoded
    s = ground_map.settings
    return {
        "format": FORMAT,
        "version": VERSION,
        "source": source,
        "bake": bake_dir,
        "size": s.size,
        "area": ground_map.area.to_json(),
        "mapping": {"U": ground_map.area.U, "V": ground_map.area.V, "note": MAPPING_NOTE},
        "encoding": e.encoding,
        "files": files,
        "color_space": "linear",
        "map_scale": e.map_scale,
        "sky_scale": e.sky_scale,
        "sky_light": ground_map.sky_light,
        "variants": variants,
        "offset": s.offset,
        "offset_mode": s.offset_mode,
        "side_vector": SIDE_VECTOR,
        "max_height": s.max_height,
        "noise": s.noise,
        "seed": s.seed,
        "sun_angle": s.sun_angle,
        "sun": None if ground_map.sun is None else {"direction": ground_map.sun[0], "on_ground": ground_map.sun[1]},
        "shadowed_fraction": ground_map.shadowed,
        "coverage": ground_map.coverage,
        "path": ground_map.path,
        "seconds_per_stage": ground_map.seconds,
        "warnings": warnings,
    }
