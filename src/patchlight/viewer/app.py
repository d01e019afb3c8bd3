"""Everything `patchlight view` serves for one target, built from the CPU renderer's pieces."""
from __future__ import annotations

import numpy as np

from ..errors import PatchlightError
from ..imaging.exposure import auto_exposure
from ..render.renderer import ENV_MODELS, Renderer
from ..render.target import Target
from ..shading.environment import ENV_SIZE
from ..shading.models import ShadingSettings
from .bundle import manifest_bytes, scene_bundle
from .server import ViewerServer

EXPOSURE_PREVIEW = 96  # pixels on a side of the CPU render that sets the automatic exposure


def make_server(target: Target, settings: ShadingSettings, port: int = 0, exposure: float | None = None,
                envmap_from=None) -> ViewerServer:
    """A ViewerServer for `target`: default camera, the environment cube (from the sky, or
    rendered from `envmap_from` or a point the renderer chooses), the sky behind the scene,
    and the exposure (automatic: from a small CPU render).

    The page may switch to the envmap or hemisphere-radiosity model at any time, so the cube
    is always made; when no point for it could be found (and none was asked for) and the first
    model does not need it, the page gets a black cube and a note naming the options instead
    of the viewer failing."""
    renderer = Renderer(target, envmap_from)
    renderer.require_inputs(settings)
    camera = renderer.default_camera()
    env_note = None
    try:
        env = renderer.environment(settings)
    except PatchlightError as exc:
        if envmap_from is not None or settings.model in ENV_MODELS:
            raise
        env = np.zeros((6, ENV_SIZE, ENV_SIZE, 4), np.float32)
        env_note = f"envmap and hemisphere-radiosity reflect black: {exc}"
    if exposure is None:
        preview = renderer.render(settings, camera, EXPOSURE_PREVIEW, EXPOSURE_PREVIEW)
        exposure = auto_exposure(preview.radiance[preview.covered]) if preview.covered.any() else 1.0
    manifest, data = scene_bundle(target, settings, camera, env, exposure, renderer.sky_cube(settings), env_note)
    return ViewerServer(manifest_bytes(manifest), data, target.bake_dir, manifest["pictures"], port)
