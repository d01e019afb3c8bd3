"""The ambient-cube model in the viewer, with a volume baked from the showcase scene: the GLSL
in headless Chromium equals the CPU reference (mean |difference| < 1/255, 99th percentile
< 4/255, as for every model), and the moving sphere and box are lit by the volume."""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from browser_support import difference
from render_scenes import SHOWCASE_CAMERA, showcase_target

from patchlight.rays.tracer import Tracer
from patchlight.render import Camera, Renderer, target_settings
from patchlight.render.output import display_pixels
from patchlight.shading.ambient_cube import ambient_cube_light
from patchlight.solved import SolvedScene
from patchlight.viewer.app import make_server
from patchlight.volumes import VolumeSettings, bake_volume, grid_over

SIZE = 128
EXPOSURE = 1.0
CAMERA = {"eye": list(SHOWCASE_CAMERA[0]), "target": list(SHOWCASE_CAMERA[1]), "fov": SHOWCASE_CAMERA[2]}
CASES = [{"name": "squared"}, {"name": "naive", "ambient_cube_naive": True},
         {"name": "per_vertex", "per_vertex": True}, {"name": "normal_map", "normal_map": True}]
LOOK = (1.0, 0.8, 1.2)  # from the sphere's centre to the eye, off every axis so the weightings differ
SPHERE_ALBEDO, SPHERE_REFLECTIVITY = 0.8, 0.25  # ambient_cube.js's moving sphere


@pytest.fixture(scope="module")
def showcase():
    """The showcase target and a volume baked from its lightmap, sky and lights."""
    target = showcase_target()
    solved = SolvedScene(target.scene, target.lightmap, "showcase")
    volume, _ = bake_volume(solved, grid_over(*target.scene.bounds(), dims=(6, 4, 6)), VolumeSettings(rays=64))
    return target, volume


def spec(case: dict, name: str | None = None, **volume) -> dict:
    """A renderCase spec of the ambient-cube model with the case's options; volume: what the
    light volume shows first (objects, probes, time, look_at_sphere: browser.mjs)."""
    options = {k: v for k, v in case.items() if k != "name"}
    return dict(options, name=name or case["name"], model="ambient-cube", camera=CAMERA, width=SIZE, height=SIZE,
                exposure=EXPOSURE, volume=volume)


@pytest.fixture(scope="module")
def webgl(browser, showcase, tmp_path_factory):
    """({case name: (SIZE, SIZE, 4) uint8}, log) from one Chromium run."""
    target, volume = showcase
    specs = [spec(c) for c in CASES]
    specs += [spec(CASES[0], "objects", objects=True, time=3.0, look_at_sphere=LOOK),
              spec(CASES[1], "objects-naive", objects=True, time=3.0, look_at_sphere=LOOK),
              spec(CASES[0], "no-objects", objects=False, time=3.0, look_at_sphere=LOOK),
              spec(CASES[0], "probes", probes=True)]
    with make_server(target, target_settings(target, volume=volume), exposure=EXPOSURE) as server:
        pictures, log = browser.cases(server.url, specs, tmp_path_factory.mktemp("webgl-volume"))
    assert log["volume"]["baked"]
    return pictures, log


def cpu_picture(showcase, case: dict):
    target, volume = showcase
    options = {k: v for k, v in case.items() if k != "name"}
    settings = target_settings(target, model="ambient-cube", volume=volume, **options)
    camera = Camera(np.array(CAMERA["eye"]), np.array(CAMERA["target"]), CAMERA["fov"])
    result = Renderer(target).render(settings, camera, SIZE, SIZE)
    return display_pixels(result.radiance, EXPOSURE), result.covered


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_webgl_equals_cpu(webgl, showcase, case):
    mean, p99 = difference(webgl[0][case["name"]], *cpu_picture(showcase, case))
    print(f"{case['name']}: mean {mean:.3f}/255, p99 {p99:.1f}/255")
    assert mean < 1.0 and p99 < 4.0


def test_the_comparison_tells_the_weightings_apart(webgl, showcase):
    mean, p99 = difference(webgl[0]["naive"], *cpu_picture(showcase, CASES[0]))
    assert mean >= 1.0 or p99 >= 4.0


@pytest.mark.parametrize("step, naive", [("objects", False), ("objects-naive", True)])
def test_the_moving_sphere_is_lit_by_the_volume(webgl, showcase, step, naive):
    """Looking at the sphere's centre, the middle pixel shows albedo x the volume along N plus
    reflectivity x the volume along R; facing the eye, R = N."""
    _, volume = showcase
    pictures, log = webgl
    sphere = log["volume"]["objects"][step]["sphere"]
    center = np.array(sphere["center"], np.float32)
    toward_eye = np.array(LOOK, np.float32) / np.linalg.norm(LOOK)
    P, N = center + sphere["radius"] * toward_eye, toward_eye
    light = ambient_cube_light(volume, P[None], N[None], naive)
    expected = display_pixels(((SPHERE_ALBEDO + SPHERE_REFLECTIVITY) * light)[None], EXPOSURE)[0, 0]
    middle = pictures[step][SIZE // 2 - 1:SIZE // 2 + 1, SIZE // 2 - 1:SIZE // 2 + 1, :3].reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(middle, expected, atol=3)
    assert np.abs(pictures[step].astype(int) - pictures["no-objects"]).max() > 20  # the object is drawn


def test_the_moving_box_stands_on_the_floor_inside_the_volume(webgl, showcase):
    target, volume = showcase
    box = webgl[1]["volume"]["objects"]["objects"]["box"]
    center, (_, height, _) = np.array(box["center"]), box["size"]
    lo = np.array(volume.grid.origin)
    hi = lo + np.array(volume.grid.spacing) * (np.array(volume.grid.dims) - 1)
    assert np.all(center >= lo) and np.all(center <= hi)
    tracer = Tracer(target.scene.positions, target.scene.indices)
    start = np.array([[center[0], (lo[1] + hi[1]) / 2, center[2]]], np.float32)
    hits = tracer.intersect(start, np.array([[0, -1, 0]], np.float32))
    floor = start[0, 1] - hits.t[0] if hits.tri[0] >= 0 else lo[1]
    assert center[1] - height / 2 == pytest.approx(floor, abs=1e-3)


def test_probe_cubes_are_drawn(webgl):
    pictures, _ = webgl
    changed = np.abs(pictures["probes"].astype(int) - pictures["squared"]).max(axis=-1) > 10
    assert 20 < changed.sum() < 0.5 * SIZE * SIZE


def test_the_live_page_moves_the_objects_and_takes_the_toggles(browser, showcase, tmp_path):
    target, volume = showcase
    with make_server(target, target_settings(target, volume=volume), exposure=EXPOSURE) as server:
        log = browser.run("volume-live", server.url, tmp_path, timeout=300)
    first, later = log["volume"]["objects"]["first"], log["volume"]["objects"]["later"]
    assert np.linalg.norm(np.subtract(first["sphere"]["center"], later["sphere"]["center"])) > 1e-3
    assert "ms/frame" in log["stats"]
    pixels = np.asarray(Image.open(tmp_path / "screenshot.png").convert("RGB")).astype(int)
    assert pixels.std() > 10
