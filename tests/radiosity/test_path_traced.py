"""The bake against an independent path tracer: at points the bake gathered, the incident
light it solved must match a Monte Carlo estimate of the same quantity (cosine-weighted mean
radiance, the README's units) with emitters, sun and sky. The reference shares only the ray
caster and the sky model with the baker (its sun term is written out here), so it checks
that every 1/pi of the gather, the passes and the direct light is in its place."""
import numpy as np
import pytest

from patchlight.bake import bake
from patchlight.radiosity.gather import ray_offsets
from patchlight.config import BakeSettings
from patchlight.radiosity import adaptive
from patchlight.radiosity.hemicube import concentric_disk
from patchlight.rays.tracer import Tracer
from patchlight.scene import load_scene
from patchlight.scene.model import face_normals

PATHS = 10000
DEPTH = 14
EPS = 1e-4


def cosine_directions(normals, rng):
    """One cosine-distributed direction per unit normal (N, 3)."""
    x, y = concentric_disk(rng.random(len(normals)), rng.random(len(normals)))
    z = np.sqrt(np.maximum(0, 1 - x * x - y * y))
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t = np.cross(normals, helper)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(normals, t)
    return x[:, None] * t + y[:, None] * b + z[:, None] * normals


def sun_incident(scene, tracer, points, normals):
    """(N, 3) incident light from the scene's suns, written out here from its definition
    (I = Es max(0, n.l) V / pi, one hard shadow ray), not taken from the baker."""
    total = np.zeros((len(points), 3))
    for sun in scene.lights:
        assert sun.kind == "directional", "this reference knows suns only"
        l = -np.asarray(sun.direction, np.float64)
        cos = np.maximum(normals @ l, 0.0)
        lit = cos > 0
        seen = ~tracer.occluded(points[lit], np.broadcast_to(l, (int(lit.sum()), 3)), np.float32(1e30))
        visible = np.zeros(len(points))
        visible[np.flatnonzero(lit)[seen]] = 1.0
        total += (sun.intensity * np.asarray(sun.color, np.float64))[None] * (cos * visible / np.pi)[:, None]
    return total


def path_traced_incident(scene, points, normals, rng):
    """(P, 3) Monte Carlo incident light I at points with normals: the lights' direct light
    there (shadow rays), plus the mean over cosine-distributed paths of the radiance arriving,
    every bounce adding emission and the lights' direct light times the reflectances so far."""
    tracer = Tracer(scene.positions, scene.indices)
    here = sun_incident(scene, tracer, np.asarray(points, np.float64), np.asarray(normals, np.float64))
    face_n, _ = face_normals(scene.positions, scene.indices)
    rho = np.array([m.base_color[:3] for m in scene.materials], np.float64)[scene.material_ids]
    emit = np.array([m.emissive[:3] for m in scene.materials], np.float64)[scene.material_ids]
    origin = np.repeat(points, PATHS, axis=0).astype(np.float64)
    normal = np.repeat(normals, PATHS, axis=0).astype(np.float64)
    throughput = np.ones((len(origin), 3))
    total = np.zeros((len(origin), 3))
    alive = np.arange(len(origin))
    for _ in range(DEPTH):
        d = cosine_directions(normal[alive], rng)
        hits = tracer.intersect(origin[alive], d)
        miss = hits.tri < 0
        if scene.sky is not None and miss.any():
            total[alive[miss]] += throughput[alive[miss]] * scene.sky.radiance(d[miss])
        keep = hits.front
        alive, d, t, tri = alive[keep], d[keep], hits.t[keep], hits.tri[keep]
        if len(alive) == 0:
            break
        n_hit = face_n[tri].astype(np.float64)
        p_hit = origin[alive] + d * t[:, None] + EPS * n_hit
        lit = sun_incident(scene, tracer, p_hit, n_hit)
        total[alive] += throughput[alive] * (emit[tri] + rho[tri] * lit)
        throughput[alive] *= rho[tri]
        origin[alive], normal[alive] = p_hit, n_hit
    return here + total.reshape(len(points), PATHS, 3).mean(axis=1)


def sample_patches(result, count, rng):
    """Computed patches whose 5 x 5 neighbourhood is covered, of one chart, and not inside."""
    p = result.patches
    ok = result.status == adaptive.COMPUTED
    for dy in range(-2, 3):
        for dx in range(-2, 3):
            y = np.clip(p.texel_y + dy, 0, p.height - 1)
            x = np.clip(p.texel_x + dx, 0, p.width - 1)
            nb = p.index[y, x]
            ok &= (nb >= 0) & (p.chart[np.maximum(nb, 0)] == p.chart)
            ok &= result.status[np.maximum(nb, 0)] != adaptive.INSIDE
    return rng.choice(np.flatnonzero(ok), size=count, replace=False)


# texels of a few centimetres: at coarser ones (the room at 96 x 96 has 0.7 m texels) the
# piecewise-constant radiosity itself is 10 % off, a discretisation error, not a units one
@pytest.mark.parametrize("name, resolution", [("cornell", 96), ("room", 256)])
def test_bake_matches_a_path_traced_reference(name, resolution):
    rng = np.random.default_rng(7)
    scene = load_scene(name)
    result = bake(scene, BakeSettings(resolution=resolution, rays=1024, tolerance=1e-4, sun_angle=0.0, texel_samples=1))
    chosen = sample_patches(result, 40, rng)
    p = result.patches
    offset = ray_offsets(result.scene, p)[chosen, None]
    reference = path_traced_incident(result.scene, p.position[chosen] + offset * p.normal[chosen],
                                     p.normal[chosen], rng)
    baked = result.solution.incident[chosen]
    lum = np.array([0.2126, 0.7152, 0.0722])
    ratio = (baked @ lum) / (reference @ lum)
    # units: the typical ratio is 1; points agree within the noise of both estimates
    # (10,000 paths and 1,024 gather rays: a few per cent each)
    assert np.median(ratio) == pytest.approx(1.0, abs=0.04)
    assert np.mean(np.abs(ratio - 1) < 0.2) >= 0.85
