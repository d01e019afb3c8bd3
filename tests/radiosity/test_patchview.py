"""View from a patch (patchlight.patchview) and the bake's texels.npz: the view is the
bake's own gather (its weighted sum is the patch's gathered light), the unfolded hemicube
is the picture five pinhole cameras at the patch take (rendered by the CPU renderer), and
`render --patch` writes it or says in one line what is wrong."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from PIL import Image

from hemicube_cameras import cpu_hemicube, frame_of, pinhole_cross

from patchlight.bake import bake
from patchlight.bakedir import write_bake
from patchlight.cli.main import main
from patchlight.config import BakeSettings
from patchlight.errors import PatchlightError
from patchlight.imaging.io import read_exr
from patchlight.patchview import PatchViews, _cross_pixels
from patchlight.radiosity import adaptive
from patchlight.inputs import open_input
from patchlight.render import Renderer, target_settings
from patchlight.scene import load_scene
from patchlight.bakedir import STATUS_NAMES, read_texels

HEMICUBE = 16


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    out = tmp_path_factory.mktemp("bake") / "cornell"
    # unstitched: the renderer's lightmap then holds the very solution the gather saw
    settings = BakeSettings(resolution=32, gather="hemicube", hemicube_size=HEMICUBE, tolerance=1e-4, stitch=False)
    result = bake(load_scene("cornell"), settings)
    write_bake(result, out, settings)
    return result, out


def test_texels_file_holds_every_pass_and_the_bake_arrays(baked):
    result, out = baked
    texels = read_texels(out)
    p = result.patches
    assert texels.passes.shape == (result.stats["passes"], 32, 32, 3)
    inside = result.status == adaptive.INSIDE
    np.testing.assert_allclose(texels.passes[-1][p.texel_y, p.texel_x][~inside], result.solution.incident[~inside],
                               rtol=2e-3, atol=1e-4)  # float16
    np.testing.assert_array_equal(read_exr(out / "lightmap.exr"), result.lightmap)
    assert texels.passes[0].sum() < texels.passes[-1].sum()  # the bounces add light
    for k, image in enumerate(result.pass_images()):  # written one at a time, each in its place
        np.testing.assert_array_equal(texels.passes[k], image.astype(np.float16))
    np.testing.assert_array_equal(texels.status[p.texel_y, p.texel_x], result.status)
    assert (texels.status[p.index < 0] == 0).all() and STATUS_NAMES[adaptive.INSIDE] == "inside geometry"
    np.testing.assert_array_equal(texels.chart[p.texel_y, p.texel_x], p.chart)
    np.testing.assert_array_equal(texels.rho[p.texel_y, p.texel_x], p.rho)
    np.testing.assert_array_equal(texels.excident[p.texel_y, p.texel_x], result.solution.excident)


def test_the_view_sums_to_the_patch_gathered_light(baked):
    result, out = baked
    views = PatchViews(out)
    computed = np.flatnonzero(result.status == adaptive.COMPUTED)
    p = result.patches
    for row in computed[:: max(1, len(computed) // 25)]:
        view = views.at(int(p.texel_x[row]), int(p.texel_y[row]))
        assert view.texel == (p.texel_x[row], p.texel_y[row]) and json.dumps(view.to_json())
        np.testing.assert_allclose(view.gathered, result.solution.gathered[row], rtol=2e-3, atol=1e-5)


def test_the_cross_places_every_hemicube_pixel_once():
    n = 8
    row, col = _cross_pixels(n)
    assert len(set(zip(row.tolist(), col.tolist()))) == 3 * n * n
    assert row.min() == col.min() == 0 and row.max() == col.max() == 2 * n - 1


def test_the_unfolded_hemicube_is_what_five_cameras_at_the_patch_see(baked):
    """The picture (the bake's item buffer showing excident light B per texel) against the
    CPU renderer's lightmap model (bilinear lightmap x base colour + emission) along pinhole
    rays built here from the patch's frame."""
    result, out = baked
    target, _ = open_input(str(out)).target()
    renderer = Renderer(target)
    settings = target_settings(target, model="lightmap")
    views = PatchViews(out)
    p = result.patches
    floor = np.flatnonzero((p.normal[:, 1] > 0.9) & (result.status == adaptive.COMPUTED))
    for row in floor[[len(floor) // 3, 2 * len(floor) // 3]]:
        view = views.at(int(p.texel_x[row]), int(p.texel_y[row]))
        cpu, covered, cross = cpu_hemicube(renderer, settings, view)
        unit = pinhole_cross(HEMICUBE, frame_of(view))[cross]
        unit /= np.linalg.norm(unit, axis=-1, keepdims=True)
        np.testing.assert_allclose(view.picture(view.directions)[cross], unit, atol=1e-4)  # the same rays
        mine = view.picture(view.radiance)[cross]
        assert np.array_equal(view.picture(view.seen)[cross] >= 0, covered[cross])
        cpu = cpu[cross]
        relative = np.abs(mine - cpu).sum(-1) / np.maximum(cpu.sum(-1), 1e-3)
        print(f"texel {view.texel}: median {np.median(relative):.3f}, 90th percentile {np.percentile(relative, 90):.3f}")
        # per pixel, one texel's B against a bilinear blend of four (32 x 32 texels): a few %
        np.testing.assert_allclose(mine.mean(axis=0), cpu.mean(axis=0), rtol=0.01)
        assert np.median(relative) < 0.08 and np.percentile(relative, 90) < 0.3


def test_render_patch_writes_the_picture_and_refuses_bad_texels(baked, tmp_path, capsys):
    result, out = baked
    p = result.patches
    row = int(np.flatnonzero(result.status == adaptive.COMPUTED)[0])
    png = tmp_path / "patch.png"
    assert main(["render", str(out), "--patch", f"{p.texel_x[row]},{p.texel_y[row]}", "-o", str(png)]) == 0
    picture = np.asarray(Image.open(png))
    assert picture.shape[0] == 2 * HEMICUBE * (256 // (2 * HEMICUBE)) and picture.shape[1] > 2 * picture.shape[0]
    capsys.readouterr()
    uncovered = np.argwhere(p.index < 0)[0]
    for bad in ("9999,0", f"{uncovered[1]},{uncovered[0]}", "1;2", "-1,3"):
        assert main(["render", str(out), "--patch", bad, "-o", str(tmp_path / "bad.png")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "--patch" in err and "Traceback" not in err
    assert main(["render", "cornell", "--patch", "1,1", "-o", str(tmp_path / "bad.png")]) == 2
    assert not (tmp_path / "bad.png").exists()


def test_a_stratified_view_is_its_gather_as_dots_on_the_hemisphere(tmp_path):
    """Stratified rays: the view still sums to the patch's gathered light, and its picture
    is the rays seen from above, every dot inside the unit disk and none lost."""
    settings = BakeSettings(resolution=32, gather="stratified", rays=64, tolerance=1e-4, stitch=False)
    result = bake(load_scene("cornell"), settings)
    write_bake(result, tmp_path / "bake", settings)
    views = PatchViews(tmp_path / "bake")
    p = result.patches
    computed = np.flatnonzero(result.status == adaptive.COMPUTED)
    for row in computed[:: max(1, len(computed) // 10)]:
        view = views.at(int(p.texel_x[row]), int(p.texel_y[row]))
        assert view.method == "stratified" and len(view.seen) == 64
        np.testing.assert_allclose(view.gathered, result.solution.gathered[row], rtol=2e-3, atol=1e-5)
        drawn = view.picture(np.ones(len(view.seen), bool), fill=False)
        size = drawn.shape[0]
        y, x = np.nonzero(drawn)
        radius = np.hypot((x + 0.5) / size * 2 - 1, 1 - (y + 0.5) / size * 2)
        assert radius.max() < 1 + 3 / size * 2 and drawn.sum() >= len(view.seen)
        row_, col, _, _ = view.pixels()
        np.testing.assert_allclose((col + 0.5) / size * 2 - 1, view.local[:, 0], atol=2 / size)
        np.testing.assert_allclose(1 - (row_ + 0.5) / size * 2, view.local[:, 1], atol=2 / size)


def test_a_damaged_texels_file_or_bake_json_is_one_line(baked, tmp_path):
    _, out = baked
    broken = tmp_path / "broken"
    shutil.copytree(out, broken)
    texels = read_texels(out)
    texels.excident[0, 0, 0] = np.nan
    texels.write(broken / "texels.npz")
    with pytest.raises(PatchlightError, match="texels.npz: values that are not finite"):
        read_texels(broken)
    (broken / "texels.npz").write_bytes(b"not a zip")
    with pytest.raises(PatchlightError, match="texels.npz: not a readable texels file"):
        read_texels(broken)
    shutil.copy(out / "texels.npz", broken / "texels.npz")
    (broken / "bake.json").write_text('{"settings": {}}')
    with pytest.raises(PatchlightError, match="bake.json: no readable gather settings"):
        PatchViews(broken)


@pytest.mark.parametrize("damage, message", [
    (lambda a: a.update(status=a["status"].reshape(-1)[:7]), "no texels or no passes"),
    (lambda a: a.update(passes=a["passes"][:0]), "no texels or no passes"),
    (lambda a: a.update(chart=np.array(["x"] * 4)), "arrays that do not hold numbers"),
    (lambda a: a.update(rho=a["rho"][:, :5]), r"arrays of mismatched shapes \(rho against status"),
    (lambda a: a.update(passes=a["passes"][..., :2]), r"arrays of mismatched shapes \(passes against status"),
])
def test_texels_arrays_of_the_wrong_shape_or_kind_are_one_line(baked, tmp_path, damage, message):
    """Each array of texels.npz is checked against the status image's size before any reader
    indexes it (a short status array was a ValueError traceback from `render`)."""
    _, out = baked
    with np.load(out / "texels.npz") as data:
        arrays = {name: data[name] for name in data.files}
    damage(arrays)
    broken = tmp_path / "broken"
    shutil.copytree(out, broken)
    np.savez(broken / "texels.npz", **arrays)
    with pytest.raises(PatchlightError, match=f"texels.npz: {message}"):
        read_texels(broken)
