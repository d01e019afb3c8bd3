"""What every browser test shares: whether node, Debian's Chromium and the npm packages are
here; `Browser`, which runs the one driver (browser.mjs) and reads back what it wrote; and
`difference`, the pixel comparison of a WebGL picture with the CPU renderer's."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
CHROMIUM = Path(os.environ.get("PATCHLIGHT_CHROMIUM", "/usr/bin/chromium"))
DRIVER = Path(__file__).with_name("browser.mjs")
MIN_COVERED = 0.3         # a comparison must cover at least this share of the picture ...
MAX_COVERAGE_MISMATCH = 0.002  # ... and GPU and CPU may disagree on whether a pixel is covered at this share


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


class Browser:
    """browser.mjs's commands, each one Chromium run against a viewer server's url."""

    def run(self, command: str, url: str, out_dir: Path, *args, timeout: float = 600, ready: str = "true") -> dict:
        """Run `command` (cases, smoke, volume-live) writing into out_dir; its log.json, after
        checking that the page got ready without console errors (ready "error": that the page
        refused, as it does with one line in its status)."""
        run = subprocess.run(["node", str(DRIVER), command, url, *map(str, args), str(out_dir)],
                             capture_output=True, text=True, timeout=timeout,
                             env={**os.environ, "NODE_PATH": str(REPO / "node_modules")})
        assert run.returncode == 0, run.stderr[-2000:]
        log = json.loads((Path(out_dir) / "log.json").read_text())
        assert log["ready"] == ready and (ready != "true" or log["errors"] == []), log
        return log

    def cases(self, url: str, specs: list[dict], out_dir: Path) -> tuple[dict, dict]:
        """({case name: (height, width, 4) uint8 RGBA, row 0 at the top}, log) of renderCase
        over every spec (browser.mjs's `cases`)."""
        out_dir = Path(out_dir)
        (out_dir / "cases.json").write_text(json.dumps(specs))
        log = self.run("cases", url, out_dir, out_dir / "cases.json")
        pictures = {s["name"]: np.fromfile(out_dir / f"{s['name']}.rgba", np.uint8).reshape(s["height"], s["width"], 4)
                    for s in specs}
        return pictures, log


def difference(gpu: np.ndarray, cpu: np.ndarray, cpu_covered: np.ndarray) -> tuple[float, float]:
    """(mean, 99th percentile) of |gpu - cpu| in 1/255 units over the pixels both cover: the
    WebGL picture (H, W, 4) uint8 (alpha 0 where nothing was drawn) against the CPU's display
    pixels (H, W, 3) uint8 and coverage (H, W). Both must cover the same pixels (up to
    MAX_COVERAGE_MISMATCH of the picture: edge pixels whose centre grazes a silhouette)."""
    gpu_covered = gpu[..., 3] > 0
    both = gpu_covered & cpu_covered
    assert both.sum() > MIN_COVERED * both.size
    assert np.count_nonzero(gpu_covered != cpu_covered) <= MAX_COVERAGE_MISMATCH * both.size
    diff = np.abs(gpu[..., :3].astype(int) - cpu.astype(int))[both]
    return float(diff.mean()), float(np.percentile(diff, 99))
