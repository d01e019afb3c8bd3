"""What a bake needs in memory, and what the machine has.

A W x H lightmap costs about BYTES_PER_TEXEL per texel of the image beside the form-factor
matrix F (patch arrays, the points spread over each texel for direct light, light vectors,
the sampler's state, images), whether or not texels are covered: measured as peak resident
memory over the interpreter's own, F dropped (room 1024: 607; room 512: 542; cornell 512:
687 bytes per texel at 2 x 2 texel samples; room 512 at 4 x 4: 1433, so about 74 bytes per
further sample). F gets what is left, up to --max-memory, and is dropped for re-gathering
once it would not fit (solve.FormFactors). The whole is checked before any work, so a
lightmap too large is refused with the estimate instead of being killed by the kernel halfway.
"""
from __future__ import annotations

import math

from ..errors import PatchlightError
from ..limits import available_memory

BYTES_PER_TEXEL = 720          # at 2 x 2 texel samples: measured 542..687 (module docstring)
BYTES_PER_TEXEL_SAMPLE = 80    # each further direct-light point per texel: measured about 74
HEADROOM = 0.9                 # of the available memory, the share a bake may plan to use
MIN_SIDE = 16


def estimate_bake_bytes(width: int, height: int, texel_samples: int = 2) -> int:
    """Peak bytes of baking a width x height lightmap, F aside (it adapts to what is left)."""
    per_texel = BYTES_PER_TEXEL + BYTES_PER_TEXEL_SAMPLE * max(0, texel_samples ** 2 - 4)
    return int(width) * int(height) * per_texel


def check_bake_memory(width: int, height: int, texel_samples: int = 2, available: int | None = None) -> None:
    """Refuse (PatchlightError) a lightmap whose bake would not fit in the available memory,
    with the estimate and the largest resolution that would."""
    needed = estimate_bake_bytes(width, height, texel_samples)
    usable = HEADROOM * (available_memory() if available is None else int(available))
    if usable > 0 and needed > usable:
        side = int(math.sqrt(usable / needed) * min(width, height)) // 4 * 4
        raise PatchlightError(
            f"lightmap {width}x{height}: the bake needs about {needed / 2**30:.1f} GiB but only "
            f"{usable / 2**30:.1f} GiB is available; lower --resolution (about {max(side, MIN_SIDE)}) "
            f"or --texels-per-unit")


def form_factor_budget(width: int, height: int, max_memory: int, texel_samples: int = 2,
                       available: int | None = None) -> int:
    """Bytes F may keep: --max-memory, or what the machine has left beside the rest of the bake."""
    available = available_memory() if available is None else int(available)
    if available <= 0:
        return int(max_memory)
    left = HEADROOM * available - estimate_bake_bytes(width, height, texel_samples)
    return int(max(0, min(max_memory, left)))
