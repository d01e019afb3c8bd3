"""Light-volume tests use the renderer tests' procedural scenes and the viewer tests' browser set-up."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
for folder in (HERE, HERE.parent / "render", HERE.parent / "viewer"):
    sys.path.insert(0, str(folder))

from browser_support import browser_missing  # noqa: E402


@pytest.fixture(scope="session")
def browser():
    """The node command that drives Chromium for these tests; skips, saying why, without one."""
    reason = browser_missing()
    if reason:
        pytest.skip(reason)
    return ["node", str(HERE / "volume_browser.mjs")]
