"""The ground map bake: preprocessing, orientation, shadows, the three encodings, files and
bad input, on small scenes whose light is known (ground_scenes.py)."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest
from ground_scenes import GREY, I0, SKY, SUN_ES, fence, ground, patches, pole, solved, sun

from patchlight.errors import PatchlightError
from patchlight.ground.encode import rgb_to_hsv
from patchlight.ground.files import (block_compressed, decode_dds, decode_dds_bytes, encode_dds, load_ground_map,
                                     read_map_pixels, to_bytes)
from patchlight.ground.groundmap import GroundMapSettings, make_groundmap, plan_groundmap, write_groundmap
from patchlight.ground.mapping import GroundArea, map_uv
from patchlight.ground.viewer import open_ground_map_dir
from patchlight.scene.builtin import SceneBuilder
from patchlight.shading.environment import sky_incident
from patchlight.shading.hemisphere_radiosity import radiosity_ground, radiosity_sky
from patchlight.scene.sky import Sky

AREA = GroundArea(-10.0, -10.0, 10.0, 10.0)
SIZE = 100  # 0.2 m texels: texel k's centre is at -9.9 + 0.2 k


def texel_of(x: float, z: float) -> tuple[int, int]:
    """(row, column) of the texel holding world point (x, z)."""
    u, v = map_uv(AREA, np.array([[x, 0.0, z]]))[0]
    return int(v * SIZE), int(u * SIZE)


def bake(b: SceneBuilder, lights=(), **options):
    options = {"size": SIZE, "area": AREA, "noise": 0.0, **options}
    settings = GroundMapSettings(**options)
    return make_groundmap(solved(b, lights), settings)


def level(with_sun=True):
    b = SceneBuilder()
    ground(b)
    pole(b)
    fence(b)
    return b, [sun()] if with_sun else []


# ------------------------------------------------------------------ preprocessing

def test_a_tall_pole_does_not_paint_the_ground_but_a_fence_does():
    b, _ = level(with_sun=False)
    gm = bake(b, shadows="alpha")
    B = gm.excident
    red = (B[..., 0] > 2 * B[..., 2]) & (B[..., 0] > 2 * B[..., 1])
    assert not red.any()
    assert np.allclose(B[texel_of(0.0, 0.0)], np.array(GREY) * I0, atol=1e-5)
    blue = B[..., 2] > 2 * B[..., 0]
    rows, cols = np.nonzero(blue)
    # the fence (x 2..6 at z = 5, 1 m tall, facing +z) lies turned up behind its foot: z 4..5
    x = AREA.x0 + (cols + 0.5) * 0.2
    z = AREA.z0 + (rows + 0.5) * 0.2
    assert x.min() > 2.0 and x.max() < 6.0 and z.min() > 4.0 and z.max() < 5.0
    assert abs(blue.sum() - 4.0 * 1.0 / 0.2**2) <= 0.15 * 100
    assert np.allclose(B[blue], np.array([0.0, 0.0, 0.8]) * I0, atol=1e-5)


def test_max_height_decides_what_is_left_out():
    b = SceneBuilder()
    ground(b)
    pole(b, height=2.0)
    B = bake(b, max_height=3.0).excident
    assert B[texel_of(0.0, 0.0)][0] > 2 * B[texel_of(0.0, 0.0)][1]  # a 2 m post is kept: its top shows
    b = SceneBuilder()
    ground(b)
    pole(b, height=2.0)
    B = bake(b, max_height=1.5).excident
    assert np.allclose(B[texel_of(0.0, 0.0)], np.array(GREY) * I0, atol=1e-5)


def test_map_rows_follow_z_and_columns_follow_x():
    b = SceneBuilder()
    ground(b)
    m = b.material("marker", (0.0, 0.9, 0.0))
    b.quad([(5, 0.01, -6), (7, 0.01, -6), (7, 0.01, -4), (5, 0.01, -4)], m, (0, 1, 0))
    B = bake(b).excident
    rows, cols = np.nonzero(B[..., 1] > 2 * B[..., 0])
    assert rows.max() < SIZE / 2 < cols.min()       # +x right, -z at the top (row 0 = v 0)
    assert (rows.min(), cols.min()) == texel_of(5.1, -5.9)


# ------------------------------------------------------------------ shadows

def test_shadow_amount_is_the_light_left_in_shadow():
    b, lights = level()
    gm = bake(b, lights, shadows="separate")
    s = gm.encoded.shadow
    i_sun = SUN_ES * np.sqrt(0.5) / np.pi                # the sun on a horizontal patch
    assert s[texel_of(5.0, 0.0)] == pytest.approx(I0 / (I0 + i_sun), rel=1e-4)   # the pole's shadow, +x
    for x, z in ((-5.0, 0.0), (5.0, 3.0), (-3.0, -7.0)):
        assert s[texel_of(x, z)] == 1.0
    # the pole is left out of the picture but still casts its shadow, 10 m long
    assert s[texel_of(9.5, 0.0)] < 1.0 and s[texel_of(-0.5, 0.0)] == 1.0


def test_a_sun_with_a_disc_gives_the_bakes_soft_shadows():
    """With the sun's angle (the bake's --sun-angle, or the light's own) the pole's 0.4 m wide
    shadow 7 m from its top is a penumbra: part of the disc stays visible, as in the bake."""
    b, lights = level()
    hard = bake(b, lights, shadows="separate").encoded.shadow
    soft = bake(b, lights, shadows="separate", sun_angle=10.0).encoded.shadow
    own = lights[0]
    own.angle = np.radians(10.0)
    assert np.array_equal(bake(b, [own], shadows="separate").encoded.shadow, soft)
    dark = hard[texel_of(5.0, 0.0)]
    assert dark < soft[texel_of(5.0, 0.0)] < 1.0
    assert np.count_nonzero((soft > dark + 0.01) & (soft < 0.99)) > np.count_nonzero((hard > dark + 0.01) & (hard < 0.99))
    assert soft[texel_of(-5.0, 0.0)] == 1.0  # full sun stays exactly unshadowed


def test_separate_and_alpha_give_back_the_picture():
    """ground = colour x shadow is the shadowed picture B again (to 8-bit precision)."""
    b, lights = level()
    for encoding in ("separate", "alpha"):
        gm = bake(b, lights, shadows=encoding)
        e = gm.encoded
        shadow = e.shadow if encoding == "separate" else e.color[..., 3]
        ground_term = radiosity_ground(e, e.color if e.color.shape[-1] == 4 else _rgba(e.color), shadow)
        assert np.allclose(ground_term * e.map_scale, gm.excident, atol=1e-4)
        sky = radiosity_sky(e, _rgba(e.color), shadow)
        lit = shadow == 1.0
        assert np.allclose(sky[lit] * e.map_scale, gm.sky_light, rtol=1e-5)


def _rgba(color):
    return color if color.shape[-1] == 4 else np.concatenate([color, np.ones(color.shape[:2] + (1,), np.float32)], -1)


# ------------------------------------------------------------------ hsv

def hsv_level():
    b = SceneBuilder()
    ground(b)
    patches(b, [(0.7, 0.1, 0.1), (0.1, 0.6, 0.2), (0.2, 0.3, 0.8), (0.6, 0.6, 0.1)])
    pole(b, x=-7.0, z=-1.0)
    pole(b, x=1.0, z=1.0)
    return b, [sun()]


def test_hsv_unshadowed_share_one_value_shadowed_are_darker_hue_and_saturation_kept(tmp_path):
    b, lights = hsv_level()
    gm = bake(b, lights, shadows="hsv", noise=0.1)
    e = gm.encoded
    hsv = rgb_to_hsv(e.color)
    original = rgb_to_hsv(gm.excident)
    sunny = gm.shadow == 1.0
    assert 0.01 < 1 - sunny.mean() < 0.5
    assert np.allclose(hsv[..., 2][sunny], 1.0)
    assert np.allclose(hsv[..., 2][~sunny], gm.shadow[~sunny], atol=1e-6)
    assert np.all(hsv[..., 2][~sunny] < 1.0)
    coloured = original[..., 1] > 0.05
    hue_gap = np.abs(hsv[..., 0] - original[..., 0])
    assert np.all(np.minimum(hue_gap, 1 - hue_gap)[coloured] < 1 / 255)
    assert np.all(np.abs(hsv[..., 1] - original[..., 1])[coloured] < 1 / 255)
    # stored as 8 bits: every unshadowed texel has V = 255
    write_groundmap(gm, tmp_path, "test", None)
    png = np.round(read_map_pixels(tmp_path, "groundmap.png") * 255).astype(int)
    assert np.all(png[sunny].max(axis=-1) == 255)
    assert np.all(png[~sunny].max(axis=-1) < 255)


def test_hsv_sky_term_in_shadow_is_darker_by_the_ground_ratio():
    b, lights = hsv_level()
    gm = bake(b, lights, shadows="hsv")
    e = gm.encoded
    texels = _rgba(e.color)
    ones = np.ones(texels.shape[:2], np.float32)
    ground_term = radiosity_ground(e, texels, ones)
    sky_term = radiosity_sky(e, texels, ones)
    lit, dark = texel_of(-5.0, 1.5), texel_of(-5.0, -1.0)   # the red patch, in the sun and in a pole's shadow
    assert gm.shadow[lit] == 1.0 and gm.shadow[dark] < 0.5
    ratio = gm.shadow[dark]
    assert np.allclose(ground_term[dark], ground_term[lit] * ratio, rtol=1e-5)
    assert np.allclose(sky_term[dark], sky_term[lit] * ratio, rtol=1e-5)
    # over unshadowed ground the sky term averages to the sky's light
    sunny = gm.shadow == 1.0
    assert np.allclose(sky_term[sunny].mean(axis=0) * e.map_scale, gm.sky_light, rtol=1e-3)
    assert np.allclose(gm.sky_light, sky_incident(Sky.uniform(SKY))[0], rtol=1e-4)


# ------------------------------------------------------------------ noise

def test_noise_is_seeded_and_bounded():
    b, lights = level()
    maps = [bake(b, lights, noise=0.1, seed=s).excident for s in (1, 1, 2)]
    plain = bake(b, lights, noise=0.0).excident
    assert np.array_equal(maps[0], maps[1]) and not np.array_equal(maps[0], maps[2])
    ratio = maps[0] / np.where(plain > 0, plain, 1)
    assert ratio[plain > 0].min() >= 0.9 - 1e-6 and ratio[plain > 0].max() <= 1.1 + 1e-6
    assert ratio[plain > 0].std() > 0.03


# ------------------------------------------------------------------ files

@pytest.mark.parametrize("encoding, block", [("hsv", "BC1"), ("alpha", "BC3"), ("separate", "BC1")])
def test_files_and_manifest(tmp_path, encoding, block):
    b, lights = level()
    gm = bake(b, lights, shadows=encoding, size=64)
    manifest = write_groundmap(gm, tmp_path, "test", "../bake")
    others = [e for e in ("separate", "alpha", "hsv") if e != encoding]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["groundmap.json", "groundmap.png", "groundmap.dds"] + (["shadow.png", "shadow.dds"] if encoding == "separate" else [])
        + [f"variant_{e}.png" for e in others] + (["variant_separate_shadow.png"] if "separate" in others else []))
    on_disk = json.loads((tmp_path / "groundmap.json").read_text())
    assert on_disk["encoding"] == encoding and on_disk["files"]["color"]["dds_format"] == block
    assert on_disk["mapping"]["U"] == pytest.approx([1 / 20, 0, 0, 0.5]) and on_disk["area"] == [-10, -10, 10, 10]
    assert on_disk["bake"] == "../bake" and "side" in on_disk["side_vector"] and len(on_disk["sky_scale"]) == 3
    dds = (tmp_path / "groundmap.dds").read_bytes()
    assert dds[:4] == b"DDS " and len(dds) - 128 == 64 * 64 * (8 if block == "BC3" else 4) // 8
    png = read_map_pixels(tmp_path, "groundmap.png")
    texels = decode_dds(tmp_path / "groundmap.dds")[..., :png.shape[-1]] / 255.0
    assert np.abs(texels - png).mean() < 4 / 255               # block compression stays close
    inputs = load_ground_map(tmp_path)
    assert inputs.encoding == encoding and inputs.map_scale == pytest.approx(manifest["map_scale"])
    assert np.array_equal(inputs.texture[..., :png.shape[-1]], png)


DDSD_CAPS, DDSD_HEIGHT, DDSD_WIDTH, DDSD_PITCH, DDSD_PIXELFORMAT, DDSD_LINEARSIZE = 0x1, 0x2, 0x4, 0x8, 0x1000, 0x80000


@pytest.mark.parametrize("width, height, channels, linear_size", [
    (256, 256, 3, 256 * 256 // 2),          # BC1: 8 bytes per 4 x 4 block
    (256, 256, 4, 256 * 256),               # BC3: 16 bytes per block
    (30, 10, 3, 8 * 3 * 8),                 # partial blocks count whole
    (2, 1, 4, 16),                          # at least one block
])
def test_the_dds_header_gives_the_top_levels_linear_size(width, height, channels, linear_size):
    """DDS_HEADER: DDSD_LINEARSIZE set, DDSD_PITCH clear and dwPitchOrLinearSize the bytes of the
    compressed top level, as strict loaders require."""
    rng = np.random.default_rng(3)
    pixels = rng.integers(0, 256, (height, width, channels), dtype=np.uint8)
    data, block = encode_dds(pixels)
    size, flags, h, w, pitch_or_linear = np.frombuffer(data[4:24], "<u4")
    assert data[:4] == b"DDS " and size == 124 and (h, w) == (height, width)
    assert data[84:88] == (b"DXT1" if channels == 3 else b"DXT5") and block == ("BC1" if channels == 3 else "BC3")
    assert flags & DDSD_LINEARSIZE and not flags & DDSD_PITCH
    assert flags & (DDSD_CAPS | DDSD_HEIGHT | DDSD_WIDTH | DDSD_PIXELFORMAT) == DDSD_CAPS | DDSD_HEIGHT | DDSD_WIDTH | DDSD_PIXELFORMAT
    assert pitch_or_linear == linear_size == len(data) - 128
    assert decode_dds_bytes(data).shape == (height, width, 4)          # still what Pillow reads


@pytest.mark.parametrize("damage", [
    lambda data: data[:84] + b"XYZW" + data[88:],  # a pixel format Pillow does not decode
    lambda data: data[:12] + (10**6).to_bytes(4, "little") * 2 + data[20:],  # 10^6 x 10^6 texels
    lambda data: data[:100],  # cut inside the header
])
def test_a_damaged_dds_file_is_one_clear_error(damage):
    data, _ = encode_dds(np.zeros((8, 8, 3), np.uint8))
    with pytest.raises(PatchlightError, match=r"^ground\.dds: (not a readable DDS file|image of)"):
        decode_dds_bytes(damage(data), "ground.dds")


def test_reopening_a_ground_map_directory_gives_exactly_the_written_map(tmp_path):
    """The viewer reads every variant from the files: the map's own PNG and DDS texels, and the
    other encodings' texels exactly as their encoder made them, with their constants."""
    b, lights = level()
    gm = bake(b, lights, shadows="separate", size=32, noise=0.1)
    manifest = write_groundmap(gm, tmp_path, "test", None)
    _, inputs = open_ground_map_dir(tmp_path)
    assert sorted(inputs.variants) == sorted(f"{e}-{k}" for e in ("separate", "alpha", "hsv") for k in ("png", "dds"))
    for name, (texels, shadow, scale, sky_scale) in inputs.variants.items():
        encoding, kind = name.split("-")
        e = gm.encode(encoding)
        written = to_bytes(e.color)
        if kind == "dds":
            written = block_compressed(written)
        assert np.array_equal(texels[..., :written.shape[-1]], written), name
        assert (shadow is None) == (e.shadow is None)
        if shadow is not None:
            grey = to_bytes(np.repeat(e.shadow[..., None], 3, -1))
            assert np.array_equal(shadow[..., :3], block_compressed(grey)[..., :3] if kind == "dds" else grey)
        assert scale == pytest.approx(e.map_scale) and np.allclose(sky_scale, e.sky_scale)
    assert np.array_equal(inputs.texture, load_ground_map(tmp_path).texture)
    assert np.array_equal(inputs.texture * 255, inputs.variants["separate-png"][0].astype(np.float32))
    assert inputs.map_scale == manifest["map_scale"] and np.allclose(inputs.sky_scale, manifest["sky_scale"])
    assert np.allclose(inputs.path, gm.path) and np.allclose(inputs.fog_color, gm.sky_light)


def test_the_cars_loop_lies_on_the_ground_when_the_scene_names_none():
    b, lights = level()
    gm = bake(b, lights, size=16)
    assert gm.path.shape == (96, 3) and np.allclose(gm.path[:, 1], 0.0)
    assert np.allclose(gm.path[:, [0, 2]].mean(axis=0), 0.0, atol=1e-6) and np.ptp(gm.path[:, 0]) == pytest.approx(12.0)


def test_a_second_map_in_the_same_directory_leaves_none_of_the_first_behind(tmp_path):
    b, lights = level()
    write_groundmap(bake(b, lights, shadows="hsv", size=16), tmp_path, "test", None)
    before = {p.name for p in tmp_path.iterdir()}
    write_groundmap(bake(b, lights, shadows="separate", size=16), tmp_path, "test", None)
    after = {p.name for p in tmp_path.iterdir()}
    assert "variant_separate.png" in before and "variant_separate.png" not in after
    assert {"shadow.png", "variant_hsv.png"} <= after and not [n for n in after if n.startswith(".")]


# ------------------------------------------------------------------ bad input

def test_bad_input_says_what_and_where():
    b, lights = level()
    with pytest.raises(PatchlightError, match="no ground under the area"):
        make_groundmap(solved(b, lights), GroundMapSettings(size=16, area=GroundArea(100, 100, 120, 120)))
    with pytest.raises(PatchlightError, match=r"^size: 20000 must be a whole number in 1\.\.16384 \(texels\)$"):
        make_groundmap(solved(b, lights), GroundMapSettings(size=20000))
    with pytest.raises(PatchlightError, match=r"^max_height: 0 must be a number > 0 \(m\)$"):
        make_groundmap(solved(b, lights), GroundMapSettings(size=16, max_height=0))
    for seed in (-1, 1.5, True):
        with pytest.raises(PatchlightError, match=f"^seed: {re.escape(repr(seed))} must be a whole number >= 0$"):
            make_groundmap(solved(b, lights), GroundMapSettings(size=16, seed=seed))
    with pytest.raises(PatchlightError, match="^offset_mode: 'sideways' must be one of none, normal, side$"):
        make_groundmap(solved(b, lights), GroundMapSettings(size=16, offset_mode="sideways"))


def test_a_plan_made_before_the_bake_is_used_only_for_the_same_level_and_settings():
    b, lights = level()
    level_scene = solved(b, lights)
    settings = GroundMapSettings(size=16, area=AREA, noise=0.0)
    plan = plan_groundmap(level_scene.scene, settings)
    assert plan.fits(level_scene.scene, settings)
    assert not plan.fits(level_scene.scene, GroundMapSettings(size=32, area=AREA, noise=0.0))
    other = SceneBuilder()
    ground(other, half=5.0)
    assert not plan.fits(solved(other, lights).scene, settings)
    fresh = make_groundmap(level_scene, settings)
    assert np.array_equal(make_groundmap(level_scene, settings, plan).encoded.color, fresh.encoded.color)
    # a plan of another level is not used
    assert np.array_equal(make_groundmap(level_scene, settings, plan_groundmap(other.scene("o"), settings)).encoded.color,
                          fresh.encoded.color)
    with pytest.raises(PatchlightError, match="no ground under the area.*the level spans x -10..10"):
        plan_groundmap(level_scene.scene, GroundMapSettings(size=16, area=GroundArea(100, 100, 120, 120)))


def test_no_sun_turns_shadows_off_with_one_warning():
    b, _ = level(with_sun=False)
    gm = bake(b, shadows="hsv")
    assert len(gm.warnings) == 1 and "no sun" in gm.warnings[0]
    assert np.all(gm.shadow == 1.0) and gm.sun is None


def test_a_map_swapped_in_while_it_is_read_is_read_whole_again(tmp_path, monkeypatch):
    """A rewrite landing between the manifest and the texels (here: during the first texel
    read) never pairs one map's manifest with the other's texels: the set is read again."""
    import patchlight.ground.files as files
    b, lights = level()
    small, large = bake(b, lights, size=32), bake(b, lights, size=64)
    write_groundmap(small, tmp_path, "small", "../bake")
    original, swaps = files.read_texels, []

    def swapping_read(directory, name):
        if not swaps:
            swaps.append(name)
            write_groundmap(large, tmp_path, "large", "../bake")
        return original(directory, name)

    monkeypatch.setattr(files, "read_texels", swapping_read)
    inputs = load_ground_map(tmp_path)
    assert swaps and inputs.texture.shape[:2] == (64, 64)
