"""The light volume as the viewer and the renderer's command line take it."""
from __future__ import annotations

import numpy as np

from ..shading.ambient_cube import volume_texture
from .volume import sky_volume


def volume_bundle(pack, settings) -> dict:
    """The manifest's "volume" entry (viewer/bundle.py) for ShadingSettings `settings`: grid
    origin, spacing, dims; `texture`, the name of its (6 NZ, NY, NX, 4) texels in data.bin
    (RGB light, alpha validity; see ambient_cube.glsl); `inside`, the name of its (NZ, NY, NX) 0/1 flags; `baked`: False
    when the model falls back to the sky as one probe (then the page adds no moving objects)."""
    volume = settings.volume if settings.volume is not None else sky_volume(settings.sky, settings.ground,
                                                                             settings.ambient)
    grid = volume.grid
    return {"origin": list(grid.origin), "spacing": list(grid.spacing), "dims": list(grid.dims),
            "texture": pack.add("ambient_cube_volume", volume_texture(volume)),
            "inside": pack.add("ambient_cube_inside", volume.inside.astype(np.float32)),
            "baked": settings.volume is not None}
