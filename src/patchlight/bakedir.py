"""The bake directory: the one owner of its file names and of reading and writing them.

A bake directory (written by `patchlight bake` or `write_bake`) holds

    lightmap.exr    float32 incident light I (H, W, 3), row 0 = v 0; its alpha channel the
                    validity: 1 for texels with light of their own (a patch on a visible
                    surface, computed or interpolated), 0 inside geometry and in the padding
    scene.glb       the scene with its lightmap UVs in TEXCOORD_1, the lightmap (MOZ_lightmap)
                    and the directional lightmap, if any (PATCHLIGHT_lightmap_directional;
                    patchlight.scene.gltf)
    lightmap.png    the lightmap exposed for display (sRGB)
    adaptive.png    the adaptive sampler's decisions (radiosity.adaptive.debug_image)
    texels.npz      every pass and the per-texel arrays the viewer reads (Texels below)
    pass_NN.png     the lightmap after each pass (--save-passes)
    lightmap_sh.exr or lightmap_dir.exr
                    the directional lightmap, if the bake made one (--directional;
                    shading.directional: layers L0, L1x, L1y, L1z of RGB, or the dominant
                    direction as RGB)
    bake.json       the summary: settings, sky, statistics, the list of files

written as one set: staged, then swapped in whole (patchlight.outputs.staged_output), so a
reader never meets a mixture of two bakes; files of an older bake that a new one need not
write are removed (STALE). A directory is a (complete) bake only with bake.json.
"""
from __future__ import annotations

import io
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import PatchlightError

MARKER = "bake.json"          # a directory is a bake only with it
LIGHTMAP = "lightmap.exr"
SCENE = "scene.glb"
LIGHTMAP_PICTURE = "lightmap.png"
ADAPTIVE_PICTURE = "adaptive.png"
DIRECTIONAL = {"sh": "lightmap_sh.exr", "dominant": "lightmap_dir.exr"}  # by DirectionalLightmap.mode
STALE = ("pass_*.png", *DIRECTIONAL.values())  # an older bake's files a new one need not write
TEXELS = "texels.npz"
REQUIRED = (SCENE, LIGHTMAP, MARKER)
STATUS_NAMES = ("uncovered", "gathered", "interpolated", "inside geometry")  # texels.npz's status


def pass_picture(number: int) -> str:
    """The file name of the lightmap after pass `number` (1, 2, ...)."""
    return f"pass_{number:02d}.png"


def is_bake_dir(path: str | Path) -> bool:
    """A complete bake: scene.glb and lightmap.exr, and bake.json, which is written last. A
    built-in scene's name is never a bake directory."""
    from .scene import is_builtin

    p = Path(path)
    return not is_builtin(path) and p.is_dir() and all((p / name).exists() for name in REQUIRED)


def require_bake_dir(path: str | Path) -> Path:
    """`path` as a complete bake directory, else a one-line PatchlightError."""
    if not is_bake_dir(path):
        raise PatchlightError(f"{path}: not a complete bake (a directory is not a bake without "
                              f"{', '.join(REQUIRED[:-1])} and {REQUIRED[-1]})")
    return Path(path)


def read_summary(path: str | Path) -> dict:
    """The bake.json of bake directory `path`, parsed."""
    from .imaging.io import read_bytes
    from .limits import load_json

    where = Path(path) / MARKER
    summary = load_json(read_bytes(where), str(where))
    if not isinstance(summary, dict) or not isinstance(summary.get("settings"), dict):
        raise PatchlightError(f"{where}: not a bake summary (no settings in it)")
    return summary


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
    from .imaging.io import read_exr

    where = Path(path) / LIGHTMAP
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

    alpha = read_exr_alpha(Path(path) / LIGHTMAP)
    return None if alpha is None else alpha > 0.5


def read_scene(path: str | Path):
    """The baked scene of bake directory `path` (scene.glb), which must carry lightmap UVs."""
    from .scene.gltf import load_gltf

    scene = load_gltf(Path(path) / SCENE)
    if scene.uv1 is None:
        raise PatchlightError(f"{Path(path) / SCENE}: no TEXCOORD_1 lightmap UVs")
    return scene


def read_directional(path: str | Path):
    """The directional lightmap (shading.directional.DirectionalLightmap) of bake directory
    `path`, or None when it has none."""
    from .imaging.io import read_exr_layers
    from .shading.directional import DirectionalLightmap

    for mode, name in DIRECTIONAL.items():
        if (Path(path) / name).exists():
            return DirectionalLightmap(mode, np.stack(read_exr_layers(Path(path) / name, _layers(mode))))
    return None


def write_directional(folder: Path, directional) -> None:
    """Write a DirectionalLightmap into `folder` (a bake's staging directory)."""
    from .imaging.io import write_exr_layers

    write_exr_layers(Path(folder) / DIRECTIONAL[directional.mode], dict(zip(_layers(directional.mode), directional.maps)))


def _layers(mode: str) -> tuple[str, ...]:
    from .shading.directional import SH_LAYERS

    return SH_LAYERS if mode == "sh" else ("",)


def write_bake(result, out_dir: Path, settings) -> dict:
    """Write a bake (patchlight.bake.BakeResult, made with BakeSettings `settings`) into
    out_dir as one set (module docstring); returns the summary that bake.json holds."""
    from .outputs import staged_output

    with staged_output(out_dir, stale=STALE) as staging:
        return stage_bake(result, staging, out_dir, settings)


def stage_bake(result, staging: Path, out_dir: Path, settings) -> dict:
    """Write a bake's files into the staging directory of a `staged_output` into out_dir whose
    stale globs include STALE; returns the summary."""
    from .imaging.exposure import auto_exposure, exposed_png_pixels
    from .imaging.io import write_bytes, write_exr, write_json, write_png
    from .imaging.lightmap import encode_directional, encode_lightmap
    from .radiosity.adaptive import debug_image
    from .scene.gltf import save_baked_glb

    k = auto_exposure(result.lightmap) if settings.exposure == "auto" else float(settings.exposure)
    images = {LIGHTMAP_PICTURE: exposed_png_pixels(result.lightmap, k),
              ADAPTIVE_PICTURE: debug_image(result.patches, result.status)}
    if settings.save_passes:
        images.update({pass_picture(i): exposed_png_pixels(image, k)
                       for i, image in enumerate(result.pass_images(), start=1)})
    meta = {"quantity": "incident light I (cosine-weighted mean radiance) = texel x scale", "exposure": k}
    extra = [] if result.directional is None else [DIRECTIONAL[result.directional.mode]]
    names = sorted([LIGHTMAP, SCENE, TEXELS, MARKER, *images, *extra])
    sky = result.scene.sky
    summary = {"scene": result.scene.source, "settings": settings.to_json(), "exposure": k,
               "sky": None if sky is None else sky.to_json(),
               **result.stats, "files": names}
    write_exr(staging / LIGHTMAP, result.lightmap, alpha=result.valid)
    if result.directional is not None:
        write_directional(staging, result.directional)
    write_bytes(staging / TEXELS, texels_of(result).to_bytes())
    for name, pixels in images.items():
        write_png(staging / name, pixels)
    lightmap = encode_lightmap(result.lightmap)
    directional = None if result.directional is None else encode_directional(
        result.directional.mode, dict(zip(_layers(result.directional.mode), result.directional.maps)), lightmap.scale)
    save_baked_glb(result.scene, staging / SCENE, lightmap, meta, folder=out_dir, directional=directional)
    write_json(staging / MARKER, summary)
    return summary


# texels.npz: the per-texel arrays, all (H, W, ...) in lightmap texels, row 0 at v = 0:
#   passes    (P, H, W, 3) float16  incident light I after each pass, filled and dilated as
#                                   lightmap.exr is, not seam-stitched (pass 1: direct + sky + emitters)
#   status    (H, W) int8           STATUS_NAMES index: uncovered, gathered, interpolated, inside
#   chart     (H, W) int32          UV chart id, -1 uncovered
#   rho       (H, W, 3) float32     reflectance the bake gave the patch
#   emission  (H, W, 3) float32     emitted radiance
#   excident  (H, W, 3) float32     B = rho I + E of the final solution (what other patches see)
# np.savez_compressed: uncovered texels are zeros (the room at 512 x 512 with 20 passes: 12 MB).

@dataclass
class Texels:
    """The arrays of texels.npz (the comment above)."""

    passes: np.ndarray
    status: np.ndarray
    chart: np.ndarray
    rho: np.ndarray
    emission: np.ndarray
    excident: np.ndarray

    def to_bytes(self) -> bytes:
        buffer = io.BytesIO()
        np.savez_compressed(buffer, passes=self.passes.astype(np.float16), status=self.status.astype(np.int8),
                            chart=self.chart.astype(np.int32), rho=self.rho.astype(np.float32),
                            emission=self.emission.astype(np.float32), excident=self.excident.astype(np.float32))
        return buffer.getvalue()


def texels_of(result) -> Texels:
    """The texels.npz arrays of a patchlight.bake.BakeResult."""
    p = result.patches
    return Texels(np.stack(result.pass_images()).astype(np.float16), p.to_image(result.status),
                  p.to_image(p.chart, fill=-1), p.to_image(p.rho), p.to_image(p.emission),
                  p.to_image(result.solution.excident.astype(np.float32)))


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
