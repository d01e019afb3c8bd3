"""The viewer page as a person uses it: it loads, every model and option can be picked from
the controls without a console error, and the screenshot shows the scene."""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from render_scenes import showcase_target

from patchlight.imaging.io import encode_png
from patchlight.render import target_settings
from patchlight.shading import MODELS
from patchlight.viewer.app import make_server


@pytest.fixture(scope="module")
def smoke(browser, tmp_path_factory):
    target = showcase_target()
    target.bake_dir = tmp_path_factory.mktemp("bake")
    for name in ("lightmap.png", "pass_01.png", "adaptive.png"):
        (target.bake_dir / name).write_bytes(encode_png(np.random.default_rng(0).integers(0, 255, (8, 8, 3), np.uint8)))
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


def test_screenshot_shows_the_scene(smoke):
    _, screenshot = smoke
    pixels = np.asarray(Image.open(screenshot).convert("RGB")).astype(int)
    assert pixels.std() > 10
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 200
