"""What a bake needs in memory, and what the machine has.

A bake's peak resident memory is, measured on the room at 2 x 2 texel samples:
BASE_BYTES (the interpreter, NumPy, numba's kernels, Embree) plus BYTES_PER_TEXEL per texel
of the W x H image (patch arrays, the points spread over each texel for direct light, light
vectors, the sampler's state, images), covered or not, plus the form-factor matrix F
(FORM_FACTOR_BYTES_PER_TEXEL: 568 at 512, 552 at 1024, 532 at 2048). Peak minus F was 681
and 471 bytes per texel at 1024 and 2048, i.e. about 280 MiB plus 400 a texel; each further
direct-light sample adds about 74 (room 512 at 4 x 4). F gets what is left, up to
--max-memory, and is dropped for re-gathering once it would not fit (solve.FormFactors).
The rest is checked before any work, so a lightmap too large is refused with the estimate
instead of being killed by the kernel halfway; the whole estimate (estimate_peak_bytes) goes
into bake.json beside the measured peak (bench/bench_memory.py compares them).
"""
from __future__ import annotations

import math

from ..errors import PatchlightError
from ..limits import available_memory

BASE_BYTES = 280 << 20         # the interpreter and its libraries
BYTES_PER_TEXEL = 400          # at 2 x 2 texel samples, F aside (module docstring)
BYTES_PER_TEXEL_SAMPLE = 80    # each further direct-light point per texel: measured about 74
FORM_FACTOR_BYTES_PER_TEXEL = 545  # F of the room per lightmap texel (module docstring)
HEADROOM = 0.9                 # of the available memory, the share a bake may plan to use
MIN_SIDE = 16


def estimate_bake_bytes(width: int, height: int, texel_samples: int = 2) -> int:
    """Peak bytes of baking a width x height lightmap, F aside (it adapts to what is left)."""
    per_texel = BYTES_PER_TEXEL + BYTES_PER_TEXEL_SAMPLE * max(0, texel_samples ** 2 - 4)
    return BASE_BYTES + int(width) * int(height) * per_texel


def estimate_peak_bytes(width: int, height: int, budget: int, texel_samples: int = 2) -> int:
    """Peak bytes of the whole bake: the rest (estimate_bake_bytes) plus F at the room's
    measured bytes per texel, at most its budget (beyond it F is dropped and re-gathered)."""
    form_factors = min(FORM_FACTOR_BYTES_PER_TEXEL * int(width) * int(height), int(budget))
    return estimate_bake_bytes(width, height, texel_samples) + form_factors


def peak_resident_bytes() -> int:
    """The most resident memory this process has held so far (Linux: ru_maxrss in KiB)."""
    import resource

    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024


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
