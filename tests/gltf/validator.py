"""The Khronos glTF validator (npm gltf-validator, run by validate.mjs under node) from Python."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SCRIPT = Path(__file__).with_name("validate.mjs")


def validator_missing() -> str | None:
    """Why the validator cannot run here, or None."""
    if shutil.which("node") is None:
        return "node is not installed (make test installs it via tools/setup_browser.sh)"
    if not (REPO / "node_modules" / "gltf-validator" / "package.json").is_file():
        return "node_modules/gltf-validator is missing (run npm ci, or tools/setup_browser.sh)"
    return None


def validate(*paths) -> list[dict]:
    """One report per file: {file, errors, warnings, messages: [{code, severity, pointer, message}]}."""
    run = subprocess.run(["node", str(SCRIPT), *map(str, paths)], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "NODE_PATH": str(REPO / "node_modules")})
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout)


def problems(report: dict, codes=()) -> list[dict]:
    """The report's errors, plus its issues of any severity whose code is in `codes`."""
    return [m for m in report["messages"] if m["severity"] == 0 or m["code"] in codes]
