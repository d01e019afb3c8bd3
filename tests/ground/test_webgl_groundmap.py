"""hemisphere-radiosity with a baked ground map: the viewer's GLSL in headless Chromium equals
the CPU reference, for every encoding and offset mode, per vertex, with fog, and with the
block-compressed texels: over the pixels both cover, mean |difference| < 1/255 and the 99th
percentile < 4/255 (8-bit sRGB values of the same exposure), as for the other models."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from browser_support import difference
from ground_scenes import fence, ground, patches, pole, solved, sun
from render_scenes import uv_sphere

from patchlight.ground.groundmap import GroundMapSettings, make_groundmap, write_groundmap
from patchlight.ground.mapping import GroundArea
from patchlight.ground.viewer import ViewerGroundMap, open_ground_map_dir
from patchlight.imaging.exposure import auto_exposure
from patchlight.render import Camera, Renderer, target_settings
from patchlight.render.output import display_pixels
from patchlight.render.target import Target
from patchlight.scene.builtin import SceneBuilder
from patchlight.scene.model import Material, Scene
from patchlight.shading.hemisphere_radiosity import ENCODINGS, OFFSET_MODES
from patchlight.viewer.app import make_server

SIZE = 96
CAMERA = {"eye": [-3.0, 3.5, 9.0], "target": [1.5, 0.8, 2.0], "fov": 50.0}
SIDE = [0.6, 0.0, 0.8]
FOG = {"fog_color": [2.0, 2.2, 2.6], "fog_range": [6.0, 16.0]}


def level_with_sphere(directory: Path):
    """(Target, ViewerGroundMap): a ground with coloured patches, a pole and a fence in the sun,
    its 64 x 64 ground map written to `directory` and opened as the viewer opens it (every
    encoding, PNG and DDS texels), and a smooth sphere above it."""
    b = SceneBuilder()
    ground(b)
    patches(b, [(0.7, 0.1, 0.1), (0.1, 0.6, 0.2), (0.2, 0.3, 0.8), (0.6, 0.6, 0.1)])
    pole(b, x=-1.0, z=3.0)
    fence(b, x0=-1.0, x1=4.0, z=4.0)
    level = solved(b, [sun((0.6, -1.0, -0.4))])
    gm = make_groundmap(level, GroundMapSettings(size=64, area=GroundArea(-10, -10, 10, 10), noise=0.1))
    write_groundmap(gm, directory, "test", None)
    _, inputs = open_ground_map_dir(directory)
    inputs.fog_range = (0.0, 0.0)  # fog only where a case asks for it
    s = level.scene
    positions, normals, uv, indices = uv_sphere(12, 24, 1.2, (1.0, 1.6, 2.5))
    scene = Scene(positions=np.concatenate([s.positions, positions]), normals=np.concatenate([s.normals, normals]),
                  uv0=np.concatenate([s.uv0, uv]), indices=np.concatenate([s.indices, indices + len(s.positions)]),
                  material_ids=np.concatenate([s.material_ids, np.full(len(indices), len(s.materials), np.int32)]),
                  materials=s.materials + [Material("chrome", np.array([0.8, 0.8, 0.8, 1], np.float32), reflectivity=0.5)],
                  lights=s.lights, sky=s.sky, name="ground map test", source="ground map test")
    return Target.from_scene(scene), inputs


def variant_inputs(inputs: ViewerGroundMap, case: dict):
    """The CPU reference's GroundMapInputs for a case: the variant's texels and the options."""
    encoding, _ = case["variant"].split("-")
    texels, shadow, scale, sky_scale = inputs.variants[case["variant"]]
    options = {k: (np.asarray(v, np.float32) if isinstance(v, list) and k != "fog_range" else v)
               for k, v in case.items() if k in ("offset_mode", "offset", "side", "fog_color", "fog_range")}
    chosen = inputs.with_options(texture=texels / np.float32(255), encoding=encoding, map_scale=scale,
                                 sky_scale=sky_scale, **options)
    if shadow is not None:
        chosen.shadow = shadow / np.float32(255)
    return chosen


def case_list() -> list[dict]:
    cases = [{"name": f"{e}-{m}", "variant": f"{e}-png", "offset_mode": m, "offset": 1.5, "side": SIDE}
             for e in ENCODINGS for m in OFFSET_MODES]
    cases.append({"name": "hsv-side-per_vertex", "variant": "hsv-png", "offset_mode": "side", "offset": 1.5,
                  "side": SIDE, "per_vertex": True})
    cases.append({"name": "alpha-normal-fog", "variant": "alpha-png", "offset_mode": "normal", "offset": 1.0,
                  "side": SIDE, **FOG})
    cases.append({"name": "hsv-dds", "variant": "hsv-dds", "offset_mode": "normal", "offset": 1.0, "side": SIDE})
    cases.append({"name": "alpha-dds", "variant": "alpha-dds", "offset_mode": "normal", "offset": 1.0, "side": SIDE})
    return cases


CARS = {"name": "cars", "variant": "hsv-png", "offset_mode": "side", "offset": 1.5, "side": SIDE, "cars": True}


CASES = case_list()


@pytest.fixture(scope="module")
def level(tmp_path_factory):
    target, inputs = level_with_sphere(tmp_path_factory.mktemp("groundmap"))
    return target, Renderer(target), inputs


def cpu_picture(level, case: dict, exposure: float):
    target, renderer, inputs = level
    settings = target_settings(target, model="hemisphere-radiosity", per_vertex=bool(case.get("per_vertex")),
                               ground_map=variant_inputs(inputs, case))
    camera = Camera(np.array(CAMERA["eye"]), np.array(CAMERA["target"]), CAMERA["fov"])
    result = renderer.render(settings, camera, SIZE, SIZE)
    return display_pixels(result.radiance, exposure), result.covered, result


@pytest.fixture(scope="module")
def exposure(level):
    _, _, result = cpu_picture(level, CASES[0], 1.0)
    return auto_exposure(result.radiance[result.covered])


@pytest.fixture(scope="module")
def webgl(browser, level, exposure, tmp_path_factory):
    target, _, inputs = level
    specs = [{"name": c["name"], "model": "hemisphere-radiosity", "per_vertex": c.get("per_vertex", False),
              "radiosity": {k: v for k, v in c.items() if k not in ("name", "per_vertex")},
              "camera": CAMERA, "width": SIZE, "height": SIZE, "exposure": exposure} for c in CASES + [CARS]]
    settings = target_settings(target, model="hemisphere-radiosity", ground_map=inputs)
    with make_server(target, settings, exposure=exposure) as server:
        pictures, _ = browser.cases(server.url, specs, tmp_path_factory.mktemp("webgl-groundmap"))
    return pictures


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_webgl_equals_cpu(webgl, level, exposure, case):
    cpu, covered, _ = cpu_picture(level, case, exposure)
    mean, p99 = difference(webgl[case["name"]], cpu, covered)
    print(f"{case['name']}: mean {mean:.3f}/255, p99 {p99:.1f}/255")
    assert mean < 1.0 and p99 < 4.0


@pytest.mark.parametrize("gpu_case, cpu_case", [("hsv-normal", "hsv-none"), ("hsv-normal", "hsv-side"),
                                                ("hsv-normal", "alpha-normal"),
                                                ("alpha-normal", "alpha-normal-fog")])
def test_the_comparison_tells_the_options_apart(webgl, level, exposure, gpu_case, cpu_case):
    cpu, covered, _ = cpu_picture(level, next(c for c in CASES if c["name"] == cpu_case), exposure)
    mean, p99 = difference(webgl[gpu_case], cpu, covered)
    assert mean >= 1.0 or p99 >= 4.0


def test_the_cars_drive_on_the_written_loop_lit_by_the_map(webgl):
    """The cars (the viewer's own material, model hemisphere-radiosity) are drawn where the
    loop of groundmap.json runs, without a console error."""
    changed = np.abs(webgl["cars"].astype(int) - webgl["hsv-side"].astype(int)).max(axis=-1) > 10
    assert changed.sum() > 50
