"""Viewer tests share the renderer tests' procedural scenes (tests/render/render_scenes.py)."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "render"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from browser_support import DRIVER, browser_missing  # noqa: E402


@pytest.fixture(scope="session")
def browser():
    """The node command that drives Chromium (browser.mjs); skips, saying why, without one."""
    reason = browser_missing()
    if reason:
        pytest.skip(reason)
    return ["node", str(DRIVER)]
