"""`patchlight blender`: the .blend shows the baked light. A few pixels rendered by Cycles
(through bpy, in its own process) equal the CPU renderer's lightmap model from the same camera
(linear radiance, pixels away from edges). Skipped, saying so, where bpy is not installed."""
from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from patchlight.cli.main import main
from patchlight.imaging.io import read_exr
from patchlight.render import Renderer
from patchlight.inputs import open_input

SIZE = 64
RENDER = Path(__file__).with_name("blender_render.py")

needs_bpy = pytest.mark.skipif(importlib.util.find_spec("bpy") is None,
                               reason="bpy is not installed (pip install 'patchlight[blender]'; bpy 5.0 needs "
                                      "Python 3.11): the Blender test does not run")


def test_without_bpy_or_a_bake_one_line_says_what_to_do(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "bpy", None)  # import bpy fails, as where it is not installed
    (tmp_path / "bake").mkdir()
    for name in ("scene.glb", "lightmap.exr"):
        (tmp_path / "bake" / name).write_bytes(b"")
    assert main(["blender", str(tmp_path / "bake"), "-o", str(tmp_path / "x.blend")]) == 2
    err = capsys.readouterr().err
    assert "pip install 'patchlight[blender]'" in err and err.count("\n") == 1
    assert main(["blender", str(tmp_path), "-o", str(tmp_path / "x.blend")]) == 2
    assert "not a bake directory (scene.glb is missing)" in capsys.readouterr().err
    assert not (tmp_path / "x.blend").exists()


@needs_bpy
def test_cycles_shows_the_baked_light_as_the_cpu_renderer(tmp_path):
    bake_dir = tmp_path / "room"
    assert main(["bake", "room", "-o", str(bake_dir), "--resolution", "64", "--rays", "256", "--quiet"]) == 0
    blend = tmp_path / "room.blend"
    subprocess.run([sys.executable, "-m", "patchlight.cli.main", "blender", str(bake_dir), "-o", str(blend)],
                   check=True, capture_output=True, timeout=600)
    subprocess.run([sys.executable, str(RENDER), str(blend), str(tmp_path / "cycles.exr"), str(SIZE)],
                   check=True, capture_output=True, timeout=600)
    cycles = read_exr(tmp_path / "cycles.exr")
    target, _ = open_input(str(bake_dir)).target()
    camera = Renderer(target).default_camera()  # the room's own camera, which scene.glb carries
    view = [",".join(map(str, camera.eye)), ",".join(map(str, camera.target)), str(camera.fov)]
    assert main(["render", str(bake_dir), "--model", "lightmap", "--camera", *view, "--size", f"{SIZE}x{SIZE}",
                 "-o", str(tmp_path / "cpu.exr")]) == 0
    cpu = read_exr(tmp_path / "cpu.exr")
    # pixels within 5 % of each of their 8 neighbours, in both pictures: away from edges, where the
    # exact sample position decides (the .blend has no sky: its windows are empty)
    smooth = near_neighbours(cpu) & near_neighbours(cycles)
    assert smooth.sum() > 0.2 * SIZE * SIZE
    error = np.abs(cycles - cpu)[smooth] / np.maximum(cpu[smooth], 1e-6)
    print(f"Cycles vs CPU on {smooth.sum()} pixels: median {100 * np.median(error):.2f} %, "
          f"max {100 * error.max():.2f} %")
    assert error.max() < 0.01


def near_neighbours(picture: np.ndarray, share: float = 0.05) -> np.ndarray:
    """(H, W) whether a pixel is positive and every neighbour lies within `share` of it."""
    pad = np.pad(picture, ((1, 1), (1, 1), (0, 0)), mode="edge")
    h, w = picture.shape[:2]
    near = (picture > 0).all(axis=-1)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            neighbour = pad[1 + dy:h + 1 + dy, 1 + dx:w + 1 + dx]
            near &= (np.abs(neighbour - picture) <= share * picture).all(axis=-1)
    return near
