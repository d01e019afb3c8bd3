"""Normal maps baked from a high-poly model: known answers (a plane over a sphere gives the
sphere's analytic normals, a flat high-poly gives (0.5, 0.5, 1)), cage and object space, AO
against a wall, and the map dropped into `render --normal-map`."""
from __future__ import annotations

import numpy as np
import pytest

from gltf_builder import Builder
from patchlight.cli.main import main
from patchlight.cli.options import use_normal_map
from patchlight.scene.model import Light
from patchlight.imaging.io import read_image
from patchlight.normalmap import NormalMapSettings, bake_normal_map
from patchlight.scene import load_scene

HALF = 0.6   # the low plane spans [-HALF, HALF] in x and z
HEIGHT = 1.1  # ... at this height, over the unit sphere at the origin
SIZE = 32


def _glb(path, positions, indices, normals, uv0=None):
    b = Builder()
    attrs = {"NORMAL": np.asarray(normals, np.float32)}
    if uv0 is not None:
        attrs["TEXCOORD_0"] = np.asarray(uv0, np.float32)
    b.mesh(b.primitive(np.asarray(positions, np.float32), indices, **attrs))
    b.scene(b.node(mesh=0))
    return b.glb(path)


def _plane(path, y, half=HALF, x0=None, n=4):
    """An n x n grid over [x0 or -half, half] x [-half, half] at height y facing +Y; u along +x, v along +z."""
    xs = np.linspace(-half if x0 is None else x0, half, n + 1)
    zs = np.linspace(-half, half, n + 1)
    x, z = np.meshgrid(xs, zs, indexing="xy")
    positions = np.stack([x.ravel(), np.full(x.size, y), z.ravel()], 1)
    uv = np.stack([(x.ravel() - xs[0]) / (xs[-1] - xs[0]), (z.ravel() + half) / (2 * half)], 1)
    quads = [(j * (n + 1) + i, (j + 1) * (n + 1) + i, j * (n + 1) + i + 1) for j in range(n) for i in range(n)]
    quads += [(j * (n + 1) + i + 1, (j + 1) * (n + 1) + i, (j + 1) * (n + 1) + i + 1) for j in range(n) for i in range(n)]
    return _glb(path, positions, np.array(quads), np.tile([0, 1, 0], (len(positions), 1)), uv)


def _sphere(path, rings=96, segments=192):
    theta = np.linspace(0, np.pi, rings + 1)
    phi = np.linspace(0, 2 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    positions = np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    k = segments + 1
    tris = [(r * k + s, r * k + s + 1, (r + 1) * k + s) for r in range(rings) for s in range(segments)]
    tris += [(r * k + s + 1, (r + 1) * k + s + 1, (r + 1) * k + s) for r in range(rings) for s in range(segments)]
    return _glb(path, positions, np.array(tris), positions)


def _texel_points():
    """World (x, z) of each texel centre of the SIZE x SIZE map over the low plane, (SIZE, SIZE) each."""
    c = (np.arange(SIZE) + 0.5) / SIZE * 2 * HALF - HALF
    z, x = np.meshgrid(c, c, indexing="ij")  # row = v = z, column = u = x
    return x, z


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("normalmap")
    return {"sphere": _sphere(d / "sphere.glb"), "low": _plane(d / "low.glb", HEIGHT),
            "cage": _plane(d / "cage.glb", HEIGHT + 0.6), "flat": _plane(d / "flat.glb", 0.0, half=3.0), "dir": d}


def _analytic():
    x, z = _texel_points()
    return np.stack([x, np.sqrt(1 - x * x - z * z), z], -1)


def test_plane_over_a_sphere_gets_the_spheres_analytic_normals_in_tangent_space(files):
    result = bake_normal_map(load_scene(files["sphere"]), load_scene(files["low"]),
                             NormalMapSettings(SIZE, SIZE, distance=1.2))
    assert result.hit.all()
    world = _analytic()
    # frame: T = +x (u), N = +y, B = cross(N, T) = -z, up the image (towards -v)
    expected = np.stack([world[..., 0], -world[..., 2], world[..., 1]], -1)
    assert np.abs(result.normal - expected).max() < 2e-3
    decoded = result.encoded() / 255.0 * 2 - 1
    assert np.abs(decoded - expected).max() < 6e-3  # 8-bit steps are 2/255


def test_cage_and_object_space_give_the_same_sphere(files):
    settings = NormalMapSettings(SIZE, SIZE, cage=load_scene(files["cage"]), space="object")
    result = bake_normal_map(load_scene(files["sphere"]), load_scene(files["low"]), settings)
    assert result.hit.all()
    assert np.abs(result.normal - _analytic()).max() < 2e-3


def test_flat_high_poly_gives_the_flat_texel_and_open_ao_through_the_cli(files, tmp_path):
    out, ao = tmp_path / "n.png", tmp_path / "ao.png"
    assert main(["normalmap", str(files["flat"]), str(files["low"]), "-o", str(out), "--size", "16x16",
                 "--distance", "2", "--ao", str(ao), "--ao-rays", "16", "--quiet"]) == 0
    pixels = np.rint(read_image(out) * 255).astype(int)
    assert pixels.shape == (16, 16, 3) and (pixels == [128, 128, 255]).all()
    assert (read_image(ao) == 1.0).all()


def test_ao_beside_a_wall_matches_the_strip_form_factor(tmp_path):
    """A floor texel x metres from a long wall of height H: the wall covers the cosine-weighted
    share (1 - x / sqrt(x^2 + H^2)) / 2 of its sky, half of it at the wall's foot."""
    b = Builder()
    floor = np.array([[-1, 0, -50], [50, 0, -50], [50, 0, 50], [-1, 0, 50]], np.float32)
    wall = np.array([[0, 0, -50], [0, 1, -50], [0, 1, 50], [0, 0, 50]], np.float32)
    positions = np.concatenate([floor, wall])
    normals = np.array([[0, 1, 0]] * 4 + [[1, 0, 0]] * 4, np.float32)
    b.mesh(b.primitive(positions, np.array([[0, 2, 1], [0, 3, 2], [4, 6, 5], [4, 7, 6]]), NORMAL=normals))
    b.scene(b.node(mesh=0))
    high = b.glb(tmp_path / "corner.glb")
    low = _plane(tmp_path / "strip.glb", 0.01, half=0.5, x0=0.002, n=1)
    result = bake_normal_map(load_scene(high), load_scene(low),
                             NormalMapSettings(8, 8, distance=0.05, ao_rays=1024, ao_distance=1e3))
    x = 0.002 + (np.arange(8) + 0.5) / 8 * 0.498  # texel centres' distance from the wall
    expected = 1 - (1 - x / np.sqrt(x * x + 1)) / 2
    assert np.abs(result.ao - expected[None, :]).max() < 0.03
    assert expected[-1] - expected[0] > 0.15  # the test can tell a wall from none


@pytest.mark.parametrize("light", [(1, 0, 0), (0, 0, 1), (-0.5, 0.3, -1)])
def test_the_map_drops_into_render_normal_map(files, tmp_path, light):
    """The flat low plane wearing the sphere's map lights as the sphere's analytic normals do,
    pixel by pixel, for lights along u (red), along v (green, +Y up the image) and between."""
    from patchlight.render import Camera, Renderer, Target, target_settings
    from patchlight.scene import load_scene

    normal = tmp_path / "n.png"
    assert main(["normalmap", str(files["sphere"]), str(files["low"]), "-o", str(normal), "--size", "64x64",
                 "--distance", "1.2", "--quiet"]) == 0
    target = Target.from_scene(load_scene(str(files["low"])))
    use_normal_map(target, normal)
    to_light = np.asarray(light, float) / np.linalg.norm(light)
    sun = Light("directional", np.ones(3, np.float32), 3.0, direction=(-to_light).astype(np.float32))
    settings = target_settings(target, "lambert", lights=[sun], ambient=np.zeros(3), normal_map=True)
    camera = Camera(np.array([0.0, 3.0, 0.001]), np.array([0.0, HEIGHT, 0.0]), 20.0)
    radiance = Renderer(target).render(settings, camera, 48, 48).radiance[..., 0].ravel()
    origins, dirs = camera.rays(48, 48)
    point = origins + dirs * ((HEIGHT - origins[:, 1]) / dirs[:, 1])[:, None]
    inside = np.all(np.abs(point[:, [0, 2]]) < HALF - 0.05, axis=1)
    x, z = point[inside, 0], point[inside, 2]
    sphere_normal = np.stack([x, np.sqrt(1 - x * x - z * z), z], 1)
    expected = 3.0 / np.pi * np.maximum(sphere_normal @ to_light, 0)
    assert inside.sum() > 500
    assert np.abs(radiance[inside] - expected).max() < 0.02 * 3.0 / np.pi


def test_a_cage_of_another_topology_and_a_missing_file_are_one_line_errors(files, tmp_path, capsys):
    sphere, low = str(files["sphere"]), str(files["low"])
    assert main(["normalmap", sphere, low, "--cage", sphere, "-o", str(tmp_path / "n.png"), "--quiet"]) == 2
    assert main(["normalmap", str(tmp_path / "none.glb"), low, "-o", str(tmp_path / "n.png"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "cage" in err[0] and "none.glb" in err[1]
    assert not list(tmp_path.glob("*.png"))


def test_a_low_sphere_with_the_baked_map_shades_like_the_high_sphere(tmp_path):
    """The tangent frames of baker and renderer agree on a curved surface: the low sphere
    (8 x 16) wearing its map lights like the smooth high sphere under a light from the side
    (what is left is parallax: the low surface lies up to 2 % inside), better than without."""
    from render_scenes import uv_sphere

    from patchlight.imaging.io import read_exr

    files = {}
    for name, (lat, lon) in {"high": (96, 192), "low": (8, 16)}.items():
        positions, normals, uv, indices = uv_sphere(lat, lon)
        files[name] = _glb(tmp_path / f"{name}.glb", positions, indices, normals, uv)
    normal = tmp_path / "n.png"
    assert main(["normalmap", str(files["high"]), str(files["low"]), "-o", str(normal), "--size", "256x128",
                 "--distance", "0.1", "--quiet"]) == 0
    common = ["--model", "lambert", "--light", "dir:-1,-0.3,-0.6:1,1,1:3", "--ambient", "0,0,0",
              "--camera", "0.3,0.5,4", "0,0,0", "30", "--size", "64x64", "--exposure", "1"]
    images = {}
    for name, extra in (("high", []), ("low", []), ("mapped", ["--normal-map", str(normal)])):
        out = tmp_path / f"{name}.exr"
        scene = files["high" if name == "high" else "low"]
        assert main(["render", str(scene), *common, *extra, "-o", str(out)]) == 0
        images[name] = read_exr(out)[..., 0]
    yy, xx = np.mgrid[0:64, 0:64]
    inner = (np.hypot(yy - 31.5, xx - 31.5) < 20) & (images["high"] > 0.05)  # lit, away from the rim
    error = {k: np.abs(images[k][inner] / images["high"][inner] - 1) for k in ("low", "mapped")}
    assert np.median(error["mapped"]) < 0.01 and np.percentile(error["mapped"], 90) < 0.05  # measured 0.8 %, 3.9 %
    assert np.percentile(error["low"], 90) > 1.3 * np.percentile(error["mapped"], 90)  # 5.6 % without the map
