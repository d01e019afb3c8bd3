"""Known answers for the punctual lights, their falloffs and the --light spec syntax."""
from __future__ import annotations

import math

import numpy as np
import pytest

from patchlight.cli.values import parse_light_spec
from patchlight.errors import PatchlightError
from patchlight.scene.model import Light
from patchlight.shading.lights import (directional_light, from_scene_light, incident_light,
                                       inverse_square_falloff, point_light, range_falloff, spot_cone, spot_light)


def test_range_falloff_reaches_zero_at_the_range_and_stays_there():
    r = 5.0
    d = np.array([0.0, 2.5, 5.0, 5.0001, 7.0, 100.0], np.float32)
    np.testing.assert_allclose(range_falloff(d, r), [1.0, 0.75, 0.0, 0.0, 0.0, 0.0], atol=1e-6)
    assert range_falloff(np.float32(5.0), r) == 0.0


def test_inverse_square_falloff_without_a_range_is_plain():
    d = np.array([1.0, 2.0, 4.0, 1000.0], np.float32)
    np.testing.assert_allclose(inverse_square_falloff(d, 0.0), 1 / d ** 2, rtol=1e-7)


def test_inverse_square_falloff_with_a_range_is_windowed_to_zero_at_it():
    """KHR_lights_punctual's range: zero from r on; 1/d^2 x (1 - (d/r)^4)^2 below it, so
    inverse-square to within 1 % up to r / 4."""
    r = 8.0
    d = np.array([0.5, 2.0, 4.0, 6.0, 7.99, 8.0, 8.01, 20.0], np.float32)
    f = inverse_square_falloff(d, r)
    window = np.clip(1 - (d.astype(np.float64) / r) ** 4, 0, 1) ** 2
    np.testing.assert_allclose(f, window / d.astype(np.float64) ** 2, rtol=1e-5)
    assert f[1] == pytest.approx(0.25 * (1 - 1 / 256) ** 2, rel=1e-6)  # d = r/4: 0.992 of 1/d^2
    assert f[2] == pytest.approx((15 / 16) ** 2 / 16, rel=1e-6)         # d = r/2
    np.testing.assert_allclose(f[:2] * d[:2] ** 2, 1.0, atol=0.008)     # well inside: inverse-square
    assert np.all(f[5:] == 0)                                           # at and beyond r: nothing
    assert np.all(np.diff(f[:6]) < 0)                                    # falls all the way


def test_a_lights_range_cuts_inverse_square_light_where_the_bake_reads_it():
    """The bake's direct light (radiosity/direct.py) goes through from_scene_light and
    incident_light: a point light with a range gives nothing beyond it, inverse-square inside."""
    lamp = Light("point", np.ones(3, np.float32), 12.0, position=np.zeros(3, np.float32), range=5.0)
    punctual = from_scene_light(lamp, "inverse-square", "lamp")
    P = np.array([[0.5, 0, 0], [4.99, 0, 0], [5.0, 0, 0], [9.0, 0, 0]], np.float32)
    _, I = incident_light(punctual, P)
    assert I[0, 0] == pytest.approx(12.0 / (np.pi * 0.25), rel=1e-3)
    assert 0 < I[1, 0] < 1e-5 and I[2, 0] == 0 and I[3, 0] == 0
    no_range = from_scene_light(Light("point", np.ones(3, np.float32), 12.0), "inverse-square", "lamp")
    assert incident_light(no_range, P)[1][3, 0] == pytest.approx(12.0 / (np.pi * 81), rel=1e-6)


def test_units_follow_design_md():
    """A sun of irradiance E gives I = E / pi; a point of intensity J at distance d gives J / (pi d^2)."""
    P = np.array([[0.0, 0.0, 0.0]])
    L, I = directional_light([0.0, -1.0, 0.0], [2.0, 4.0, 6.0], P)
    np.testing.assert_allclose(L, [[0, 1, 0]])
    np.testing.assert_allclose(I, [[2 / np.pi, 4 / np.pi, 6 / np.pi]])
    L, I = point_light([0.0, 3.0, 4.0], [10.0, 10.0, 10.0], 0.0, "inverse-square", P)
    np.testing.assert_allclose(L, [[0, 0.6, 0.8]])
    np.testing.assert_allclose(I, [[10 / (np.pi * 25)] * 3])
    _, I = point_light([0.0, 3.0, 4.0], [10.0, 10.0, 10.0], 10.0, "range", P)
    np.testing.assert_allclose(I, [[10 * 0.75 / np.pi] * 3])


def test_spot_cone_is_full_inside_zero_outside_and_smooth_between():
    inner, outer = math.radians(10), math.radians(30)
    down = np.array([0.0, -1.0, 0.0])
    angles = np.radians([0, 9.9, 20, 30.1, 60])
    L = np.stack([-np.sin(angles), np.cos(angles), np.zeros_like(angles)], axis=1)  # towards the light
    cone = spot_cone(L, down, math.cos(inner), math.cos(outer))
    t = (math.cos(math.radians(20)) - math.cos(outer)) / (math.cos(inner) - math.cos(outer))
    np.testing.assert_allclose(cone, [1.0, 1.0, t * t, 0.0, 0.0], atol=1e-6)
    P = np.array([[0.0, 0.0, 0.0]])
    _, I = spot_light([0.0, 2.0, 0.0], down, [8.0, 8.0, 8.0], 0.0, "inverse-square",
                      math.cos(inner), math.cos(outer), P)
    np.testing.assert_allclose(I, [[8 / (4 * np.pi)] * 3])


def test_parse_light_specs():
    sun = parse_light_spec("dir:0,-2,0:1,0.9,0.8:3")
    assert sun.kind == "directional" and sun.intensity == 3
    np.testing.assert_allclose(sun.direction, [0, -1, 0])
    lamp = parse_light_spec("point:1,2,3:1,1,1:50:4")
    assert lamp.kind == "point" and lamp.range == 4 and list(lamp.position) == [1, 2, 3]
    spot = parse_light_spec("spot:0,3,0:0,-1,0:1,1,1:80:40:20:9")
    assert spot.kind == "spot" and spot.range == 9
    assert spot.outer_cone == pytest.approx(math.radians(40)) and spot.inner_cone == pytest.approx(math.radians(20))


SPEC_FIELDS = [  # every field count of every kind: (spec, position, direction, colour, intensity, inner, outer, range)
    ("dir:0,-2,0:1,0.9,0.8:3", None, (0, -1, 0), (1, 0.9, 0.8), 3, None, None, None),
    ("point:1,2,3:0.5,0.6,0.7:50", (1, 2, 3), None, (0.5, 0.6, 0.7), 50, None, None, None),
    ("point:1,2,3:0.5,0.6,0.7:50:4", (1, 2, 3), None, (0.5, 0.6, 0.7), 50, None, None, 4),
    ("spot:0,2,0:0,-1,0:0.2,0.3,0.4:10:30", (0, 2, 0), (0, -1, 0), (0.2, 0.3, 0.4), 10, 0, 30, None),
    ("spot:0,2,0:0,-1,0:0.2,0.3,0.4:10:30:20", (0, 2, 0), (0, -1, 0), (0.2, 0.3, 0.4), 10, 20, 30, None),
    ("spot:0,2,0:0,-1,0:0.2,0.3,0.4:10:30:20:9", (0, 2, 0), (0, -1, 0), (0.2, 0.3, 0.4), 10, 20, 30, 9),
]


@pytest.mark.parametrize("spec, position, direction, colour, intensity, inner, outer, range_", SPEC_FIELDS,
                         ids=[s[0] for s in SPEC_FIELDS])
def test_every_field_count_of_every_kind_reads_each_field_in_its_place(spec, position, direction, colour,
                                                                      intensity, inner, outer, range_):
    light = parse_light_spec(spec)
    np.testing.assert_allclose(light.color, colour, rtol=1e-6)
    assert light.intensity == intensity and light.range == range_
    if position is not None:
        np.testing.assert_allclose(light.position, position)
    if direction is not None:
        np.testing.assert_allclose(light.direction, direction)
    if outer is not None:
        assert light.outer_cone == pytest.approx(math.radians(outer))
        assert light.inner_cone == pytest.approx(math.radians(inner))


@pytest.mark.parametrize("spec", [s[0] for s in SPEC_FIELDS])
def test_a_negative_colour_or_intensity_is_refused_at_every_field_count(spec):
    kind, *fields = spec.split(":")
    at = 2 if kind == "spot" else 1  # the colour field, the intensity after it
    for k, bad in ((at, "-1,1,1"), (at + 1, "-2")):
        broken = ":".join([kind, *fields[:k], bad, *fields[k + 1:]])
        with pytest.raises(PatchlightError, match="must not be negative"):
            parse_light_spec(broken)


@pytest.mark.parametrize("spec", ["lamp:0,0,0:1,1,1:1", "point:0,0:1,1,1:1", "point:0,0,0:1,1,1",
                                  "dir:0,0,0:1,1,1:1", "point:0,0,0:1,1,1:x", "spot:0,0,0:0,-1,0:1,1,1:1:30:40",
                                  "point:0,0,0:1,1,1:-3", "point:0,0,0:1,1,1:1:2:3",
                                  "point:0,0,0:1,1,1:1:0", "spot:0,0,0:0,-1,0:1,1,1:1:30:10:-2"])
def test_bad_light_specs_are_one_line_errors(spec):
    with pytest.raises(PatchlightError) as err:
        parse_light_spec(spec)
    assert "\n" not in str(err.value) and spec in str(err.value)


def test_range_falloff_needs_a_range():
    light = Light("point", np.ones(3, np.float32), 1.0)
    with pytest.raises(PatchlightError, match="range falloff needs a range"):
        from_scene_light(light, "range", "light 0")
    assert from_scene_light(light, "inverse-square", "light 0").falloff == "inverse-square"
