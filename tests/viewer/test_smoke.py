"""The viewer page as a person uses it: it loads, every model and option (overlays, marks,
passes, the A/B split) can be picked from the controls without a console error, lights can
be aimed, given a cone, added and removed, and the screenshot shows the scene."""
from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image
from render_scenes import showcase_target

from patchlight.render import target_settings
from patchlight.shading import FALLOFFS, LIGHT_KINDS, MODELS
from patchlight.bakedir import Texels
from patchlight.viewer.app import make_server


@pytest.fixture(scope="module")
def smoke(browser, tmp_path_factory):
    """The showcase with stand-in bake arrays (two passes, every texel status, a few charts),
    so the bake panel's controls are there to pick."""
    target = showcase_target()
    rng = np.random.default_rng(0)
    h, w = target.lightmap.shape[:2]
    target.texels = Texels(np.stack([target.lightmap / 2, target.lightmap]), rng.integers(0, 4, (h, w)),
                           rng.integers(0, 6, (h, w)), np.full((h, w, 3), 0.5), np.zeros((h, w, 3)), target.lightmap / 2)
    target.bake_dir = tmp_path_factory.mktemp("bake")
    out = tmp_path_factory.mktemp("smoke")
    with make_server(target, target_settings(target, model="lightmap")) as server:
        log = browser.run("smoke", server.url, out, timeout=300)
    return log, out / "screenshot.png"


def test_page_loads_and_every_model_can_be_picked_without_console_errors(smoke):
    log, _ = smoke
    assert log["ready"] == "true"
    assert log["errors"] == []
    assert log["models"] == list(MODELS)
    for model in MODELS:
        assert log["frames"][model].startswith(model) and "ms/frame" in log["frames"][model]
    assert log["surfaces"] == ["", "light", "adaptive", "charts"]
    assert log["hover"].startswith("texel ") and " I " in log["hover"]  # the texel under the pointer
    assert log["legend"] == ["uncovered", "gathered", "interpolated", "inside geometry", "chart border texels",
                             "every other texel (64 x 32)"]


def test_screenshot_shows_the_scene(smoke):
    _, screenshot = smoke
    pixels = np.asarray(Image.open(screenshot).convert("RGB")).astype(int)
    assert pixels.std() > 10
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 200


def direction(azimuth: float, elevation: float) -> list[float]:
    """The page's aim (degrees: azimuth from +Z towards +X, elevation above the horizon) as a
    unit vector of the way the light travels."""
    az, el = math.radians(azimuth), math.radians(elevation)
    return [math.cos(el) * math.sin(az), math.sin(el), math.cos(el) * math.cos(az)]


def test_the_light_panel_offers_common_glsls_kinds_and_falloffs(smoke):
    controls = smoke[0]["lightControls"]
    assert controls["kinds"] == list(LIGHT_KINDS) and controls["falloffs"] == list(FALLOFFS)
    assert controls["panelShown"] and controls["fieldsShown"] and controls["lights"] == ["0", "1", "2"]
    assert controls["sunRows"] == {"position": False, "aim": True, "range": False, "falloff": False, "cone": False}
    assert controls["spotRows"] == {"position": True, "aim": True, "range": True, "falloff": True, "cone": True}


def test_lights_can_be_aimed_given_a_cone_added_and_removed(smoke):
    """The sun aimed at azimuth 90, elevation -30; the spot at 180, -60 with a 10..40 degree
    cone; a spot added (selected) and removed again. The shader uniforms follow the state."""
    controls = smoke[0]["lightControls"]
    assert controls["added"] == 4 and controls["selected"] == "3"
    state, uniforms = controls["after"]["state"], controls["after"]["uniforms"]
    assert [light["kind"] for light in state] == ["directional", "point", "spot"] and uniforms["count"] == 3
    np.testing.assert_allclose(state[0]["direction"], direction(90, -30), atol=1e-9)
    np.testing.assert_allclose(state[2]["direction"], direction(180, -60), atol=1e-9)
    assert state[2]["cos_outer"] == pytest.approx(math.cos(math.radians(40)))
    assert state[2]["cos_inner"] == pytest.approx(math.cos(math.radians(10)))
    assert state[1]["falloff"] == "range" and max(state[1]["intensity"]) == pytest.approx(20)
    np.testing.assert_allclose(uniforms["direction"], [light["direction"] for light in state], atol=1e-6)
    np.testing.assert_allclose(uniforms["cos_outer"], [light["cos_outer"] for light in state], atol=1e-6)
    np.testing.assert_allclose(uniforms["cos_inner"], [light["cos_inner"] for light in state], atol=1e-6)
