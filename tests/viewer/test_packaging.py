"""A built patchlight carries its viewer: the wheel `pip install .` installs holds the three.js
files the page imports (three_files.py), three.js's licence and the GLTFLoader plugin, so
`patchlight view` works outside the checkout with no npm (the server prefers that copy)."""
from __future__ import annotations

import subprocess
import sys
import zipfile

import pytest
from browser_support import REPO, three_missing

from patchlight.viewer.three_files import THREE_FILES, THREE_LICENSE


def test_the_wheel_holds_three_js_with_its_licence_and_the_plugin(tmp_path):
    if three_missing():
        pytest.skip(three_missing())
    run = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(tmp_path), str(REPO)],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    wheel, = tmp_path.glob("patchlight-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for name in THREE_FILES + THREE_LICENSE:
        assert f"patchlight/viewer/three/{name}" in names, name
    assert "patchlight/viewer/static/patchlight_gltf.js" in names
    licence = zipfile.ZipFile(wheel).read("patchlight/viewer/three/LICENSE").decode()
    assert "MIT" in licence and "three.js authors" in licence.lower()
