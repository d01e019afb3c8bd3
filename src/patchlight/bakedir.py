"""The bake directory: the one owner of its file names and of reading and writing them.

A bake directory (written by `patchlight bake` or `write_bake`) holds

    lightmap.exr    float32 incident light I (H, W, 3), row 0 = v 0; its alpha channel the
                    validity: 1 for texels with light of their own (a patch on a visible
                    surface, computed or interpolated), 0 inside geometry and in the padding
    scene.glb       the scene with its lightmap UVs in TEXCOORD_1, the lightmap textures
                    (MOZ_lightmap) and the directional lightmap, if any
                    (PATCHLIGHT_lightmap_directional; patchlight.scene.gltf)
    lightmap.png    the lightmap exposed for display (sRGB)
    adaptive.png    the adaptive sampler's decisions (radiosity.adaptive.debug_image)
    texels.npz      every pass and the per-texel arrays the viewer reads (Texels below)
    pass_NN.png     the lightmap after each pass (save_passes)
    lightmap_sh.exr or lightmap_dir.exr
                    the directional lightmap, if the bake made one (directional;
                    shading.directional: layers L0, L1x, L1y, L1z of RGB, or the dominant
                    direction as RGB)
    bake.json       the summary: settings, sky, statistics, the atlases, the list of files

written as one set: staged, then swapped in whole (patchlight.outputs.staged_output), so a
reader never meets a mixture of two bakes; files of an older bake that a new one need not
write are removed (STALE). A directory is a (complete) bake only with bake.json.

A bake of several atlases (`--max-atlas`) writes each atlas's maps as files of their own,
lightmap_0.exr, lightmap_1.exr, ... (and lightmap_sh_0.exr, ...: `atlas_files`); bake.json's
"atlases" gives their count, size and files. The pictures (lightmap.png, adaptive.png,
pass_NN.png) and texels.npz hold the atlases stacked top to bottom, as the bake works on
them (`scene.model.stacked_uv1`); the readers here stack the files the same way.
"""
from __future__ import annotations

import zipfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from .errors import PatchlightError

MARKER = "bake.json"          # a directory is a bake only with it
LIGHTMAP = "lightmap.exr"
SCENE = "scene.glb"
LIGHTMAP_PICTURE = "lightmap.png"
ADAPTIVE_PICTURE = "adaptive.png"
DIRECTIONAL = {"sh": "lightmap_sh.exr", "dominant": "lightmap_dir.exr"}  # by DirectionalLightmap.mode
STALE = ("pass_*.png", "lightmap*.exr")  # an older bake's files a new one need not write
TEXELS = "texels.npz"
REQUIRED = (SCENE, MARKER)  # and the lightmap: LIGHTMAP, or atlas_files(LIGHTMAP, n)
STATUS_NAMES = ("uncovered", "gathered", "interpolated", "inside geometry")  # texels.npz's status


def pass_picture(number: int) -> str:
    """The file name of the lightmap after pass `number` (1, 2, ...)."""
    return f"pass_{number:02d}.png"


def atlas_files(name: str, count: int) -> list[str]:
    """The files of a map `name` (LIGHTMAP, a DIRECTIONAL name) in a bake of `count` atlases:
    the name itself for one, else "lightmap_0.exr", "lightmap_1.exr", ..."""
    if count == 1:
        return [name]
    stem, dot, suffix = name.rpartition(".")
    return [f"{stem}_{k}{dot}{suffix}" for k in range(count)]


def is_bake_dir(path: str | Path) -> bool:
    """A complete bake: scene.glb, the lightmap (lightmap.exr, or lightmap_0.exr ...) and
    bake.json, which is written last. A built-in scene's name is never a bake directory."""
    from .scene import is_builtin

    p = Path(path)
    return (not is_builtin(path) and p.is_dir() and all((p / name).exists() for name in REQUIRED)
            and any((p / atlas_files(LIGHTMAP, n)[0]).exists() for n in (1, 2)))


def require_bake_dir(path: str | Path) -> Path:
    """`path` as a complete bake directory, else a one-line PatchlightError."""
    if not is_bake_dir(path):
        raise PatchlightError(f"{path}: not a complete bake (a directory is not a bake without "
                              f"{SCENE}, {LIGHTMAP} and {MARKER})")
    return Path(path)


def atlas_count(path: str | Path) -> int:
    """How many atlases the bake in `path` has (bake.json's "atlases"; 1 for a bake without,
    or for a folder without bake.json)."""
    from .scene.model import MAX_ATLASES

    summary = _marker(path) if (Path(path) / MARKER).exists() else None
    atlases = summary.get("atlases") if isinstance(summary, dict) else None
    count = atlases.get("count") if isinstance(atlases, dict) else 1
    if not (isinstance(count, int) and not isinstance(count, bool) and 1 <= count <= MAX_ATLASES):
        raise PatchlightError(f"{Path(path) / MARKER}: atlases count {count!r} is not a whole number in 1..{MAX_ATLASES}")
    return count


def _read_atlases(path: Path, name: str, read):
    """The map `name` of bake `path`, its atlases' files read by `read(file)` and stacked along
    rows (None when `read` gives None for them)."""
    pages = [read(Path(path) / file) for file in atlas_files(name, atlas_count(path))]
    if any(page is None for page in pages):
        return None
    if len({page.shape for page in pages}) > 1:
        raise PatchlightError(f"{Path(path) / atlas_files(name, len(pages))[0]}: the atlases' files differ in size")
    return np.concatenate(pages, axis=-3 if pages[0].ndim == 4 else 0)


def read_summary(path: str | Path) -> dict:
    """The bake.json of bake directory `path`, parsed."""
    summary = _marker(path)
    if not isinstance(summary, dict) or not isinstance(summary.get("settings"), dict):
        raise PatchlightError(f"{Path(path) / MARKER}: not a bake summary (no settings in it)")
    return summary


def _marker(path: str | Path):
    """bake.json of bake directory `path`, parsed (any JSON value)."""
    from .imaging.io import read_bytes
    from .limits import load_json

    where = Path(path) / MARKER
    return load_json(read_bytes(where), str(where))


def recorded_sun_angle(path: str | Path) -> float | None:
    """The sun angle (degrees) the bake in `path` was made with (bake.json), or None."""
    angle = read_summary(path)["settings"].get("sun_angle")
    if angle is not None and not (isinstance(angle, (int, float)) and 0 <= angle < 90):
        raise PatchlightError(f"{Path(path) / MARKER}: sun_angle {angle!r} is not an angle in 0..90 degrees")
    return angle


def read_lightmap(path: str | Path) -> np.ndarray:
    """(H, W, 3) float32 incident light of bake directory `path`; PatchlightError naming the
    texels that are not finite (a damaged or hand-edited file). Small negative values, which
    interpolation and denoising leave, are kept."""
    return _read_atlases(path, LIGHTMAP, _finite_exr)


def _finite_exr(where: Path) -> np.ndarray:
    from .imaging.io import read_exr

    lightmap = read_exr(where)
    bad = ~np.isfinite(lightmap).all(axis=2)
    if bad.any():
        row, column = np.argwhere(bad)[0]
        raise PatchlightError(f"{where}: {int(bad.sum())} texels are not finite (the first at row {row}, "
                              f"column {column}: {lightmap[row, column].tolist()})")
    return lightmap


def read_bake(path: str | Path) -> tuple:
    """(scene, lightmap, valid) of bake directory `path` (read_scene, read_lightmap,
    read_validity), all of the same bake even when a newer one is swapped in meanwhile."""
    from .outputs import read_consistently

    return read_consistently(path, lambda: (read_scene(path), read_lightmap(path), read_validity(path)))


def read_validity(path: str | Path) -> np.ndarray | None:
    """(H, W) bool of bake directory `path`: the texels with light of their own (lightmap.exr's
    alpha), or None for a bake written without it."""
    from .imaging.io import read_exr_alpha

    alpha = _read_atlases(path, LIGHTMAP, read_exr_alpha)
    return None if alpha is None else alpha > 0.5


def read_scene(path: str | Path):
    """The baked scene of bake directory `path` (scene.glb), which must carry lightmap UVs."""
    from .scene.gltf import load_gltf

    scene = load_gltf(Path(path) / SCENE)
    if scene.uv1 is None:
        raise PatchlightError(f"{Path(path) / SCENE}: no TEXCOORD_1 lightmap UVs")
    count = atlas_count(path)
    if scene.atlases != count:
        raise PatchlightError(f"{Path(path) / SCENE}: {scene.atlases} lightmap atlases, but {MARKER} says {count}")
    return scene


def read_directional(path: str | Path):
    """The directional lightmap (shading.directional.DirectionalLightmap) of bake directory
    `path`, or None when it has none."""
    from .imaging.io import read_exr_layers
    from .shading.directional import DirectionalLightmap

    count = atlas_count(path)
    for mode, name in DIRECTIONAL.items():
        if (Path(path) / atlas_files(name, count)[0]).exists():
            maps = _read_atlases(path, name, lambda file: np.stack(read_exr_layers(file, _layers(mode))))
            return DirectionalLightmap(mode, maps)
    return None


def write_directional(folder: Path, directional, atlases: int = 1) -> None:
    """Write a DirectionalLightmap (its maps over `atlases` stacked atlases) into `folder` (a
    bake's staging directory)."""
    from .imaging.io import write_exr_layers

    pages = np.split(directional.maps, atlases, axis=1)
    for file, maps in zip(atlas_files(DIRECTIONAL[directional.mode], atlases), pages):
        write_exr_layers(Path(folder) / file, dict(zip(_layers(directional.mode), maps)))


def _layers(mode: str) -> tuple[str, ...]:
    from .shading.directional import SH_LAYERS

    return SH_LAYERS if mode == "sh" else ("",)


def write_bake(result, out_dir: Path, settings, quiet: bool = True) -> dict:
    """Write a bake (patchlight.bake.BakeResult, made with BakeSettings `settings`) into
    out_dir as one set (module docstring), with a progress bar unless quiet; returns the
    summary that bake.json holds."""
    from .outputs import staged_output
    from .progress import Progress

    with staged_output(out_dir, stale=STALE) as staging, Progress(quiet) as progress:
        return stage_bake(result, staging, out_dir, settings, progress)


def stage_bake(result, staging: Path, out_dir: Path, settings, progress=None) -> dict:
    """Write a bake's files into the staging directory of a `staged_output` into out_dir whose
    stale globs include STALE; returns the summary. texels.npz is written on a thread of its
    own meanwhile (`outputs.alongside`); progress (patchlight.progress.Progress, or None)
    shows a "writing" bar, a step per file and per pass and array of texels.npz."""
    from .imaging.exposure import auto_exposure, exposed_png_pixels
    from .imaging.io import write_exr, write_json, write_png
    from .imaging.lightmap import encode_directional, encode_lightmap, lightmap_scale
    from .outputs import alongside
    from .progress import Progress
    from .radiosity.adaptive import debug_image
    from .scene.gltf import save_baked_glb

    count = result.scene.atlases
    k = auto_exposure(result.lightmap) if settings.exposure == "auto" else float(settings.exposure)
    pictures = [pass_picture(i) for i in range(1, len(result.pass_incident) + 1)] if settings.save_passes else []
    meta = {"quantity": "incident light I (cosine-weighted mean radiance) = texel x scale", "exposure": k}
    lightmaps = atlas_files(LIGHTMAP, count)
    extra = [] if result.directional is None else atlas_files(DIRECTIONAL[result.directional.mode], count)
    names = sorted([*lightmaps, SCENE, TEXELS, MARKER, LIGHTMAP_PICTURE, ADAPTIVE_PICTURE, *pictures, *extra])
    sky = result.scene.sky
    stats = dict(result.stats)
    if "atlases" in stats:
        stats["atlases"] = {**stats["atlases"], "files": lightmaps}
    summary = {"scene": result.scene.source, "settings": settings.to_json(), "exposure": k,
               "sky": None if sky is None else sky.to_json(),
               **stats, "files": names}

    def texels(step):  # after each array: stop there if the rest failed, else a step of the bar
        write_texels_of(result, staging / TEXELS, lambda: (step(), advance()))

    steps = len(names) - 1 + len(result.pass_incident) + len(fields(Texels)) - 1  # texels.npz by its arrays
    with (progress or Progress(quiet=True)).stage("writing", total=steps) as advance:
        with alongside(texels):
            for file, page, valid in zip(lightmaps, np.split(result.lightmap, count), np.split(result.valid, count)):
                write_exr(staging / file, page, alpha=valid)
                advance()
            if result.directional is not None:
                write_directional(staging, result.directional, count)
                advance(count)
            write_png(staging / LIGHTMAP_PICTURE, exposed_png_pixels(result.lightmap, k))
            write_png(staging / ADAPTIVE_PICTURE, debug_image(result.patches, result.status))
            advance(2)
            for name, image in zip(pictures, result.pass_images()):
                write_png(staging / name, exposed_png_pixels(image, k))
                advance()
            scale = lightmap_scale(result.lightmap)  # one scale for every atlas
            encoded = [encode_lightmap(page, scale) for page in np.split(result.lightmap, count)]
            directional = None if result.directional is None else [
                encode_directional(result.directional.mode, dict(zip(_layers(result.directional.mode), maps)), scale)
                for maps in np.split(result.directional.maps, count, axis=1)]
            save_baked_glb(result.scene, staging / SCENE, encoded[0] if count == 1 else encoded, meta, folder=out_dir,
                           directional=directional)
            advance()
        write_json(staging / MARKER, summary)  # once texels.npz is whole too
        advance()
    return summary


# texels.npz: the per-texel arrays, all (H, W, ...) in lightmap texels, row 0 at v = 0:
#   passes    (P, H, W, 3) float16  incident light I after each pass, filled and dilated as
#                                   lightmap.exr is, not seam-stitched (pass 1: direct + sky + emitters)
#   status    (H, W) int8           STATUS_NAMES index: uncovered, gathered, interpolated, inside
#   chart     (H, W) int32          UV chart id, -1 uncovered
#   rho       (H, W, 3) float32     reflectance the bake gave the patch
#   emission  (H, W, 3) float32     emitted radiance
#   excident  (H, W, 3) float32     B = rho I + E of the final solution (what other patches see)
# Deflated (`write_texels`): uncovered texels are zeros (the room at 2048 x 2048 with 19 passes: 161 MB).

@dataclass
class Texels:
    """The arrays of texels.npz (the comment above)."""

    passes: np.ndarray
    status: np.ndarray
    chart: np.ndarray
    rho: np.ndarray
    emission: np.ndarray
    excident: np.ndarray

    def write(self, path: Path) -> None:
        """Write these arrays as texels.npz at path (`write_texels`)."""
        write_texels(path, self.passes, len(self.passes), self.status, self.chart, self.rho, self.emission, self.excident)


def write_texels(path: Path, passes, pass_count: int, status, chart, rho, emission, excident,
                 written=None) -> None:
    """Write texels.npz at path: the arrays of the comment above, passes any iterable of
    pass_count (H, W, 3) images (a (P, H, W, 3) array too), each converted and written in
    turn, so a bake's passes never sit in memory as one stack. Deflated at level 1, member by
    member, straight into the file: the room at 2048 x 2048 (19 passes, 0.7 GB of arrays) in
    4.4 s and 161 MB, where NumPy's savez_compressed (level 6, through a buffer of the whole
    file, the passes stacked) took 10.1 s for 152 MB. written(): called after each pass and
    each other array (None: nothing), which may raise to stop the writing there."""
    from .imaging.halves import to_float16

    h, w = status.shape
    members = [("passes", np.float16, (pass_count, h, w, 3), passes), ("status", np.int8, (h, w), [status]),
               ("chart", np.int32, (h, w), [chart]), ("rho", np.float32, (h, w, 3), [rho]),
               ("emission", np.float32, (h, w, 3), [emission]), ("excident", np.float32, (h, w, 3), [excident])]
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as archive:
        for name, dtype, shape, parts in members:
            with archive.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array_header_1_0(member, {"descr": np.lib.format.dtype_to_descr(np.dtype(dtype)),
                                                             "fortran_order": False, "shape": shape})
                for part in parts:
                    member.write((to_float16(part) if dtype == np.float16 else np.ascontiguousarray(part, dtype)).data)
                    if written is not None:
                        written()


def write_texels_of(result, path: Path, written=None) -> None:
    """Write texels.npz of a patchlight.bake.BakeResult at path, its passes one at a time,
    each pass's image made (`_made_ahead`) while the one before is deflated; written: as
    `write_texels`'s."""
    p = result.patches
    write_texels(path, _made_ahead(result.pass_images()), len(result.pass_incident), p.to_image(result.status),
                 p.to_image(p.chart, fill=-1), p.to_image(p.rho), p.to_image(p.emission),
                 p.to_image(result.solution.excident.astype(np.float32)), written)


def _made_ahead(items):
    """The items of an iterator, each next one made on a thread of its own while the caller
    uses the one before (the fill of a pass's image takes a fifth of the time its deflate
    does, and the kernels let go of the GIL): one item more in memory."""
    items = iter(items)
    with ThreadPoolExecutor(1) as pool:
        coming = pool.submit(next, items, None)
        while (item := coming.result()) is not None:
            coming = pool.submit(next, items, None)
            yield item


def read_texels(bake_dir: str | Path) -> Texels | None:
    """The bake's texels.npz, or None when the bake has none (written before it existed);
    PatchlightError when it is damaged."""
    path = Path(bake_dir) / TEXELS
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            texels = Texels(**{name: data[name] for name in Texels.__dataclass_fields__})
    except (OSError, KeyError, ValueError, zipfile.BadZipFile) as exc:
        raise PatchlightError(f"{path}: not a readable texels file ({exc})") from None
    arrays = {name: getattr(texels, name) for name in Texels.__dataclass_fields__}
    if any(a.dtype.kind not in "fiu" for a in arrays.values()):
        raise PatchlightError(f"{path}: arrays that do not hold numbers")
    if texels.status.ndim != 2 or texels.status.size == 0 or len(texels.passes) == 0:
        raise PatchlightError(f"{path}: no texels or no passes")
    h, w = texels.status.shape
    shapes = {"passes": (len(texels.passes), h, w, 3), "chart": (h, w), "rho": (h, w, 3), "emission": (h, w, 3),
              "excident": (h, w, 3)}
    wrong = [name for name, shape in shapes.items() if arrays[name].shape != shape]
    if wrong:
        raise PatchlightError(f"{path}: arrays of mismatched shapes ({', '.join(wrong)} against status {h} x {w})")
    if not all(np.isfinite(a).all() for a in (texels.passes, texels.rho, texels.emission, texels.excident)):
        raise PatchlightError(f"{path}: values that are not finite")
    if texels.status.min() < 0 or texels.status.max() >= len(STATUS_NAMES):
        raise PatchlightError(f"{path}: texel status outside 0..{len(STATUS_NAMES) - 1}")
    return texels
