"""The GLTFLoader plugin (viewer/static/patchlight_gltf.js) in headless Chromium: a bake's
scene.glb, loaded as a three.js app loads it (GLTFLoader + the plugin, three.js's own
materials; the viewer's scene.glb view), looks like `patchlight render --model lightmap` from
the same camera: within 2/255 on every smooth pixel (one whose 3 x 3 neighbourhood in the CPU
picture spans at most 2/255 and lies wholly on the surface), and no material samples the
occlusionTexture that only marks the lightmap used (strength 0). The room's lights are marked
baked, so the plugin turns them off; baked with --keep-lights they stay on in three.js."""
from __future__ import annotations

import numpy as np
import pytest
from browser_support import three_missing

from patchlight.cli.main import main
from patchlight.imaging.io import read_image
from patchlight.render import Renderer
from patchlight.inputs import open_input
from patchlight.viewer.app import make_server
from patchlight.render.settings import target_settings

SIZE = 160
EXPOSURE = 0.8
SMOOTH = 2  # /255: the span of a smooth pixel's neighbourhood


def bake(tmp_path_factory, *options):
    out = tmp_path_factory.mktemp("plugin") / "room"
    assert main(["bake", "room", "-o", str(out), "--resolution", "128", "--rays", "64", "--quiet", *options]) == 0
    return out


def neighbourhood_span(picture: np.ndarray) -> np.ndarray:
    """(H, W) largest max - min over each pixel's 3 x 3 neighbourhood and channels (borders: inf)."""
    h, w = picture.shape[:2]
    p = picture.astype(np.int32)
    span = np.full((h, w), np.iinfo(np.int32).max)
    shifts = [p[1 + dy:h - 1 + dy, 1 + dx:w - 1 + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
    stack = np.stack(shifts)
    span[1:-1, 1:-1] = (stack.max(axis=0) - stack.min(axis=0)).max(axis=-1)
    return span


def cpu_and_three(browser, bake_dir, tmp_path) -> tuple[np.ndarray, np.ndarray, dict]:
    """(CPU picture (H, W, 3), three.js picture (H, W, 4), the three.js materials' maps) of the
    bake from its default camera, int32 0..255: `patchlight render --model lightmap`, and the
    viewer's scene.glb view."""
    target, _ = open_input(str(bake_dir)).target()
    c = Renderer(target).default_camera().to_json()
    cpu_png = tmp_path / "cpu.png"
    view = [",".join(map(str, c["eye"])), ",".join(map(str, c["target"])), str(c["fov"])]
    assert main(["render", str(bake_dir), "--model", "lightmap", "--camera", *view, "--size", f"{SIZE}x{SIZE}",
                 "--exposure", str(EXPOSURE), "-o", str(cpu_png)]) == 0
    cpu = np.round(read_image(cpu_png) * 255).astype(np.int32)
    spec = {"name": "engine", "model": "lightmap", "engine": True, "camera": c, "width": SIZE, "height": SIZE,
            "exposure": EXPOSURE}
    with make_server(target, target_settings(target, model="lightmap"), exposure=EXPOSURE) as server:
        pictures, log = browser.cases(server.url, [spec], tmp_path)
    return cpu, pictures["engine"].astype(np.int32), log["engine"]


def test_scene_glb_through_the_plugin_matches_the_cpu_lightmap_render(browser, tmp_path_factory, tmp_path):
    if three_missing():
        pytest.skip(three_missing())
    cpu, gpu, materials = cpu_and_three(browser, bake(tmp_path_factory), tmp_path)
    # every material shows the lightmap; its occlusionTexture stand-in (strength 0) is never sampled
    assert materials and all(m["lightMap"] and not m["aoMap"] for m in materials.values()), materials
    covered = gpu[..., 3] > 0
    inside = np.zeros_like(covered)
    inside[1:-1, 1:-1] = np.stack([covered[1 + dy:SIZE - 1 + dy, 1 + dx:SIZE - 1 + dx]
                                   for dy in (-1, 0, 1) for dx in (-1, 0, 1)]).all(axis=0)
    smooth = inside & (neighbourhood_span(cpu) <= SMOOTH)
    assert smooth.mean() > 0.2  # a good part of the picture is compared
    diff = np.abs(gpu[..., :3] - cpu)[smooth]
    every = np.abs(gpu[..., :3] - cpu)[covered]
    print(f"plugin vs CPU: {smooth.sum()} smooth pixels ({smooth.mean():.0%}): mean {diff.mean():.3f}/255, "
          f"max {diff.max()}/255; all {covered.sum()} covered: mean {every.mean():.3f}/255, "
          f"p99 {np.percentile(every, 99):.1f}/255")
    assert diff.max() <= 2


def test_lights_kept_dynamic_stay_on_in_three_js(browser, tmp_path_factory, tmp_path):
    """--keep-lights: the sun is left out of the lightmap and marked baked false, so three.js lights the
    room with it (brighter than the lightmap alone); baked, the plugin turned it off (above)."""
    if three_missing():
        pytest.skip(three_missing())
    cpu, gpu, _ = cpu_and_three(browser, bake(tmp_path_factory, "--keep-lights"), tmp_path)
    covered = gpu[..., 3] > 0
    assert (gpu[..., :3] - cpu)[covered].mean() > 10
