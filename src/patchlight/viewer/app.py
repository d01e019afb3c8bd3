"""Everything `patchlight view` serves for one target, built from the CPU renderer's pieces."""
from __future__ import annotations

from ..imaging.exposure import auto_exposure
from ..render.renderer import Renderer
from ..render.target import Target
from ..shading.models import ShadingSettings
from .bundle import manifest_bytes, scene_bundle
from .server import ViewerServer

EXPOSURE_PREVIEW = 96  # pixels on a side of the CPU render that sets the automatic exposure


def make_server(target: Target, settings: ShadingSettings, port: int = 0, exposure: float | None = None,
                envmap_from=None) -> ViewerServer:
    """A ViewerServer for `target`: default camera, the environment cube (from the sky, or
    rendered from `envmap_from`), the sky behind the scene, and the exposure (automatic: from a
    small CPU render)."""
    renderer = Renderer(target, envmap_from)
    renderer.require_inputs(settings)
    camera = renderer.default_camera()
    env = renderer.environment(settings)
    if exposure is None:
        preview = renderer.render(settings, camera, EXPOSURE_PREVIEW, EXPOSURE_PREVIEW)
        exposure = auto_exposure(preview.radiance[preview.covered]) if preview.covered.any() else 1.0
    manifest, data = scene_bundle(target, settings, camera, env, exposure, renderer.sky_cube(settings))
    return ViewerServer(manifest_bytes(manifest), data, target.bake_dir, manifest["pictures"], port)
