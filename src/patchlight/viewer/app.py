"""Everything `patchlight view` serves for one target, built from the CPU renderer's pieces."""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from .. import bakedir
from ..errors import PatchlightError
from ..imaging.exposure import auto_exposure
from ..imaging.io import json_text, read_bytes
from ..patchview import PatchViews
from ..render.renderer import ENV_MODELS, Renderer
from ..render.target import Target
from ..shading.environment import ENV_SIZE
from ..shading.models import ShadingSettings
from .bundle import manifest_bytes, scene_bundle
from .server import ViewerServer

EXPOSURE_PREVIEW = 96  # pixels on a side of the CPU render that sets the automatic exposure


def make_server(target: Target, settings: ShadingSettings, port: int = 0, exposure: float | None = None,
                envmap_from=None, patch: tuple[int, int] | None = None, compare: Target | None = None,
                say=str) -> ViewerServer:
    """A ViewerServer for `target`: default camera, the environment cube (from the sky, or
    rendered from `envmap_from` or a point the renderer chooses), the sky behind the scene,
    and the exposure (automatic: from a small CPU render). A bake with texels.npz answers the
    view from any patch (`patch`: the texel shown first, checked here). `compare`: a second
    bake of the same lightmap UVs, for the page's A/B split of two bakes.

    The page may switch to the envmap or hemisphere-radiosity model at any time, so the cube
    is always made; when no point for it could be found (and none was asked for) and the first
    model does not need it, the page gets a black cube and a note naming the options instead
    of the viewer failing (say(error): the note's words for the error; the command line's name
    its flags)."""
    patch_view = None if target.texels is None else PatchEndpoint(target.bake_dir)
    if patch is not None:
        if patch_view is None:
            raise PatchlightError(f"`patch`: {target.name} is not a bake with texels.npz (bake it to view from a "
                                  f"patch)")
        patch_view.views().at(*patch)  # one line now when no patch is there
    if compare is not None:
        require_same_uvs(target, compare)
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
        env_note = f"envmap and hemisphere-radiosity reflect black: {say(exc)}"
    if exposure is None:
        preview = renderer.render(settings, camera, EXPOSURE_PREVIEW, EXPOSURE_PREVIEW)
        exposure = auto_exposure(preview.radiance[preview.covered]) if preview.covered.any() else 1.0
    manifest, data = scene_bundle(target, settings, camera, env, exposure, renderer.sky_cube(settings), env_note, patch,
                                  compare)
    glb_path = None if target.bake_dir is None else target.bake_dir / bakedir.SCENE
    glb = read_bytes(glb_path) if glb_path is not None and glb_path.is_file() else None
    manifest["scene_glb"] = glb is not None
    return ViewerServer(manifest_bytes(manifest), data, port, patch_view, glb)


def require_same_uvs(target: Target, compare: Target) -> None:
    """PatchlightError unless `compare` is a bake whose lightmap lies on target's surfaces the
    same way (the same triangles' lightmap UVs), so its lightmap can stand in for target's."""
    a, b = target.scene, compare.scene
    same = (compare.lightmap is not None and a.uv1 is not None and b.uv1 is not None
            and a.indices.shape == b.indices.shape and np.allclose(a.uv1[a.indices], b.uv1[b.indices], atol=1e-6))
    if not same:
        raise PatchlightError(f"`compare` {compare.name}: not a bake with the same lightmap UVs as {target.name} "
                              "(bake both from one scene at one resolution, or from a scene with its own TEXCOORD_1)")


class PatchEndpoint:
    """/scene/patch: the JSON of PatchView.to_json for a texel, or {"error": one line}. The
    bake's PatchViews is built on the first request (or by `views()`)."""

    def __init__(self, bake_dir: Path):
        self.bake_dir = bake_dir
        self._lock = threading.Lock()
        self._views: PatchViews | None = None

    def views(self) -> PatchViews:
        with self._lock:
            if self._views is None:
                self._views = PatchViews(self.bake_dir)
            return self._views

    def __call__(self, x: int, y: int) -> bytes:
        try:
            return json_text(self.views().at(x, y).to_json(), "patch view", indent=None).encode()
        except PatchlightError as exc:
            return json_text({"error": str(exc)}, "patch view", indent=None).encode()
