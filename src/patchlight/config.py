"""Every bake default in one place, with unit, range and typical value.

| name              | unit / type   | default        | meaning (range; typical)                                        |
|-------------------|---------------|----------------|-----------------------------------------------------------------|
| resolution        | texels        | None           | lightmap width = height (16..8192); None: from texels_per_unit  |
| texels_per_unit   | texels / m    | 16             | lightmap density when UVs are made (0.001..10000; 8-64)         |
| padding           | texels        | 2              | gap between UV charts (>= 2)                                    |
| gather            | str           | "stratified"   | "hemicube" or "stratified" (measured faster to a given error)   |
| hemicube_size     | pixels        | 32             | front face N x N, even (8..512; 32-128)                         |
| rays              | rays / patch  | 512            | stratified rays, rounded down to an a x b grid (16..16384; 512) |
| passes            | count         | 100            | upper bound on passes (1 = direct + sky only)                   |
| tolerance         | ratio         | 1e-3           | stop when the largest relative change still to come is below    |
| adaptive          | bool          | True           | compute every 4th texel, refine where neighbours differ         |
| first_accuracy    | ratio         | 0.5            | the sampler's first run, for the first passes (0..1; 0.5)       |
| accuracy          | ratio         | 0.98           | final run: threshold = accuracy ** spacing (0..1; 0.98)         |
| sun_samples       | rays / texel  | 16             | shadow rays over the sun's disc when its angle is > 0           |
| emitter_samples   | rays / texel  | 16             | shadow rays to emissive triangles, n x n over the texel (0: off)|
| texel_samples     | per axis      | 2              | direct light averaged over n x n points of each texel (1..4)    |
| sun_angle         | degrees       | None           | override the sun's angular diameter (0 = hard; 0.53 real sun)   |
| falloff           | str           | inverse-square | point/spot falloff when a light names none: or "range"         |
| exposure          | 1 / radiance  | "auto"         | PNG = 1 - exp(-k I); auto puts the 90th percentile at 0.8       |
| max_memory        | bytes         | 8 GiB          | above this the form-factor matrix is not kept: re-gather a pass |
| seed              | int           | 1              | random rotation of the stratified pattern per patch (>= 0)      |
| denoise           | bool          | False          | OIDN (RTLightmap) on the gathered light; direct stays sharp     |
| save_passes       | bool          | False          | also a PNG per pass (pass_01.png, ...); texels.npz has them all |
| stitch            | bool          | True           | least-squares agreement of the lookups across UV chart seams    |
| directional       | str           | None           | also bake "sh" (L1, lightmap_sh.exr) or "dominant" (_dir.exr)   |
| ray               | str           | None           | Ray head HOST:PORT for the gather ("auto", or "local": start one) |
| density           | {name: T}     | {}             | texels / m of the objects so named (over their extras)          |
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

from .errors import PatchlightError

GiB = 1 << 30
FALLOFFS = ("inverse-square", "range")
GATHERS = ("stratified", "hemicube")
DIRECTIONAL_MODES = ("sh", "dominant")  # L1 spherical harmonics, or the dominant direction and its share
TEXELS_PER_UNIT = (1e-3, 1e4)  # the range taken, texels per metre


@dataclass
class BakeSettings:
    resolution: int | None = None
    texels_per_unit: float = 16.0
    padding: int = 2
    gather: str = "stratified"
    hemicube_size: int = 32
    rays: int = 512
    passes: int = 100
    tolerance: float = 1e-3
    adaptive: bool = True
    first_accuracy: float = 0.5
    accuracy: float = 0.98
    sun_samples: int = 16
    emitter_samples: int = 16
    texel_samples: int = 2
    sun_angle: float | None = None
    falloff: str = "inverse-square"
    exposure: float | str = "auto"
    max_memory: int = 8 * GiB
    seed: int = 1
    denoise: bool = False
    save_passes: bool = False
    stitch: bool = True
    directional: str | None = None
    ray: str | None = None
    density: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict:
        return asdict(self)

    def validate(self) -> None:
        """PatchlightError naming the first setting outside its range (the table above)."""
        def number(x) -> bool:
            return isinstance(x, (int, float)) and math.isfinite(x)

        checks = [
            (self.resolution is None or (isinstance(self.resolution, int) and 16 <= self.resolution <= 8192),
             f"resolution: {self.resolution} is not a whole number of texels in 16..8192"),
            (number(self.texels_per_unit) and TEXELS_PER_UNIT[0] <= self.texels_per_unit <= TEXELS_PER_UNIT[1],
             f"texels per unit: {self.texels_per_unit} is not a number in {TEXELS_PER_UNIT[0]:g}..{TEXELS_PER_UNIT[1]:g}"),
            (self.gather in GATHERS, f"gather must be one of {', '.join(GATHERS)}"),
            (self.falloff in FALLOFFS, f"falloff must be one of {', '.join(FALLOFFS)}"),
            (isinstance(self.passes, int) and self.passes >= 1, "passes must be a whole number >= 1"),
            (number(self.tolerance) and self.tolerance > 0, "tolerance must be a positive number"),
            (number(self.accuracy) and 0 < self.accuracy < 1, "accuracy must lie between 0 and 1"),
            (number(self.first_accuracy) and 0 < self.first_accuracy < 1, "first accuracy must lie between 0 and 1"),
            (isinstance(self.rays, int) and 1 <= self.rays <= 16384, "rays must be a whole number in 1..16384"),
            (isinstance(self.hemicube_size, int) and 2 <= self.hemicube_size <= 512 and self.hemicube_size % 2 == 0,
             "hemicube size must be an even number in 2..512"),
            (isinstance(self.sun_samples, int) and self.sun_samples >= 1, "sun samples must be a whole number >= 1"),
            (isinstance(self.emitter_samples, int) and 0 <= self.emitter_samples <= 1024,
             "emitter samples must be a whole number in 0..1024"),
            (isinstance(self.texel_samples, int) and 1 <= self.texel_samples <= 4, "texel samples must be 1..4"),
            (self.sun_angle is None or (number(self.sun_angle) and 0 <= self.sun_angle < 90),
             "sun angle must lie in 0..90 degrees"),
            (self.exposure == "auto" or (number(self.exposure) and self.exposure > 0),
             "exposure must be a positive number or auto"),
            (number(self.max_memory) and 0 <= self.max_memory <= 1 << 50, "max memory must be a number of bytes in 0..2^50"),
            (isinstance(self.seed, int) and self.seed >= 0, "seed must be a whole number >= 0"),
            (self.directional in (None, *DIRECTIONAL_MODES), "directional must be sh or dominant"),
            *((number(t) and TEXELS_PER_UNIT[0] <= t <= TEXELS_PER_UNIT[1],
               f"density {name}: {t} texels per metre is not a number in "
               f"{TEXELS_PER_UNIT[0]:g}..{TEXELS_PER_UNIT[1]:g}") for name, t in self.density.items()),
        ]
        for ok, message in checks:
            if not ok:
                raise PatchlightError(message)
