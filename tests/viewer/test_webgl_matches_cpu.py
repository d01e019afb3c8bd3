"""Every model and option, drawn by the viewer's GLSL in headless Chromium (SwiftShader
WebGL2), equals the CPU renderer's picture of the same scene and camera: over the pixels
both cover, mean |difference| < 1/255 and the 99th percentile < 4/255 (8-bit sRGB values
of the same film exposure, which both apply in their display transform). Besides the
showcase's one light of each kind, cases with several lights of each kind (up to MAX_LIGHTS)."""
from __future__ import annotations

import numpy as np
import pytest
from browser_support import difference
from render_scenes import (SHOWCASE_CAMERA, _box, _quad, directional_maps, lightmap_image, normal_texture,
                           scene_from_parts, showcase_target, uv_sphere)

from patchlight.render import Camera, Renderer, target_settings
from patchlight.render.output import display_pixels
from patchlight.shading import LIT_MODELS, MODELS
from patchlight.render.target import Target
from patchlight.scene.model import Light, Material
from patchlight.shading.lights import MAX_LIGHTS, from_scene_light
from patchlight.shading.textures import _bilinear_taps, cube_face_coords, sample_cube
from patchlight.viewer.app import make_server

SIZE = 128
EXPOSURE = 1.0
CAMERA = {"eye": list(SHOWCASE_CAMERA[0]), "target": list(SHOWCASE_CAMERA[1]), "fov": SHOWCASE_CAMERA[2]}


def _light(kind, color, strength, position=(0.0, 0.0, 0.0), direction=(0.0, -1.0, 0.0), range_=None,
           cone=(0.0, 0.5)) -> Light:
    d = np.asarray(direction, np.float32)
    return Light(kind, np.array(color, np.float32), strength, position=np.array(position, np.float32),
                 direction=d / np.linalg.norm(d), range=range_, inner_cone=cone[0], outer_cone=cone[1])


# Several lights of each kind at once: every slot of the shaders' light arrays in use.
LIGHT_SETS = {
    "pairs": [  # two of each kind; one point light without a range
        _light("directional", (1.0, 0.9, 0.8), 2.0, direction=(-0.3, -0.8, -0.5)),
        _light("directional", (0.3, 0.4, 1.0), 1.5, direction=(0.6, -0.5, 0.2)),
        _light("point", (1.0, 0.3, 0.2), 15.0, position=(2.0, 1.2, 1.5), range_=5.0),
        _light("point", (0.2, 1.0, 0.4), 10.0, position=(-1.8, 0.8, 1.8)),
        _light("spot", (1.0, 1.0, 0.6), 40.0, position=(1.5, 2.5, 1.0), direction=(-0.4, -1.0, -0.3),
               range_=6.0, cone=(0.2, 0.45)),
        _light("spot", (0.6, 0.6, 1.0), 30.0, position=(-1.0, 2.0, -1.5), direction=(0.3, -1.0, 0.5),
               range_=7.0, cone=(0.1, 0.35)),
    ],
    "eight": [  # MAX_LIGHTS: four points and four spots, all with a range
        *(_light("point", c, 8.0, position=p, range_=r) for c, p, r in [
            ((1.0, 0.2, 0.2), (2.2, 0.5, 1.2), 3.5), ((0.2, 1.0, 0.2), (-2.0, 0.3, 1.0), 4.0),
            ((0.2, 0.3, 1.0), (0.5, 1.8, 2.0), 3.0), ((1.0, 1.0, 0.3), (-0.5, 0.0, -2.2), 5.0)]),
        *(_light("spot", c, 25.0, position=p, direction=d, range_=6.0, cone=(0.15, 0.4)) for c, p, d in [
            ((1.0, 0.6, 0.2), (0.0, 3.0, 0.0), (0.0, -1.0, 0.0)), ((0.3, 1.0, 1.0), (2.5, 2.0, 2.5), (-1, -1, -1)),
            ((1.0, 0.3, 1.0), (-2.5, 2.0, 2.0), (1, -1.2, -1)), ((0.8, 0.8, 0.8), (2.0, 1.5, -2.5), (-0.5, -1, 1))]),
    ],
}
assert len(LIGHT_SETS["eight"]) == MAX_LIGHTS


def case_list() -> list[dict]:
    cases = []
    for model in MODELS:
        variants = [{}]
        if model in LIT_MODELS and model != "ambient":
            variants += [{"per_vertex": True}, {"normal_map": True}, {"falloff": "range"}]
        if model == "lightmap":
            variants += [{"lightmap_specular": True}, {"lightmap_specular": True, "per_vertex": True},
                         {"lightmap_specular": True, "normal_map": True}]
        if model == "lightmap-directional":  # per pixel only
            variants = [{}, {"normal_map": True}, {"lightmap_specular": True, "normal_map": True}]
        for options in variants:
            name = "-".join([model, *(k if v is True else str(v) for k, v in options.items())])
            cases.append({"name": name, "model": model, **options})
    for name, model, lights, options in [("lambert-pairs", "lambert", "pairs", {}),
                                         ("phong-pairs", "phong", "pairs", {}),
                                         ("blinn-phong-pairs-per_vertex", "blinn-phong", "pairs", {"per_vertex": True}),
                                         ("self-shadow-pairs-normal_map", "self-shadow", "pairs", {"normal_map": True}),
                                         ("lambert-eight-range", "lambert", "eight", {"falloff": "range"}),
                                         ("phong-eight", "phong", "eight", {})]:
        cases.append({"name": name, "model": model, "lights": lights, **options})
    return cases


def page_lights(name: str, falloff: str = "inverse-square") -> list[dict]:
    """A light set as the manifest lists lights (the page's renderCase takes them so)."""
    return [from_scene_light(light, falloff, name).to_json() for light in LIGHT_SETS[name]]


CASES = case_list()


@pytest.fixture(scope="module")
def showcase():
    target = showcase_target()
    return target, Renderer(target)


@pytest.fixture(scope="module")
def webgl(browser, showcase, tmp_path_factory):
    """{case name: (SIZE, SIZE, 4) uint8} from one Chromium run over every case."""
    target, _ = showcase
    specs = [dict(c, camera=CAMERA, width=SIZE, height=SIZE, exposure=EXPOSURE) for c in CASES]
    for spec in specs:
        if "lights" in spec:
            spec["lights"] = page_lights(spec["lights"])
    with make_server(target, target_settings(target), exposure=EXPOSURE) as server:
        pictures, _ = browser.cases(server.url, specs, tmp_path_factory.mktemp("webgl"))
    return pictures


def cpu_picture(showcase, case: dict) -> tuple[np.ndarray, np.ndarray]:
    target, renderer = showcase
    options = {k: v for k, v in case.items() if k not in ("name", "model", "lights")}
    lights = LIGHT_SETS[case["lights"]] if "lights" in case else None
    settings = target_settings(target, model=case["model"], lights=lights, **options)
    camera = Camera(np.array(CAMERA["eye"]), np.array(CAMERA["target"]), CAMERA["fov"])
    result = renderer.render(settings, camera, SIZE, SIZE)
    return display_pixels(result.radiance, EXPOSURE), result.covered


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_webgl_equals_cpu(webgl, showcase, case):
    mean, p99 = difference(webgl[case["name"]], *cpu_picture(showcase, case))
    print(f"{case['name']}: mean {mean:.3f}/255, p99 {p99:.1f}/255")
    assert mean < 1.0 and p99 < 4.0


@pytest.mark.parametrize("gpu_case, cpu_case", [("phong", "blinn-phong"), ("lambert", "lambert-per_vertex"),
                                                ("lambert", "lambert-normal_map"), ("lambert", "lambert-range"),
                                                ("phong", "self-shadow"), ("lightmap", "lightmap-lightmap_specular"),
                                                ("lambert", "envmap"), ("lambert", "hemisphere"),
                                                ("lambert", "lambert-pairs"), ("lambert-pairs", "lambert-eight-range"),
                                                ("lightmap-normal_map", "lightmap-directional-normal_map"),
                                                ("lightmap-directional-normal_map",
                                                 "lightmap-directional-lightmap_specular-normal_map")])
def test_the_comparison_tells_every_option_apart(webgl, showcase, gpu_case, cpu_case):
    """The thresholds are tight enough to fail when the two sides shade differently."""
    case = next(c for c in CASES if c["name"] == cpu_case)
    mean, p99 = difference(webgl[gpu_case], *cpu_picture(showcase, case))
    assert mean >= 1.0 or p99 >= 4.0


ENVMAP_FROM = (0.0, 0.5, 2.5)


def test_envmap_from_a_point_reflects_that_cube_with_the_sky_behind(browser, showcase, tmp_path):
    """With --envmap-from the page reflects the cube rendered from that point, and behind the
    scene draws the scene's own sky (not that cube), both as the CPU renderer does."""
    target, _ = showcase
    specs = [dict(name=name, model="envmap", sky=name == "sky", camera=CAMERA, width=SIZE, height=SIZE,
                  exposure=EXPOSURE) for name in ("envmap", "sky")]
    with make_server(target, target_settings(target), exposure=EXPOSURE, envmap_from=ENVMAP_FROM) as server:
        gpu, _ = browser.cases(server.url, specs, tmp_path)
    renderer = Renderer(target, ENVMAP_FROM)
    camera = Camera(np.array(CAMERA["eye"]), np.array(CAMERA["target"]), CAMERA["fov"])
    result = renderer.render(target_settings(target, model="envmap"), camera, SIZE, SIZE)
    cpu = display_pixels(result.radiance, EXPOSURE)
    mean, p99 = difference(gpu["envmap"], cpu, result.covered)
    assert mean < 1.0 and p99 < 4.0
    behind = ~result.covered
    assert behind.sum() > 0.1 * SIZE * SIZE and np.all(gpu["sky"][..., 3] == 255)
    sky_diff = np.abs(gpu["sky"][..., :3].astype(int) - cpu.astype(int))[behind]
    assert sky_diff.mean() < 1.0 and np.percentile(sky_diff, 99) < 4.0
    _, directions = camera.rays(SIZE, SIZE)
    env = renderer.environment(target_settings(target))
    env_behind = display_pixels(sample_cube(env[..., :3], directions[behind.ravel()])[None], EXPOSURE)[0]
    assert np.abs(gpu["sky"][..., :3][behind].astype(int) - env_behind.astype(int)).mean() > 4.0  # not the env


def mirror_in_a_painted_room() -> Target:
    """A room of six walls in six colours, lit by ambient light only, and a mirror sphere below
    its centre: the environment cube seen from the centre holds one wall per face, so its
    seams are where the colour changes, and the mirror shows every seam."""
    colours = [(0.9, 0.1, 0.1), (0.1, 0.8, 0.1), (0.1, 0.2, 0.9), (0.9, 0.9, 0.1), (0.1, 0.9, 0.9), (0.9, 0.1, 0.9)]
    walls = []
    for positions, normals, uv, indices in _box([-3, -3, -3], [3, 3, 3]):
        walls.append((positions, -normals, uv, indices[:, ::-1].copy()))  # facing into the room
    materials = [Material(name=f"wall {k}", base_color=np.array([*c, 1], np.float32)) for k, c in enumerate(colours)]
    materials.append(Material(name="mirror", base_color=np.array([0.0, 0.0, 0.0, 1], np.float32), reflectivity=1.0))
    scene = scene_from_parts(walls + [uv_sphere(24, 48, 1.0, (0.0, -1.6, 0.0))], materials, list(range(7)))
    return Target.from_scene(scene)


def _clamped_cube(faces, directions):
    """The cube lookup without seamless filtering (each face clamped at its edges)."""
    face, s, t = cube_face_coords(directions)
    size = faces.shape[1]
    x0, x1, fx = _bilinear_taps(s, size, "clamp")
    y0, y1, fy = _bilinear_taps(t, size, "clamp")
    fx, fy = fx[:, None], fy[:, None]
    return ((faces[face, y0, x0] * (1 - fx) + faces[face, y0, x1] * fx) * (1 - fy)
            + (faces[face, y1, x0] * (1 - fx) + faces[face, y1, x1] * fx) * fy).astype(np.float32)


def test_the_environment_cube_is_filtered_across_its_seams_as_webgl_does(browser, tmp_path, monkeypatch):
    target = mirror_in_a_painted_room()
    settings = target_settings(target, model="envmap", ambient=(1.0, 1.0, 1.0))
    camera = {"eye": [0.0, 0.6, 2.9], "target": [0.0, -1.6, 0.0], "fov": 40.0}
    spec = dict(name="mirror", model="envmap", camera=camera, width=SIZE, height=SIZE, exposure=EXPOSURE)
    with make_server(target, settings, exposure=EXPOSURE, envmap_from=(0.0, 0.0, 0.0)) as server:
        gpu = browser.cases(server.url, [spec], tmp_path)[0]["mirror"]
    renderer = Renderer(target, envmap_from=(0.0, 0.0, 0.0))
    view = Camera(np.array(camera["eye"]), np.array(camera["target"]), camera["fov"])
    seamless = renderer.render(settings, view, SIZE, SIZE)
    monkeypatch.setattr("patchlight.shading.models.sample_cube", _clamped_cube)
    clamped = display_pixels(renderer.render(settings, view, SIZE, SIZE).radiance, EXPOSURE).astype(int)
    cpu = display_pixels(seamless.radiance, EXPOSURE)
    mean, p99 = difference(gpu, cpu, seamless.covered)
    assert mean < 1.0 and p99 < 4.0
    seams = np.abs(clamped - cpu.astype(int)).max(axis=-1) > 8
    assert seams.sum() > 20  # the mirror shows seams where the two filters differ ...
    at_seams = np.abs(gpu[..., :3].astype(int) - cpu.astype(int))[seams]
    to_clamped = np.abs(gpu[..., :3].astype(int) - clamped)[seams]
    # ... and there WebGL agrees with the seamless filter (measured: 2/255 against 15/255)
    assert at_seams.mean() < 4.0 and at_seams.mean() < 0.25 * to_clamped.mean()


def test_dominant_direction_lightmaps_match_too(browser, tmp_path):
    """The lightmap-directional model with a dominant-direction map (the showcase has L1 SH)."""
    target = showcase_target(directional="dominant")
    renderer = Renderer(target)
    cases = [{"name": "dominant", "model": "lightmap-directional", "normal_map": True},
             {"name": "dominant-specular", "model": "lightmap-directional", "normal_map": True,
              "lightmap_specular": True}]
    specs = [dict(c, camera=CAMERA, width=SIZE, height=SIZE, exposure=EXPOSURE) for c in cases]
    with make_server(target, target_settings(target), exposure=EXPOSURE) as server:
        pictures, _ = browser.cases(server.url, specs, tmp_path)
    for case in cases:
        mean, p99 = difference(pictures[case["name"]], *cpu_picture((target, renderer), case))
        print(f"{case['name']}: mean {mean:.3f}/255, p99 {p99:.1f}/255")
        assert mean < 1.0 and p99 < 4.0


def test_a_double_sided_normal_mapped_quad_matches_from_behind(browser, tmp_path):
    """Seen from below, a double-sided normal-mapped quad lit from below: the GLSL and the CPU
    turn the whole tangent frame on the back face (glTF's convention), model by model."""
    quad = _quad([[-2, 0, 2], [2, 0, 2], [2, 0, -2], [-2, 0, -2]], [0, 1, 0])
    material = Material(name="sheet", base_color=np.float32([0.8, 0.8, 0.75, 1.0]), double_sided=True,
                        normal_texture=normal_texture(), shininess=12.0)
    lights = [_light("directional", (1.0, 0.95, 0.9), 3.0, direction=(0.6, 0.7, 0.2)),
              _light("point", (0.4, 0.6, 1.0), 6.0, position=(-0.8, -1.2, 0.5), range_=5.0)]
    target = Target.from_scene(scene_from_parts([quad], [material], [0], lights, uv1_boxes=[(0.0, 0.0, 1.0, 1.0)]),
                               lightmap_image())
    target.directional = directional_maps("dominant")
    camera = {"eye": [0.6, -3.0, 1.5], "target": [0.0, 0.0, 0.0], "fov": 50.0}
    cases = [{"name": "lambert", "model": "lambert", "normal_map": True},
             {"name": "blinn-phong", "model": "blinn-phong", "normal_map": True},
             {"name": "directional", "model": "lightmap-directional", "normal_map": True, "lightmap_specular": True}]
    specs = [dict(c, camera=camera, width=SIZE, height=SIZE, exposure=EXPOSURE) for c in cases]
    with make_server(target, target_settings(target), exposure=EXPOSURE) as server:
        pictures, _ = browser.cases(server.url, specs, tmp_path)
    renderer = Renderer(target)
    view = Camera(np.array(camera["eye"]), np.array(camera["target"]), camera["fov"])
    for case in cases:
        settings = target_settings(target, model=case["model"], normal_map=True,
                                   lightmap_specular=case.get("lightmap_specular", False))
        result = renderer.render(settings, view, SIZE, SIZE)
        mean, p99 = difference(pictures[case["name"]], display_pixels(result.radiance, EXPOSURE), result.covered)
        print(f"back face, {case['name']}: mean {mean:.3f}/255, p99 {p99:.1f}/255")
        assert mean < 1.0 and p99 < 4.0, case["name"]
