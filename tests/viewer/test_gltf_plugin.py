"""The GLTFLoader plugin (viewer/static/patchlight_gltf.js) in headless Chromium: a bake's
scene.glb, loaded as a three.js app loads it (GLTFLoader + the plugin, three.js's own
materials; the viewer's scene.glb view), looks like `patchlight render --model lightmap` from
the same camera: within 2/255 on every smooth pixel (one whose 3 x 3 neighbourhood in the CPU
picture spans at most 2/255 and lies wholly on the surface), and no material samples the
occlusionTexture that only marks the lightmap used (strength 0). The room's lights are marked
baked, so the plugin turns them off; baked with --keep-lights they stay on in three.js.

A directional bake (sh and dominant) of a room whose materials carry a normal map of smooth
bumps: the plugin patches three.js's material so that its picture matches `patchlight render
--model lightmap-directional --normal-map` within 2/255 on every smooth pixel, and the bumps
show (the picture differs from the plain lightmap's where the normal map tilts). With the
highlight on, a glossy bumpy room matches `render ... --specular`, and misses it off."""
from __future__ import annotations

import json

import numpy as np
import pytest
from browser_support import three_missing
from render_scenes import _quad, scene_from_parts

from patchlight.cli.main import main
from patchlight.imaging.io import read_image
from patchlight.scene import Light, Material, Scene, Sky, load_scene
from patchlight.scene.gltf import save_baked_glb
from patchlight.scene.gltf.container import pack_glb, split_glb
from patchlight.shading.surface import vertex_tangents
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


def cpu_render(bake_dir, camera: dict, out, *options) -> np.ndarray:
    """(H, W, 3) int32 0..255: `patchlight render BAKE_DIR` from `camera` with `options`."""
    view = [",".join(map(str, camera["eye"])), ",".join(map(str, camera["target"])), str(camera["fov"])]
    assert main(["render", str(bake_dir), "--camera", *view, "--size", f"{SIZE}x{SIZE}",
                 "--exposure", str(EXPOSURE), "-o", str(out), *options]) == 0
    return np.round(read_image(out) * 255).astype(np.int32)


def cpu_and_three(browser, bake_dir, tmp_path, *options, specular=(False,), camera=None) -> tuple[np.ndarray, np.ndarray, dict]:
    """(CPU picture (H, W, 3), three.js picture (H, W, 4), the three.js materials' maps) of the
    bake from `camera` ({eye, target, fov}; default: the bake's default camera), int32 0..255:
    `patchlight render --model lightmap` (or the render `options`), and the viewer's scene.glb
    view. specular: the page's lightmap specular (the plugin's highlight) in each three.js
    picture; with several, a list of pictures."""
    target, _ = open_input(str(bake_dir)).target()
    c = camera or Renderer(target).default_camera().to_json()
    cpu = cpu_render(bake_dir, c, tmp_path / "cpu.png", *(options or ("--model", "lightmap")))
    specs = [{"name": f"engine{k}", "model": "lightmap", "engine": True, "lightmap_specular": on, "camera": c,
              "width": SIZE, "height": SIZE, "exposure": EXPOSURE} for k, on in enumerate(specular)]
    with make_server(target, target_settings(target, model="lightmap"), exposure=EXPOSURE) as server:
        pictures, log = browser.cases(server.url, specs, tmp_path)
    gpu = [pictures[s["name"]].astype(np.int32) for s in specs]
    return cpu, gpu if len(gpu) > 1 else gpu[0], log["engine"]


def smooth_difference(cpu: np.ndarray, gpu: np.ndarray, what: str, least: float = 0.2) -> int:
    """The largest |gpu - cpu| (/255) over the smooth pixels (module docstring), which must be
    at least the share `least` of the picture; prints the figures."""
    covered = gpu[..., 3] > 0
    inside = np.zeros_like(covered)
    inside[1:-1, 1:-1] = np.stack([covered[1 + dy:SIZE - 1 + dy, 1 + dx:SIZE - 1 + dx]
                                   for dy in (-1, 0, 1) for dx in (-1, 0, 1)]).all(axis=0)
    smooth = inside & (neighbourhood_span(cpu) <= SMOOTH)
    assert smooth.mean() > least  # a good part of the picture is compared
    diff = np.abs(gpu[..., :3] - cpu)[smooth]
    every = np.abs(gpu[..., :3] - cpu)[covered]
    print(f"{what}: {smooth.sum()} smooth pixels ({smooth.mean():.0%}): mean {diff.mean():.3f}/255, "
          f"max {diff.max()}/255; all {covered.sum()} covered: mean {every.mean():.3f}/255, "
          f"p99 {np.percentile(every, 99):.1f}/255")
    return int(diff.max())


def covered_difference(gpu: np.ndarray, cpu: np.ndarray, what: str) -> np.ndarray:
    """Per pixel `gpu` covers, the largest |gpu - cpu| over the channels (/255), shape (covered,);
    prints the share off by more than 4/255, the mean and the max."""
    diff = np.abs(gpu[..., :3] - cpu).max(axis=-1)[gpu[..., 3] > 0]
    print(f"{what}: {np.mean(diff > 4):.0%} of pixels off by more than 4/255, mean {diff.mean():.1f}/255, "
          f"max {diff.max()}/255")
    return diff


def test_scene_glb_through_the_plugin_matches_the_cpu_lightmap_render(browser, tmp_path_factory, tmp_path):
    if three_missing():
        pytest.skip(three_missing())
    cpu, gpu, materials = cpu_and_three(browser, bake(tmp_path_factory), tmp_path)
    # every material shows the lightmap; its occlusionTexture stand-in (strength 0) is never sampled
    assert materials and all(m["lightMap"] and not m["aoMap"] for m in materials.values()), materials
    assert smooth_difference(cpu, gpu, "plugin vs CPU") <= 2


def test_lights_kept_dynamic_stay_on_in_three_js(browser, tmp_path_factory, tmp_path):
    """--keep-lights: the sun is left out of the lightmap and marked baked false, so three.js lights the
    room with it (brighter than the lightmap alone); baked, the plugin turned it off (above)."""
    if three_missing():
        pytest.skip(three_missing())
    cpu, gpu, _ = cpu_and_three(browser, bake(tmp_path_factory, "--keep-lights"), tmp_path)
    covered = gpu[..., 3] > 0
    assert (gpu[..., :3] - cpu)[covered].mean() > 10


def bumpy_scene(folder, name: str = "room", gloss: bool = False, scene: Scene | None = None) -> str:
    """The built-in scene `name` (or `scene`) as a glTF file whose materials carry a normal map
    of smooth bumps (a height 0.1 sin(2 pi u) sin(2 pi v) over TEXCOORD_0 in metres, tilting the
    normal by up to 32 degrees), with its tangents (TANGENT), so three.js and the CPU build the
    same frame; with `gloss` a white colour map whose alpha, the gloss, runs 0.2..0.8 along u."""
    scene = scene or load_scene(name)
    t = 2 * np.pi * (np.arange(64) + 0.5) / 64
    u, v = np.meshgrid(t, t)
    height = 0.1 * 2 * np.pi  # the slope's amplitude
    n = np.stack([-height * np.cos(u) * np.sin(v), height * np.sin(u) * np.cos(v), np.ones_like(u)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    for material in scene.materials:
        material.normal_texture = (0.5 + 0.5 * n).astype(np.float32)
        if gloss:
            material.base_color_texture = np.concatenate(
                [np.ones_like(n), 0.5 + 0.3 * np.sin(u)[..., None]], axis=-1).astype(np.float32)
    scene.tangents = vertex_tangents(scene.positions, scene.normals, scene.uv0, scene.indices)
    path = save_baked_glb(scene, folder / f"bumpy_{name}.glb")
    text, blob = split_glb(path.read_bytes(), path)
    doc = json.loads(text)  # bilinear without mipmaps, as the CPU renderer samples textures
    doc["samplers"] = [{"magFilter": 9729, "minFilter": 9729}]
    for texture in doc["textures"]:
        texture["sampler"] = 0
    path.write_bytes(pack_glb(json.dumps(doc).encode(), blob))
    return str(path)


@pytest.mark.parametrize("mode", ["sh", "dominant"])
def test_a_directional_bake_through_the_plugin_matches_the_cpu_directional_render(browser, tmp_path_factory,
                                                                                  tmp_path, mode):
    if three_missing():
        pytest.skip(three_missing())
    folder = tmp_path_factory.mktemp("bumpy")
    out = folder / mode
    assert main(["bake", bumpy_scene(folder), "-o", str(out), "--resolution", "128", "--rays", "64",
                 "--directional", mode, "--quiet"]) == 0
    cpu, (gpu, shiny), materials = cpu_and_three(browser, out, tmp_path, "--model", "lightmap-directional",
                                                 "--normal-map", specular=(False, True))
    assert materials and all(m["lightMap"] and m["normalMap"] for m in materials.values()), materials
    assert smooth_difference(cpu, gpu, f"plugin vs CPU, directional {mode}", least=0.15) <= 2  # bumps: fewer smooth
    camera = Renderer(open_input(str(out)).target()[0]).default_camera().to_json()
    highlight = cpu_render(out, camera, tmp_path / "specular.png", "--model", "lightmap-directional", "--normal-map",
                           "--specular")  # the highlight too, for sh as for dominant
    assert np.abs(highlight - cpu).max() > 20
    assert smooth_difference(highlight, shiny, f"plugin vs CPU, directional {mode} with specular", least=0.08) <= 2
    # the bumps show: the plain lightmap (no direction, no normal map) differs where the map tilts
    plain = cpu_render(out, camera, tmp_path / "plain.png", "--model", "lightmap")
    bumps = covered_difference(gpu, plain, f"directional {mode} vs the plain lightmap")
    assert np.mean(bumps > 4) > 0.1 and bumps.mean() > 2


def test_the_plugins_highlight_matches_the_cpu_directional_specular(browser, tmp_path_factory, tmp_path):
    """The room with bumps and a gloss map, baked dominant: with the page's lightmap specular
    on, the plugin's picture matches `render --model lightmap-directional --normal-map
    --specular` within 2/255 on smooth pixels; off, the highlight is missing. The baked sun,
    off in three.js, adds no highlight of its own in either (before, the CPU model drew it
    beside the dominant direction's: 50/255 mean on smooth pixels)."""
    if three_missing():
        pytest.skip(three_missing())
    folder = tmp_path_factory.mktemp("glossy")
    out = folder / "dominant"
    assert main(["bake", bumpy_scene(folder, "room", gloss=True), "-o", str(out), "--resolution", "128",
                 "--rays", "64", "--directional", "dominant", "--quiet"]) == 0
    cpu, (shiny, dull), _ = cpu_and_three(browser, out, tmp_path, "--model", "lightmap-directional", "--normal-map",
                                          "--specular", specular=(True, False))
    assert smooth_difference(cpu, shiny, "plugin vs CPU, dominant with specular", least=0.08) <= 2  # highlights: fewer smooth (10 % of the picture)
    missing = covered_difference(dull, cpu, "without the highlight")
    assert np.mean(missing > 4) > 0.05 and missing.max() > 20


def test_a_double_sided_normal_mapped_quad_seen_from_behind_matches_three_js(browser, tmp_path_factory, tmp_path):
    """A double-sided bumpy quad under a sky and a sun slanting along its tangent, baked
    dominant, seen from below: three.js turns tangent, bitangent and normal on a back face (as
    glTF's sample viewer), and so does `render --model lightmap-directional --normal-map`
    (before, its back face turned the bitangent and normal only: the bumps' tangent slope
    leaned the wrong way)."""
    if three_missing():
        pytest.skip(three_missing())
    quad = _quad([[-1.5, 0, 1.5], [1.5, 0, 1.5], [1.5, 0, -1.5], [-1.5, 0, -1.5]], [0, 1, 0])
    material = Material(name="sheet", base_color=np.float32([0.8, 0.75, 0.7, 1.0]), double_sided=True)
    sun = Light("directional", np.ones(3, np.float32), 4.0, direction=np.float32([-0.6, -0.8, 0.0]), name="sun")
    scene = scene_from_parts([quad], [material], [0], [sun], Sky.uniform([0.6, 0.7, 0.9]))
    scene.name = "sheet"
    folder = tmp_path_factory.mktemp("sheet")
    out = folder / "dominant"
    assert main(["bake", bumpy_scene(folder, "sheet", scene=scene), "-o", str(out), "--resolution", "64",
                 "--rays", "64", "--directional", "dominant", "--quiet"]) == 0
    below = {"eye": [0.5, -2.6, 1.4], "target": [0.0, 0.0, 0.0], "fov": 50.0}
    cpu, gpu, materials = cpu_and_three(browser, out, tmp_path, "--model", "lightmap-directional", "--normal-map",
                                        camera=below)
    assert materials and all(m["normalMap"] for m in materials.values()), materials
    assert smooth_difference(cpu, gpu, "plugin vs CPU, back face", least=0.3) <= 2
