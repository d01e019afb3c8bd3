"""Shared by every test directory: tests/render (the procedural scenes, render_scenes.py),
tests/scene (the glTF builder, gltf_builder.py) and tests/viewer (the browser driver's support, browser_support.py) on the import path, and the
`browser` fixture of the WebGL tests."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent
for folder in ("render", "viewer", "scene"):
    if str(TESTS / folder) not in sys.path:
        sys.path.insert(0, str(TESTS / folder))

from browser_support import Browser, browser_missing  # noqa: E402


@pytest.fixture(scope="session")
def browser() -> Browser:
    """Runs browser.mjs in Chromium; skips, saying why, where it cannot run."""
    reason = browser_missing()
    if reason:
        pytest.skip(reason)
    return Browser()
