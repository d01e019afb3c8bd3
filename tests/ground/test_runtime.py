"""The hemisphere-radiosity model's NumPy reference: where it samples the map, what it makes
of the texels in each encoding, and the listing's composition, against known answers."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import patchlight.shaders as shaders_pkg
from patchlight.errors import PatchlightError
from patchlight.shading.hemisphere_radiosity import (ENCODINGS, OFFSET_MODES, GroundMapInputs, apply_fog, fog_factor,
                                                      hemisphere_radiosity, hemisphere_radiosity_color,
                                                      neutral_ground_map)
from patchlight.shading.models import ShadingSettings

SIZE = 8          # an 8 x 8 map over x, z in [0, 8]: texel (i, j) covers x in [j, j+1], z in [i, i+1]
SKY_SCALE = np.array([0.2, 0.3, 0.9], np.float32)


def texel_rgb(i: int, j: int) -> np.ndarray:
    return np.array([(j + 0.5) / SIZE, (i + 0.5) / SIZE, 0.25], np.float32)


def inputs(encoding="alpha", **options) -> GroundMapInputs:
    texture = np.ones((SIZE, SIZE, 4), np.float32)
    for i in range(SIZE):
        for j in range(SIZE):
            texture[i, j, :3] = texel_rgb(i, j)
    U = np.array([1 / SIZE, 0, 0, 0], np.float32)
    V = np.array([0, 0, 1 / SIZE, 0], np.float32)
    return GroundMapInputs(texture=texture, U=U, V=V, encoding=encoding, map_scale=2.0, sky_scale=SKY_SCALE, **options)


def radiosity_at(m, point, normal) -> np.ndarray:
    return hemisphere_radiosity(m, np.array([point], np.float32), np.array([normal], np.float32))[0]


P = (3.5, 1.2, 4.5)  # over the centre of texel (4, 3)


def test_up_facing_gets_the_sky_term():
    for mode in OFFSET_MODES:
        assert np.allclose(radiosity_at(inputs(offset_mode=mode), P, (0, 1, 0)), SKY_SCALE)


def test_down_facing_gets_the_texel_straight_below():
    for mode in OFFSET_MODES:
        assert np.allclose(radiosity_at(inputs(offset_mode=mode, offset=1.0), P, (0, -1, 0)), texel_rgb(4, 3))


def test_side_facing_samples_the_texel_offset_to_that_side():
    m = inputs(offset_mode="normal", offset=2.0)
    half = 0.5 * SKY_SCALE
    assert np.allclose(radiosity_at(m, P, (1, 0, 0)), 0.5 * texel_rgb(4, 5) + half)
    assert np.allclose(radiosity_at(m, P, (-1, 0, 0)), 0.5 * texel_rgb(4, 1) + half)
    assert np.allclose(radiosity_at(m, P, (0, 0, 1)), 0.5 * texel_rgb(6, 3) + half)
    assert np.allclose(radiosity_at(inputs(offset_mode="none"), P, (1, 0, 0)), 0.5 * texel_rgb(4, 3) + half)


def test_side_mode_offsets_only_the_left_right_part():
    half = 0.5 * SKY_SCALE
    m = inputs(offset_mode="side", offset=2.0, side=np.array([1.0, 0, 0], np.float32))
    assert np.allclose(radiosity_at(m, P, (0, 0, 1)), 0.5 * texel_rgb(4, 3) + half)    # forward: exact position
    assert np.allclose(radiosity_at(m, P, (0, 0, -1)), 0.5 * texel_rgb(4, 3) + half)   # backward too
    assert np.allclose(radiosity_at(m, P, (1, 0, 0)), 0.5 * texel_rgb(4, 5) + half)    # sideways: offset
    turned = inputs(offset_mode="side", offset=2.0, side=np.array([0, 0, 1.0], np.float32))  # the car turned 90 degrees
    assert np.allclose(radiosity_at(turned, P, (1, 0, 0)), 0.5 * texel_rgb(4, 3) + half)


def test_each_encoding_reads_the_shadow_where_it_keeps_it():
    shade = 0.25
    texel = np.array([[0.8, 0.4, 0.2, shade]], np.float32)
    shadow = np.full((1, 1, 4), shade, np.float32)
    down, up = np.array([[0, -1.0, 0]], np.float32), np.array([[0, 1.0, 0]], np.float32)
    p = np.zeros((1, 3), np.float32)
    expected = {  # (ground, sky)
        "alpha": (texel[0, :3] * shade, SKY_SCALE * shade),
        "separate": (texel[0, :3] * shade, SKY_SCALE * shade),
        "hsv": (texel[0, :3], SKY_SCALE * texel[0, :3].mean()),
    }
    for encoding in ENCODINGS:
        m = GroundMapInputs(texture=texel.reshape(1, 1, 4) if encoding != "separate" else
                            np.concatenate([texel[:, :3], [[1.0]]], 1).reshape(1, 1, 4).astype(np.float32),
                            U=np.zeros(4, np.float32), V=np.zeros(4, np.float32), encoding=encoding, map_scale=1.0,
                            sky_scale=SKY_SCALE, shadow=shadow if encoding == "separate" else np.ones((1, 1, 4), np.float32))
        ground, sky = expected[encoding]
        assert np.allclose(hemisphere_radiosity(m, p, down)[0], ground), encoding
        assert np.allclose(hemisphere_radiosity(m, p, up)[0], sky), encoding


def test_composition_is_the_listing_with_neutral_levels():
    """A white diffuse surface under a uniform map value 0.5 and no sun shows the map's
    radiance 0.5 map_scale; the sun raises it by 1 + I N.L / A; the x2 modulations multiply."""
    m = GroundMapInputs(texture=np.full((1, 1, 4), 0.5, np.float32), U=np.zeros(4), V=np.zeros(4), encoding="hsv",
                        map_scale=4.0, sky_scale=np.ones(3, np.float32))
    white = np.ones((1, 3), np.float32)
    env = np.zeros((1, 4), np.float32)
    ambient = np.array([0.2, 0.2, 0.2], np.float32)
    R = np.full((1, 3), 0.5, np.float32)
    no_sun = hemisphere_radiosity_color(m, white, env, ambient[None], np.zeros(1), R, 0.0, ambient)
    assert np.allclose(no_sun, 0.5 * 4.0)
    sun = hemisphere_radiosity_color(m, white, env, ambient[None] + 0.6, np.zeros(1), R, 0.0, ambient)
    assert np.allclose(sun, 2.0 * (1 + 0.6 / 0.2))
    grey = hemisphere_radiosity_color(m, 0.5 * white, env, ambient[None], np.zeros(1), 0.25 * R / 0.5, 0.0, ambient)
    assert np.allclose(grey, 2.0 * 0.5 * 0.5)
    mirror = hemisphere_radiosity_color(m, white, np.array([[6.0, 6.0, 6.0, 0.0]], np.float32), ambient[None],
                                        np.ones(1), R, 1.0, ambient)
    assert np.allclose(mirror, 6.0)   # a perfect mirror under neutral light shows the environment's radiance


def test_fog_is_linear_in_distance():
    m = inputs(fog_range=(10.0, 30.0), fog_color=np.array([1.0, 2.0, 3.0], np.float32))
    points = np.array([[5, 0, 0], [20, 0, 0], [40, 0, 0]], np.float32)
    f = fog_factor(m, points, np.zeros(3, np.float32))
    assert np.allclose(f, [1.0, 0.5, 0.0])
    assert np.allclose(apply_fog(m, np.zeros((3, 3), np.float32), f)[1], [0.5, 1.0, 1.5])
    assert np.all(fog_factor(inputs(), points, np.zeros(3)) == 1.0)


def test_neutral_fallback_is_the_plain_hemisphere():
    sky, ground = np.array([1.0, 2.0, 4.0], np.float32), np.array([0.5, 0.4, 0.3], np.float32)
    m = neutral_ground_map(sky, ground)
    p = np.zeros((2, 3), np.float32)
    R = hemisphere_radiosity(m, p, np.array([[0, 1.0, 0], [0, -1.0, 0]], np.float32)) * m.map_scale
    assert np.allclose(R, [sky, ground])


def test_glsl_ids_match_the_reference():
    text = (Path(shaders_pkg.__path__[0]) / "hemisphere_radiosity.glsl").read_text()
    defines = dict(re.findall(r"^#define\s+(\w+)\s+(\d+)", text, re.M))
    assert [int(defines[f"RADIOSITY_{e.upper()}"]) for e in ENCODINGS] == [0, 1, 2]
    assert [int(defines[f"OFFSET_{m.upper()}"]) for m in OFFSET_MODES] == [0, 1, 2]


def test_settings_refuse_what_the_model_cannot_use():
    with pytest.raises(PatchlightError, match="ambient"):
        ShadingSettings(model="hemisphere-radiosity", ambient=np.zeros(3, np.float32)).validate()
    with pytest.raises(PatchlightError, match="^offset_mode: 'sideways' must be one of none, normal, side$"):
        ShadingSettings(model="hemisphere-radiosity", ground_map=inputs(offset_mode="sideways")).validate()
    with pytest.raises(PatchlightError, match="unit length"):
        ShadingSettings(model="hemisphere-radiosity", ground_map=inputs(side=np.array([2.0, 0, 0]))).validate()
