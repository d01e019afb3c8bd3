"""Lightmap UVs: TEXCOORD_1 kept, xatlas in a child process, the planar fallback packer."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from atlas_meshes import cube_scene, quad_scene, sphere_scene
from scipy.ndimage import distance_transform_cdt

from patchlight.atlas import _kernels, uvs
from patchlight.atlas.raster import rasterize
from patchlight.atlas.uvs import ensure_lightmap_uvs, uv_charts
from patchlight.errors import PatchlightError
from patchlight.scene import load_scene


def chart_masks(scene, width, height):
    """(C, H, W) bool: the texels each uv1 chart touches, each chart rasterised on its own."""
    tex = scene.uv1[scene.indices].astype(np.float64) * [width, height]
    chart, count = uv_charts(scene.uv1, scene.indices)
    return np.array([_kernels.rasterize_owners(tex, chart == c, width, height) >= 0 for c in range(count)])


def empty_texels_between_charts(masks):
    """Fewest empty texels (chessboard distance - 1) between texels of two different charts."""
    claims = masks.sum(axis=0)
    gap = np.inf
    for mask in masks:
        others = claims - mask > 0
        if others.any():
            gap = min(gap, distance_transform_cdt(~mask, metric="chessboard")[others].min() - 1)
    return gap


def check_atlas(source, scene, width, height, padding):
    """Same triangles in the same order, uv1 in [0, 1], charts apart by >= padding texels."""
    np.testing.assert_array_equal(scene.positions[scene.indices], source.positions[source.indices])
    np.testing.assert_array_equal(scene.normals[scene.indices], source.normals[source.indices])
    assert scene.uv1.dtype == np.float32 and scene.uv1.min() >= 0 and scene.uv1.max() <= 1
    masks = chart_masks(scene, width, height)
    assert masks.sum(axis=0).max() == 1  # every texel claimed by one chart only
    assert empty_texels_between_charts(masks) >= padding
    patches, _ = rasterize(scene, width, height)
    # every triangle owns a texel, or (when small) touches only covered texels
    tex = scene.uv1[scene.indices].astype(np.float64) * [width, height]
    for t in np.nonzero(np.bincount(patches.triangle, minlength=scene.n_triangles) == 0)[0]:
        alone = _kernels.rasterize_owners(tex, np.arange(scene.n_triangles) == t, width, height) >= 0
        assert alone.any() and (patches.index[alone] >= 0).all()
    return masks


def test_texcoord1_is_kept_bit_exact():
    scene = quad_scene(size=2.0)
    scene.uv1 = scene.uv1 * np.float32(0.7) + np.float32(0.1)
    before = scene.uv1.tobytes()
    out, width, height, info = ensure_lightmap_uvs(scene, texels_per_unit=40)
    assert out.uv1.tobytes() == before and out.positions is scene.positions
    # W^2 * uv area (0.49) holds world area (4 m^2) at 40 texels/m: W = 40 * 2 / 0.7 -> 116
    assert (width, height) == (116, 116)
    assert info["uv_source"] == "TEXCOORD_1" and info["charts"] == 1 and info["warnings"] == []
    assert ensure_lightmap_uvs(scene, texels_per_unit=1)[1] == 16  # clamped up to 16
    assert ensure_lightmap_uvs(scene, texels_per_unit=40, resolution=64)[1:3] == (64, 64)


@pytest.mark.parametrize("make", [cube_scene, sphere_scene])
def test_xatlas_charts_do_not_overlap_and_keep_padding(make):
    source = make()
    scene, width, height, info = ensure_lightmap_uvs(source, texels_per_unit=24, padding=2)
    assert info["uv_source"] == "xatlas" and info["warnings"] == []
    assert width % 4 == 0 and height % 4 == 0
    masks = check_atlas(source, scene, width, height, padding=2)
    assert info["charts"] == len(masks)


def test_xatlas_fills_a_requested_resolution():
    source = sphere_scene()
    scene, width, height, info = ensure_lightmap_uvs(source, resolution=64, padding=2)
    assert (width, height) == (64, 64) and info["uv_source"] == "xatlas"
    masks = check_atlas(source, scene, width, height, padding=2)
    assert masks.any(axis=0).mean() > 0.3  # the charts spread over the page


@pytest.mark.parametrize("make", [cube_scene, sphere_scene])
@pytest.mark.parametrize("resolution", [None, 128])
def test_fallback_packer_charts_do_not_overlap_and_keep_padding(make, resolution, monkeypatch):
    monkeypatch.setattr(uvs, "_xatlas_installed", lambda: False)
    source = make()
    scene, width, height, info = ensure_lightmap_uvs(source, texels_per_unit=24, resolution=resolution, padding=2)
    assert info["uv_source"] == "fallback"
    assert info["warnings"] == ["xatlas is not installed; used the simple planar-chart packer"]
    if resolution:
        assert (width, height) == (resolution, resolution)
    masks = check_atlas(source, scene, width, height, padding=2)
    assert info["charts"] == len(masks) == (6 if make is cube_scene else 24 * 10 + 2 * 24)
    if make is cube_scene and resolution is None:
        # each face is a 24 x 24 texel square (plus the 0.02 texel safety margin: 25 cells)
        for mask in masks:
            ys, xs = np.nonzero(mask)
            assert np.ptp(ys) + 1 == np.ptp(xs) + 1 == 25 and mask.sum() == 25 * 25


def test_xatlas_crash_falls_back_with_one_warning(monkeypatch):
    monkeypatch.setenv("PATCHLIGHT_XATLAS_CHILD_CRASH", "1")
    source = cube_scene()
    scene, width, height, info = ensure_lightmap_uvs(source, texels_per_unit=16)
    assert info["uv_source"] == "fallback"
    assert info["warnings"] == ["xatlas crashed (signal 11, SIGSEGV); used the simple planar-chart packer"]
    check_atlas(source, scene, width, height, padding=2)


def test_xatlas_timeout_falls_back(monkeypatch):
    monkeypatch.setattr(uvs, "CHILD_TIMEOUT_BASE_S", 1e-3)
    monkeypatch.setattr(uvs, "CHILD_TIMEOUT_PER_TRIANGLE_S", 0.0)
    info = ensure_lightmap_uvs(cube_scene(), texels_per_unit=16)[3]
    assert info["uv_source"] == "fallback" and len(info["warnings"]) == 1
    assert info["warnings"][0].startswith("xatlas took longer than")


@pytest.mark.parametrize("scale", [1e12, 1e18])
def test_huge_coordinates_reach_xatlas_normalised(scale):
    """A cube 1e12 (1e18) m wide at 3e12 (3e18) m gets the same charts and size as a 1 m cube
    (xatlas sees the same unit-sized mesh) and its density in texels per metre."""
    small = ensure_lightmap_uvs(cube_scene(), resolution=64)
    huge_source = cube_scene(scale)
    huge_source.positions += np.float32(3 * scale)
    huge = ensure_lightmap_uvs(huge_source, resolution=64)
    assert huge[3]["uv_source"] == small[3]["uv_source"] == "xatlas"
    assert huge[3]["charts"] == small[3]["charts"] and huge[1:3] == small[1:3]
    assert huge[3]["texels_per_unit"] == pytest.approx(small[3]["texels_per_unit"] / scale, rel=1e-5)


def _hanging_xatlas(env: dict, **popen) -> tuple[subprocess.Popen, int]:
    """A Python process packing a cube with xatlas, whose child hangs, and the child's pid
    once it has set its signals."""
    script = ("import sys; sys.path.insert(0, sys.argv[1]); from atlas_meshes import cube_scene\n"
              "from patchlight.atlas.uvs import ensure_lightmap_uvs; ensure_lightmap_uvs(cube_scene())")
    parent = subprocess.Popen([sys.executable, "-c", script, str(Path(__file__).parent)],
                              env={**os.environ, **env, "PATCHLIGHT_XATLAS_CHILD_HANG": "1"}, **popen)
    for _ in range(600):  # up to 60 s on a busy machine
        children = Path(f"/proc/{parent.pid}/task/{parent.pid}/children").read_text().split()
        if children:
            time.sleep(0.5)  # the child has set its parent-death signal and SIGINT's before it pauses
            return parent, int(children[0])
        time.sleep(0.1)
    parent.kill()
    parent.wait()
    raise AssertionError("no xatlas child started")


def test_xatlas_child_dies_with_its_parent(tmp_path):
    """SIGKILL the process waiting for a (hanging) xatlas child: the kernel kills the child
    too, and no temporary folder of it remains."""
    parent, child = _hanging_xatlas({"TMPDIR": str(tmp_path)})
    parent.kill()
    parent.wait()
    for _ in range(100):
        if not Path(f"/proc/{child}").exists() or "Z" in Path(f"/proc/{child}/stat").read_text().split()[2]:
            break
        time.sleep(0.1)
    else:
        raise AssertionError("the xatlas child outlived its parent")
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_while_xatlas_runs_ends_its_child_too():
    """SIGINT to the whole process group while a (hanging) xatlas child runs, as a terminal's
    Ctrl-C sends it: the child ignores it, the parent stops at once and kills and reaps its
    child on the way out."""
    parent, child = _hanging_xatlas({}, stderr=subprocess.PIPE, start_new_session=True)
    try:
        os.killpg(parent.pid, signal.SIGINT)
        _, err = parent.communicate(timeout=30)
    finally:
        if parent.poll() is None:
            os.killpg(parent.pid, signal.SIGKILL)
            parent.wait()
    assert parent.returncode != 0 and b"KeyboardInterrupt" in err
    assert not Path(f"/proc/{child}").exists()  # killed and reaped, not a zombie


def test_vertex_arrays_are_split_consistently():
    source = cube_scene()
    source.colors = np.random.default_rng(0).random((len(source.positions), 4)).astype(np.float32)
    scene = ensure_lightmap_uvs(source, texels_per_unit=8)[0]
    assert len(scene.positions) > len(source.positions)  # seams split the cube's 8 vertices
    np.testing.assert_array_equal(scene.colors[scene.indices], source.colors[source.indices])
    np.testing.assert_array_equal(scene.material_ids, source.material_ids)


def test_absurd_sizes_and_bad_options_are_refused():
    with pytest.raises(PatchlightError, match="lower `texels_per_unit` or set `resolution`"):
        ensure_lightmap_uvs(cube_scene(size=100.0), texels_per_unit=1000)
    with pytest.raises(PatchlightError, match="resolution"):
        ensure_lightmap_uvs(cube_scene(), resolution=9000)
    with pytest.raises(PatchlightError, match="texels per unit"):
        ensure_lightmap_uvs(cube_scene(), texels_per_unit=-1)
    with pytest.raises(PatchlightError, match="padding"):
        ensure_lightmap_uvs(cube_scene(), padding=-1)
    flat = quad_scene()
    flat.uv1 = np.zeros_like(flat.uv1)
    with pytest.raises(PatchlightError, match="TEXCOORD_1 covers no area"):
        ensure_lightmap_uvs(flat)




def test_texcoord1_outside_the_unit_square_is_warned_and_too_dense_is_refused():
    scene = quad_scene()
    scene.uv1 = scene.uv1 * 2 - 0.5     # reaches from -0.5 to 1.5
    _, _, _, info = ensure_lightmap_uvs(scene, resolution=32)
    assert len(info["warnings"]) == 1 and "outside TEXCOORD_1's [0, 1] square" in info["warnings"][0]
    with pytest.raises(PatchlightError, match="needs a .* lightmap \\(limit 8192\\)"):
        ensure_lightmap_uvs(quad_scene(), texels_per_unit=1e9)


def test_the_density_search_repacks_the_first_charts_as_xatlas_packs_them_afresh():
    """The child charts once and repacks those charts for every later guess (`_chart_shapes`):
    the result maps each triangle to its own corners, fits the page, and stretches the
    triangles' edges (texels over metres x the density) as little as xatlas charting and
    packing anew at that density does: each chart rounded up to whole texels once, not once
    at the first guess's density and again at the last's."""
    from patchlight.atlas import _xatlas_child as child

    scene = load_scene("room")  # small charts, each a few texels: a texel's rounding shows
    positions = np.ascontiguousarray(scene.positions, np.float32)
    indices = np.ascontiguousarray(scene.indices, np.uint32)
    first = child._generate(positions, indices, 2, 0.0, 256)
    packing = child._fitted(positions, indices, 2, 256)
    fresh = child._generate(positions, indices, 2, packing.texels_per_unit, 256)
    assert packing.fits(256) and packing.charts == first.charts == fresh.charts
    assert packing.texels_per_unit != first.texels_per_unit  # a later guess, repacked, was kept
    np.testing.assert_array_equal(packing.vmapping[packing.indices], indices)

    def stretch(p):  # (3T,) each edge's length in texels over its metres x the density reported
        uv, world = p.uv[p.indices], positions.astype(np.float64)[p.vmapping][p.indices]
        texels = np.linalg.norm(np.roll(uv, -1, axis=1) - uv, axis=2)
        return (texels / (np.linalg.norm(np.roll(world, -1, axis=1) - world, axis=2) * p.texels_per_unit)).ravel()

    repacked, anew = (np.percentile(stretch(p), [50, 90, 100]) for p in (packing, fresh))
    assert (repacked <= 1.01 * anew).all(), (repacked, anew)


def test_a_child_that_cannot_start_falls_back_with_one_warning(monkeypatch):
    """fork refused (no memory, no process left): the planar packer takes over, one warning
    says why, and the pipes made for the child are closed again."""
    def refuse():
        raise OSError(12, "Cannot allocate memory")

    monkeypatch.setattr(uvs.os, "fork", refuse)
    fds = len(os.listdir("/proc/self/fd"))
    source = cube_scene()
    scene, width, height, info = ensure_lightmap_uvs(source, texels_per_unit=16)
    assert info["uv_source"] == "fallback"
    assert info["warnings"] == ["xatlas's process could not start (Cannot allocate memory); "
                                "used the simple planar-chart packer"]
    assert len(os.listdir("/proc/self/fd")) == fds
    check_atlas(source, scene, width, height, padding=2)
