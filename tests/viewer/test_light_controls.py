"""Lights made with the viewer's own controls in a scene that has none (the Cornell box, lit
only by its emissive ceiling): the light panel is there, a light of each kind can be added,
placed, aimed and given a cone, and the page draws them as the CPU renderer draws the same
lights (the WebGL-vs-CPU tolerance of test_webgl_matches_cpu.py)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from browser_support import difference

from patchlight.render import Camera, Renderer, Target, target_settings
from patchlight.scene import load_scene
from patchlight.render.output import display_pixels
from patchlight.shading.lights import FALLOFFS, PunctualLight
from patchlight.viewer.app import make_server

SIZE = 96
EXPOSURE = 1.0
ACTIONS = [
    {"select": "#light-kind", "value": "directional"}, {"click": "#light-add"},
    {"fill": "#light-azimuth", "value": 30}, {"fill": "#light-elevation", "value": -50},
    {"fill": "#light-intensity", "value": 4},
    {"select": "#light-kind", "value": "point"}, {"click": "#light-add"},
    {"fill": "#light-x", "value": 0.28}, {"fill": "#light-y", "value": 0.45}, {"fill": "#light-z", "value": 0.25},
    {"fill": "#light-intensity", "value": 0.08}, {"fill": "#light-range", "value": 0.6},
    {"select": "#light-kind", "value": "spot"}, {"click": "#light-add"},
    {"fill": "#light-x", "value": 0.45}, {"fill": "#light-y", "value": 0.5}, {"fill": "#light-z", "value": 0.1},
    {"fill": "#light-azimuth", "value": -30}, {"fill": "#light-elevation", "value": -45},
    {"fill": "#light-outer", "value": 35}, {"fill": "#light-inner", "value": 15},
    {"fill": "#light-intensity", "value": 0.1},
]


def aim(azimuth: float, elevation: float) -> list[float]:
    az, el = math.radians(azimuth), math.radians(elevation)
    return [math.cos(el) * math.sin(az), math.sin(el), math.cos(el) * math.cos(az)]


@pytest.fixture(scope="module")
def cornell():
    target = Target.from_scene(load_scene("cornell"))
    assert target.scene.lights == []
    return target


@pytest.fixture(scope="module")
def made(browser, cornell, tmp_path_factory):
    """(log, picture) of the controls run: lights added to the Cornell box, one frame of phong."""
    out = tmp_path_factory.mktemp("controls")
    camera = Renderer(cornell).default_camera()
    case = dict(name="added", model="phong", camera=camera.to_json(), width=SIZE, height=SIZE, exposure=EXPOSURE)
    (out / "script.json").write_text(json.dumps({"actions": ACTIONS, "case": case}))
    with make_server(cornell, target_settings(cornell), exposure=EXPOSURE) as server:
        log = browser.run("controls", server.url, out, out / "script.json", timeout=300)
    picture = np.fromfile(out / "added.rgba", np.uint8).reshape(SIZE, SIZE, 4)
    return log, picture, camera


def test_a_scene_without_lights_shows_the_panel_to_add_one(made):
    log, _, _ = made
    assert log["before"]["panelShown"] and log["before"]["lights"] == [] and not log["before"]["fieldsShown"]
    assert log["after"]["lights"] == ["0", "1", "2"] and log["after"]["fieldsShown"]


def test_the_controls_make_the_lights_they_show(made):
    state = made[0]["lights"]["state"]
    sun, lamp, spot = state
    assert [light["kind"] for light in state] == ["directional", "point", "spot"]
    np.testing.assert_allclose(sun["direction"], aim(30, -50), atol=1e-9)
    np.testing.assert_allclose(sun["intensity"], [4, 4, 4])
    np.testing.assert_allclose(lamp["position"], [0.28, 0.45, 0.25])
    assert lamp["range"] == 0.6 and lamp["falloff"] == FALLOFFS[0] == "inverse-square"
    np.testing.assert_allclose(spot["position"], [0.45, 0.5, 0.1])
    np.testing.assert_allclose(spot["direction"], aim(-30, -45), atol=1e-9)
    assert spot["cos_outer"] == pytest.approx(math.cos(math.radians(35)))
    assert spot["cos_inner"] == pytest.approx(math.cos(math.radians(15)))


def test_the_page_draws_the_added_lights_as_the_cpu_renderer_does(made, cornell):
    log, gpu, camera = made
    lights = [PunctualLight(kind=l["kind"], position=np.array(l["position"], np.float32),
                            direction=np.array(l["direction"], np.float32),
                            intensity=np.array(l["intensity"], np.float32), falloff=l["falloff"],
                            range=l["range"], cos_inner=l["cos_inner"], cos_outer=l["cos_outer"])
              for l in log["lights"]["state"]]
    settings = target_settings(cornell, model="phong")
    settings.lights = lights
    result = Renderer(cornell).render(settings, Camera(camera.eye, camera.target, camera.fov), SIZE, SIZE)
    unlit = Renderer(cornell).render(target_settings(cornell, model="phong"), camera, SIZE, SIZE)
    cpu = display_pixels(result.radiance, EXPOSURE)
    mean, p99 = difference(gpu, cpu, result.covered)
    print(f"added lights: mean {mean:.3f}/255, p99 {p99:.1f}/255")
    assert mean < 1.0 and p99 < 4.0
    lit = np.abs(cpu.astype(int) - display_pixels(unlit.radiance, EXPOSURE)).max(axis=-1) > 8
    assert lit.mean() > 0.2  # the added lights light a good part of the picture
