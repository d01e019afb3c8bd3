"""Validity: lightmap.exr's alpha, double-sided cards, and no light through a wall thinner
than a texel."""
import numpy as np

from patchlight.bake import bake
from patchlight.bakedir import read_lightmap, read_validity, write_bake
from patchlight.config import BakeSettings
from patchlight.radiosity import adaptive
from patchlight.scene import Light, SceneBuilder, Sky
from patchlight.solved import SolvedScene

UP = (0.0, 1.0, 0.0)


def rendered(result, points: np.ndarray) -> np.ndarray:
    """(P, 3) the lightmap model at surface points (P, 3) lying on the floor y = 0: the texel
    light the renderer reads there (bilinear through TEXCOORD_1)."""
    scene = result.scene
    corners = scene.positions[scene.indices].astype(np.float64)
    floor = np.flatnonzero(np.abs(corners[:, :, 1]).max(axis=1) < 1e-6)
    out = np.zeros((len(points), 3))
    solved = SolvedScene(scene, result.lightmap, "test")
    for t in floor:
        a, b, c = corners[t][:, [0, 2]]
        m = np.column_stack([b - a, c - a])
        uv = np.linalg.solve(m, (points[:, [0, 2]] - a).T).T
        on = (uv >= -1e-9).all(axis=1) & (uv.sum(axis=1) <= 1 + 1e-9)
        out[on] = solved.incident(np.full(on.sum(), t), uv[on, 0], uv[on, 1])
    return out


def test_a_double_sided_card_is_a_surface_from_below_and_the_floor_under_it_is_lit():
    b = SceneBuilder()
    grey, card = b.material("grey", (0.5, 0.5, 0.5)), b.material("card", (0.8, 0.8, 0.8))
    b.quad([[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]], grey, UP)
    b.quad([[-0.5, 0.2, -0.5], [-0.5, 0.2, 0.5], [0.5, 0.2, 0.5], [0.5, 0.2, -0.5]], card, UP)
    scene = b.scene("card", sky=Sky.uniform((1.0, 1.0, 1.0)))
    scene.materials[card].double_sided = True
    result = bake(scene, BakeSettings(texels_per_unit=8))
    p = result.patches
    under = (np.abs(p.position[:, 1]) < 1e-6) & (np.abs(p.position[:, [0, 2]]).max(axis=1) < 0.4)
    assert under.sum() > 10 and not np.any(result.status[under] == adaptive.INSIDE)
    grid = np.stack(np.meshgrid(np.linspace(-0.4, 0.4, 9), [0.0], np.linspace(-0.4, 0.4, 9)), -1).reshape(-1, 3)
    seen = rendered(result, grid)[:, 0]
    # the card's underside reflects the floor's light and the sky comes in at the sides
    assert seen.min() > 0.15, f"floor under the card reads {seen.min():.3f}"
    scene.materials[card].double_sided = False  # one-sided, its back marks the floor inside
    one_sided = bake(scene, BakeSettings(texels_per_unit=8))
    assert np.mean(one_sided.status[under] == adaptive.INSIDE) > 0.5


RES, DENSITY = 64, 3.75  # texels of 0.267 m


def _shelf_uvs(scene, first_at: float) -> None:
    """Lightmap UVs by hand, DENSITY texels per metre: each quad (two triangles of the
    builder, corners c0 c1 c2 / c0 c2 c3) on its own rectangle of a shelf packing, the first
    quad's corner c0 at texel (first_at, first_at)."""
    tris = scene.positions.reshape(-1, 2, 3, 3).astype(np.float64)  # quad, triangle, corner
    c0, c1, c3 = tris[:, 0, 0], tris[:, 0, 1], tris[:, 1, 2]
    width, height = np.linalg.norm(c1 - c0, axis=1), np.linalg.norm(c3 - c0, axis=1)
    uv = np.zeros(tris.shape[:3] + (2,))
    x = y = first_at
    shelf = 0.0
    for q in range(len(tris)):
        w, h = width[q] * DENSITY, height[q] * DENSITY
        if x + w + 2 > RES:
            x, y, shelf = 2.0, y + shelf + 3, 0.0
        e1, e3 = (c1[q] - c0[q]) / width[q], (c3[q] - c0[q]) / height[q]
        rel = tris[q] - c0[q]
        uv[q] = np.stack([x + DENSITY * rel @ e1, y + DENSITY * rel @ e3], -1) / RES
        x, shelf = x + w + 3, max(shelf, h)
    scene.uv1 = uv.reshape(-1, 2).astype(np.float32)


def _two_rooms():
    """A 4 x 2 m floor split by a 0.2 m wall at x = 2: the west room open to a sun and the
    sky, the east room sealed by walls and a ceiling. Texels of 0.267 m, one centred under
    the wall at x = 2."""
    b = SceneBuilder()
    grey = b.material("grey", (0.6, 0.6, 0.6))
    b.quad([[0, 0, 0], [4, 0, 0], [4, 0, 2], [0, 0, 2]], grey, UP)
    b.box((1.9, 0, 0), (2.1, 2, 2), grey)
    b.quad([[2.1, 2, 0], [4, 2, 0], [4, 2, 2], [2.1, 2, 2]], grey, (0, -1, 0))
    b.quad([[4, 0, 0], [4, 2, 0], [4, 2, 2], [4, 0, 2]], grey, (-1, 0, 0))
    b.quad([[2.1, 0, 0], [4, 0, 0], [4, 2, 0], [2.1, 2, 0]], grey, (0, 0, 1))
    b.quad([[2.1, 0, 2], [4, 0, 2], [4, 2, 2], [2.1, 2, 2]], grey, (0, 0, -1))
    sun = Light("directional", np.ones(3, np.float32), 6.0, direction=np.array([0.5, -1, 0.2], np.float32))
    scene = b.scene("two rooms", lights=[sun], sky=Sky.uniform((0.5, 0.6, 0.8)))
    _shelf_uvs(scene, first_at=2.0)  # texel 9's centre: x = (9.5 - 2) / 3.75 = 2.0
    return scene


def test_no_light_crosses_a_wall_thinner_than_a_texel_into_a_sealed_room(tmp_path):
    settings = BakeSettings(resolution=RES)
    result = bake(_two_rooms(), settings)
    x, z = np.meshgrid(np.linspace(2.1, 3.0, 37), np.linspace(0.05, 1.95, 20))
    sealed = rendered(result, np.stack([x.ravel(), np.zeros(x.size), z.ravel()], -1))
    x, z = np.meshgrid(np.linspace(0.5, 1.5, 11), np.linspace(0.5, 1.5, 11))
    lit = rendered(result, np.stack([x.ravel(), np.zeros(x.size), z.ravel()], -1))
    assert lit.min() > 0.3
    assert sealed.max() < 1e-4 * lit.mean(), f"the sealed room's floor reads up to {sealed.max():.4f}"
    assert result.stats["walled_inside_patches"] > 0

    write_bake(result, tmp_path, settings)
    p = result.patches
    alpha = read_validity(tmp_path)
    inside = result.status == adaptive.INSIDE
    assert np.all(alpha[p.texel_y[~inside], p.texel_x[~inside]])
    assert not np.any(alpha[p.texel_y[inside], p.texel_x[inside]]) and inside.any()
    assert not np.any(alpha[p.index < 0])
    np.testing.assert_array_equal(read_lightmap(tmp_path), result.lightmap)


def test_a_texel_inside_pairs_its_first_usable_neighbour_with_each_other_one():
    """wall_pairs against the neighbours read one by one: covered (index >= 0), on the map and
    not inside; the first such, in NEIGHBOURS order, paired with every later one."""
    from patchlight.radiosity import _kernels

    rng = np.random.default_rng(2)
    height, width = 9, 11
    covered = rng.random((height, width)) < 0.8
    index = np.full((height, width), -1, np.int64)
    index[covered] = np.arange(covered.sum())
    texel_y, texel_x = np.nonzero(covered)
    inside = rng.random(len(texel_y)) < 0.4
    expected = []
    for p in np.flatnonzero(inside):
        usable = []
        for dy, dx in _kernels.NEIGHBOURS:
            y, x = texel_y[p] + dy, texel_x[p] + dx
            if 0 <= y < height and 0 <= x < width and index[y, x] >= 0 and not inside[index[y, x]]:
                usable.append(index[y, x])
        expected += [(p, usable[0], other) for other in usable[1:]]
    got = _kernels.wall_pairs(index, inside, texel_y.astype(np.int32), texel_x.astype(np.int32))
    assert len(expected) > 20
    np.testing.assert_array_equal(np.stack(got, 1), np.array(expected))
