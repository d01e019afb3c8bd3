"""Viewer tests share the renderer tests' procedural scenes, and need node + Chromium."""
from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "render"))

REPO = Path(__file__).resolve().parents[2]
CHROMIUM = Path(os.environ.get("PATCHLIGHT_CHROMIUM", "/usr/bin/chromium"))


def browser_missing() -> str | None:
    """Why the browser tests cannot run here, or None."""
    if shutil.which("node") is None:
        return "node is not installed (make test installs it via tools/setup_browser.sh)"
    if not CHROMIUM.exists():
        return f"{CHROMIUM} is missing (tools/setup_browser.sh installs Debian's chromium)"
    for package in ("playwright-core", "three"):
        if not (REPO / "node_modules" / package / "package.json").is_file():
            return f"node_modules/{package} is missing (run npm ci, or tools/setup_browser.sh)"
    return None


@pytest.fixture(scope="session")
def browser():
    """The node command that drives Chromium (tests/viewer/browser.mjs); skips without one."""
    reason = browser_missing()
    if reason:
        pytest.skip(reason)
    return ["node", str(Path(__file__).with_name("browser.mjs"))]


def node_env() -> dict:
    return {**os.environ, "NODE_PATH": str(REPO / "node_modules")}
