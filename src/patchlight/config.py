"""Every bake default in one place, with unit, range and typical value.

| name              | unit / type   | default        | meaning (range; typical)                                        |
|-------------------|---------------|----------------|-----------------------------------------------------------------|
| resolution        | texels        | None           | lightmap width = height (16..8192); None: from texels_per_unit  |
| texels_per_unit   | texels / m    | 16             | lightmap density when UVs are made (1..1000; 8-64)              |
| padding           | texels        | 2              | gap between UV charts (>= 2)                                    |
| gather            | str           | "stratified"   | "hemicube" or "stratified" (measured faster to a given error)   |
| hemicube_size     | pixels        | 32             | front face N x N, even (8..512; 32-128)                         |
| rays              | rays / patch  | 512            | stratified rays, rounded down to an a x b grid (16..16384; 512) |
| passes            | count         | 100            | upper bound on passes (1 = direct + sky only)                   |
| tolerance         | ratio         | 1e-3           | stop when the largest relative change of a pass is below        |
| adaptive          | bool          | True           | compute every 4th texel, refine where neighbours differ         |
| accuracy          | ratio         | 0.98           | refinement threshold = accuracy ** spacing (0..1; 0.98)         |
| sun_samples       | rays / texel  | 16             | shadow rays over the sun's disc when its angle is > 0           |
| texel_samples     | per axis      | 2              | direct light averaged over n x n points of each texel (1..4)    |
| sun_angle         | degrees       | None           | override the sun's angular diameter (0 = hard; 0.53 real sun)   |
| falloff           | str           | inverse-square | point/spot falloff when a light names none: or "range"         |
| exposure          | 1 / radiance  | "auto"         | PNG = 1 - exp(-k I); auto puts the 90th percentile at 0.8       |
| max_memory        | bytes         | 8 GiB          | above this the form-factor matrix is not kept: re-gather a pass |
| seed              | int           | 1              | random rotation of the stratified pattern per patch             |
| denoise           | bool          | False          | OIDN (RTLightmap) on the gathered light; direct stays sharp     |
| ray               | str           | None           | Ray cluster address for the gather ("local": start one here)    |
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

GiB = 1 << 30


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
    accuracy: float = 0.98
    sun_samples: int = 16
    texel_samples: int = 2
    sun_angle: float | None = None
    falloff: str = "inverse-square"
    exposure: float | str = "auto"
    max_memory: int = 8 * GiB
    seed: int = 1
    denoise: bool = False
    save_passes: bool = False
    ray: str | None = None

    def to_json(self) -> dict:
        return asdict(self)
