"""What the browser tests need: node, Debian's Chromium and the npm packages; and how to run node."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CHROMIUM = Path(os.environ.get("PATCHLIGHT_CHROMIUM", "/usr/bin/chromium"))
DRIVER = Path(__file__).with_name("browser.mjs")


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


def three_missing() -> str | None:
    """Why the viewer server cannot run here (it serves node_modules/three), or None."""
    if not (REPO / "node_modules" / "three" / "build" / "three.module.js").is_file():
        return "node_modules/three is missing (run npm ci, or tools/setup_browser.sh)"
    return None


def node_env() -> dict:
    """The environment for browser.mjs: node finds playwright-core in the repository's node_modules."""
    return {**os.environ, "NODE_PATH": str(REPO / "node_modules")}
