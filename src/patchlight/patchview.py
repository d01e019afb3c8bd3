"""View from a patch: what one lightmap texel sees, traced by the bake's own Gatherer.

The rays are the bake's pattern (hemicube pixels with their multiplier map, or stratified
cosine rays), turned about the patch's normal exactly as in its gather, resolved through the
same item buffer; each ray shows the excident light B of the patch it meets (the final
solution, texels.npz), the sky's radiance, or a mark for a back face or a lost hit. So the
picture is the bake's own view, and its weighted sum, less the emitted light the direct
stage's next-event estimation holds instead (its MIS share), is the patch's gathered light.

Pictures (`PatchView.picture`): a hemicube of size N unfolds into a 2N x 2N cross as the
radiosity article draws it, the front face (N x N, looking along the normal) in the middle
and the four half faces (N x N/2) folded out around it; stratified rays are dots on the
hemisphere seen from above (orthographic: cosine-weighted rays fall uniformly on the disk).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import PatchlightError
from .radiosity.gather import BACK_FACE, LOST, SKY

DISK_PIXELS = 128     # a stratified view's picture is this many pixels across
MARKS = {BACK_FACE: (1.0, 0.0, 1.0), LOST: (1.0, 1.0, 0.0)}  # linear display colours
KINDS = {"sky": SKY, "back face": BACK_FACE, "lost": LOST}
BACKGROUND = -100  # picture pixels no ray reaches (the cross's corners, between the dots)
BACKGROUND_COLOUR = (0.02, 0.02, 0.02)


@dataclass
class PatchView:
    """One patch's gather. texel (x, y); method, size (hemicube pixels across, or rays asked
    for); seen (D,) i32 patch id or SKY / BACK_FACE / LOST per ray; origin (3,) the lifted
    ray origin; directions (D, 3) world; local (D, 3) the pattern in the patch's frame
    (z = normal, before turning); weights (D,) summing to 1; radiance (D, 3) f32 seen;
    next_event (D, 3) f32 the part of it emitted that the direct stage counts instead."""

    texel: tuple[int, int]
    method: str
    size: int
    seen: np.ndarray
    origin: np.ndarray
    directions: np.ndarray
    local: np.ndarray
    weights: np.ndarray
    radiance: np.ndarray
    next_event: np.ndarray

    @property
    def gathered(self) -> np.ndarray:
        """(3,) the weighted sum of what the rays see, less what next-event estimation holds:
        the gathered light."""
        return (self.weights[:, None] * (self.radiance - self.next_event)).sum(axis=0)

    def pixels(self) -> tuple[np.ndarray, np.ndarray, int, int]:
        """(rows, columns) of each ray's pixel in the picture, and its height and width."""
        if self.method == "hemicube":
            return _cross_pixels(self.size) + (2 * self.size, 2 * self.size)
        col = np.clip(((self.local[:, 0] + 1) / 2 * DISK_PIXELS).astype(int), 0, DISK_PIXELS - 1)
        row = np.clip(((1 - self.local[:, 1]) / 2 * DISK_PIXELS).astype(int), 0, DISK_PIXELS - 1)
        return row, col, DISK_PIXELS, DISK_PIXELS

    def picture(self, values: np.ndarray, fill: float = 0.0) -> np.ndarray:
        """Per-ray values (D, ...) laid out as the picture (H, W, ...); pixels no ray reaches
        hold `fill`. A stratified ray is a 3 x 3 dot."""
        row, col, h, w = self.pixels()
        out = np.full((h, w) + values.shape[1:], fill, values.dtype)
        if self.method == "hemicube":
            out[row, col] = values
            return out
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                out[np.clip(row + dy, 0, h - 1), np.clip(col + dx, 0, w - 1)] = values
        return out

    def to_json(self) -> dict:
        """What the viewer's patch panel draws: pictures as flat row-major lists."""
        kinds = self.picture(np.where(self.seen >= 0, 0, self.seen).astype(np.int32), fill=BACKGROUND)
        return {"texel": list(self.texel), "method": self.method, "size": self.size,
                "height": kinds.shape[0], "width": kinds.shape[1],
                "radiance": np.round(self.picture(self.radiance), 6).ravel().tolist(),
                "kind": kinds.ravel().tolist(), "weight": self.picture(self.weights).ravel().tolist(),
                "kinds": KINDS, "background": BACKGROUND, "marks": {int(k): v for k, v in {**MARKS, BACKGROUND: BACKGROUND_COLOUR}.items()},
                "gathered": self.gathered.tolist(), "rays": len(self.seen),
                "counts": {name: int(np.count_nonzero(self.seen == code)) for name, code in KINDS.items()}}


def patch_picture(view: PatchView, exposure: float, scale: int = 1) -> np.ndarray:
    """(H, 2 W + gap, 3) uint8: the view exposed as the viewer shows it (back faces and lost
    hits in their MARKS colours, pixels no ray reaches dark grey) beside its multiplier map
    (weight / largest weight, grey), each pixel repeated scale x scale."""
    from .imaging.color import linear_to_srgb
    from .render.output import display_pixels

    seen = view.picture(view.seen, fill=BACKGROUND)
    shown = display_pixels(view.picture(view.radiance), exposure)
    for code, colour in {**MARKS, BACKGROUND: BACKGROUND_COLOUR}.items():
        shown[seen == code] = np.round(linear_to_srgb(np.array(colour)) * 255).astype(np.uint8)
    weight = view.picture(view.weights / view.weights.max())
    weights = np.round(linear_to_srgb(weight) * 255).astype(np.uint8)[..., None].repeat(3, axis=-1)
    weights[seen == BACKGROUND] = shown[seen == BACKGROUND]
    gap = np.zeros((shown.shape[0], max(1, shown.shape[1] // 16), 3), np.uint8)
    both = np.concatenate([shown, gap, weights], axis=1)
    return both.repeat(scale, axis=0).repeat(scale, axis=1)


def _cross_pixels(n: int) -> tuple[np.ndarray, np.ndarray]:
    """(row, column) in the 2N x 2N cross of each hemicube pixel, in hemicube_directions'
    order: front (row b, column a), then the half faces +x, -x, +y, -y (row `up`, column a);
    the horizon (up = 0) lies on the cross's outer rim."""
    h = n // 2
    b, a = np.divmod(np.arange(n * n), n)
    rows, cols = [h + n - 1 - b], [h + a]
    up, a = np.divmod(np.arange(n * h), n)
    for row, col in (                  # each folded out about its edge with the front (up = 1),
            (h + n - 1 - a, h + n + h - 1 - up),   # +x: to the right
            (h + n - 1 - a, up),                   # -x: to the left
            (up, h + a),                           # +y: above
            (h + n + h - 1 - up, h + a)):          # -y: below
        rows.append(row)
        cols.append(col)
    return np.concatenate(rows), np.concatenate(cols)


class PatchViews:
    """Looks from any texel of a bake directory: scene.glb rasterised again at the bake's
    resolution (the same patches and ids), the bake's gather settings from bake.json, and the
    excident light B of texels.npz."""

    def __init__(self, bake_dir: str | Path):
        from . import bakedir
        from .atlas.raster import rasterize
        from .radiosity.emitters import find_emitters, samples_per_texel
        from .radiosity.gather import Gatherer
        from .rays.tracer import Tracer

        bake_dir = Path(bake_dir)
        self.texels = bakedir.read_texels(bake_dir)
        if self.texels is None:
            raise PatchlightError(f"{bake_dir}: no texels.npz (bake it again to view from a patch)")
        summary = bakedir.read_summary(bake_dir)
        try:
            settings = summary["settings"]
            method, seed = settings["gather"], int(settings["seed"])
            size = int(settings["hemicube_size"] if method == "hemicube" else settings["rays"])
        except (ValueError, KeyError, TypeError) as exc:
            raise PatchlightError(f"{bake_dir / bakedir.MARKER}: no readable gather settings ({exc})") from None
        scene = bakedir.read_scene(bake_dir)
        height, width = self.texels.status.shape
        self.patches, _ = rasterize(scene, width, height)
        samples = samples_per_texel(int(settings.get("emitter_samples", 0)))
        emitters = find_emitters(scene, self.patches) if samples else None
        self.gatherer = Gatherer(scene, self.patches, Tracer(scene.positions, scene.indices), method, size, seed,
                                 emitters, samples)
        self.size = size

    def at(self, x: int, y: int) -> PatchView:
        """The view from texel (x, y) (column, row; row 0 at v = 0)."""
        p = self.patches
        if not (0 <= x < p.width and 0 <= y < p.height) or p.index[y, x] < 0:
            raise PatchlightError(f"`patch` {x},{y}: no patch there (the lightmap is {p.width}x{p.height}; "
                                  "pick a texel a surface covers)")
        row = int(p.index[y, x])
        g = self.gatherer
        seen, directions, shares = g.look(row)
        radiance = np.zeros((len(seen), 3), np.float32)
        hit = seen >= 0
        seen_texels = p.texel_y[seen[hit]], p.texel_x[seen[hit]]
        radiance[hit] = self.texels.excident[seen_texels]
        next_event = np.zeros_like(radiance)
        next_event[hit] = self.texels.emission[seen_texels] * (1.0 - shares[hit, None])
        sky = seen == SKY
        if g.sky is not None and sky.any():
            radiance[sky] = g.sky.radiance(directions[sky])
        origin = p.position[row] + g.offset[row] * p.normal[row]
        return PatchView((x, y), g.method, self.size, seen, origin, directions, g.dirs, g.weights, radiance, next_event)
