"""Build step: three.js becomes package data (pyproject.toml holds everything else).

A wheel (`pip install .`) carries patchlight/viewer/three/: the files the viewer page imports
(patchlight/viewer/three_files.py), copied from node_modules/three with three's LICENSE and
package.json. When node_modules/three is missing, `npm ci` fetches it first (package-lock.json
pins the version). An editable install (`make demo`, `make test`) gets the same folder inside
src/ (git ignores it); without npm it goes without, and the viewer then asks for `npm ci`."""
from __future__ import annotations

import runpy
import shutil
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
LISTS = runpy.run_path(str(ROOT / "src" / "patchlight" / "viewer" / "three_files.py"))


def three_source() -> Path:
    """node_modules/three of this checkout, after `npm ci` if it is missing."""
    three = ROOT / "node_modules" / "three"
    if not (three / "package.json").is_file():
        if shutil.which("npm") is None:
            raise SystemExit("patchlight build: node_modules/three is missing and npm is not installed "
                             "(install node and npm, or run `npm ci` first)")
        subprocess.run(["npm", "ci", "--omit=dev", "--no-audit", "--no-fund", "--loglevel=error"], cwd=ROOT, check=True)
    return three


class BuildWithThree(build_py):
    """build_py, then three.js into patchlight/viewer/three/ of the build (or of src/, editable)."""

    def run(self):
        super().run()
        package = ROOT / "src" if self.editable_mode else Path(self.build_lib)
        try:
            source = three_source()
        except (SystemExit, subprocess.CalledProcessError) as exc:
            if not self.editable_mode:
                raise
            print(f"patchlight build: the viewer's three.js files are not bundled ({exc})")
            return
        target = package / "patchlight" / "viewer" / LISTS["BUNDLED"]
        for name in LISTS["THREE_FILES"] + LISTS["THREE_LICENSE"]:
            (target / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source / name, target / name)


setup(cmdclass={"build_py": BuildWithThree})
