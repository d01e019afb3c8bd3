"""What a bake needs in memory and time, and what the machine has.

A bake's peak resident memory is, measured on the room (bench/bench_memory.py, the CLI's
whole process, writing included): BASE_BYTES (the interpreter, NumPy, numba's kernels,
Embree) plus BYTES_PER_TEXEL per texel of the W x H image (patch arrays, light vectors, the
sampler's plan and state, the passes kept as float16, images and the files' buffers),
covered or not, plus the form-factor matrix F (FORM_FACTOR_BYTES_PER_TEXEL: the room's 123,
108 and 99 at 1024, 2048 and 4096, four bytes an entry). Peak minus F was 0.52, 1.42 and
4.91 GiB at 1024, 2048 and 4096: 256 MiB plus 276, 300 and 298 bytes a texel (the
writing, since in bands beside texels.npz, less: 4.52 GiB at 4096). Direct light
works chunk by chunk, so its points per texel cost nothing per texel, and texels.npz is
written pass by pass. Directional maps (`--directional`) add DIRECTIONAL_BYTES_PER_TEXEL: their
float64 sums per patch and their images (the room at 1024 and 2048: 204 and 210 bytes a texel
with sh, 187 at 2048 with dominant). The time is CPU seconds per texel over the cores: 22
microseconds each, a bound for the machines measured, which differ threefold (the whole
command, the room at 1024, 2048 and 4096: 18, 15 and 14 on one VM, 241 CPU seconds for 16.8 M
texels at 4096; the bake alone on a faster one: the room 4.6-5.1, the Cornell box 4.0, the
town of bench/bench_large.py at 2048 5.8), and 40 more with directional maps, which gather
every texel again (the room with sh at 1024 added 31 on the first VM, 13 on the faster one;
the Cornell box with dominant 29 there). F gets what is left, up to max_memory, and is
dropped for re-gathering once it would not fit (solve.FormFactors). The rest is checked before any work, so a lightmap too
large is refused with the estimate (and the time it would take) instead of being killed by
the kernel halfway; the whole estimate (estimate_peak_bytes, estimate_seconds) goes into
bake.json beside the measured peak (bench/bench_memory.py compares them).
"""
from __future__ import annotations

import math
import os

from ..errors import PatchlightError
from ..limits import available_memory

BASE_BYTES = 256 << 20         # the interpreter and its libraries
BYTES_PER_TEXEL = 300          # F aside (module docstring)
DIRECTIONAL_BYTES_PER_TEXEL = 210  # more with directional maps (module docstring)
FORM_FACTOR_BYTES_PER_TEXEL = 110  # F of the room per lightmap texel (module docstring)
CORE_SECONDS_PER_TEXEL = 22e-6  # a bake per texel on one core, a bound (module docstring)
DIRECTIONAL_CORE_SECONDS_PER_TEXEL = 40e-6  # more with directional maps (module docstring)
HEADROOM = 0.9                 # of the available memory, the share a bake may plan to use
MIN_SIDE = 16


def estimate_bake_bytes(width: int, height: int, directional: bool = False) -> int:
    """Peak bytes of baking a width x height lightmap (with directional maps or not), F aside
    (it adapts to what is left)."""
    per_texel = BYTES_PER_TEXEL + (DIRECTIONAL_BYTES_PER_TEXEL if directional else 0)
    return BASE_BYTES + int(width) * int(height) * per_texel


def estimate_peak_bytes(width: int, height: int, budget: int, directional: bool = False) -> int:
    """Peak bytes of the whole bake: the rest (estimate_bake_bytes) plus F at the room's
    measured bytes per texel, at most its budget (beyond it F is dropped and re-gathered)."""
    form_factors = min(FORM_FACTOR_BYTES_PER_TEXEL * int(width) * int(height), int(budget))
    return estimate_bake_bytes(width, height, directional) + form_factors


def estimate_seconds(width: int, height: int, directional: bool = False) -> float:
    """Seconds a width x height bake (with directional maps or not) takes on this machine's
    cores, at most (module docstring)."""
    per_texel = CORE_SECONDS_PER_TEXEL + (DIRECTIONAL_CORE_SECONDS_PER_TEXEL if directional else 0)
    return per_texel * int(width) * int(height) / (os.cpu_count() or 1)


def peak_resident_bytes() -> int:
    """The most resident memory this process has held so far (Linux: ru_maxrss in KiB)."""
    import resource

    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024


def check_bake_memory(width: int, height: int, available: int | None = None, directional: bool = False) -> None:
    """Refuse (PatchlightError) a lightmap whose bake would not fit in the available memory,
    with the estimates of memory and time and the largest resolution that would fit."""
    needed = estimate_bake_bytes(width, height, directional)
    usable = HEADROOM * (available_memory() if available is None else int(available))
    if usable > 0 and needed > usable:
        side = int(math.sqrt(max(usable - BASE_BYTES, 0) / max(needed - BASE_BYTES, 1)) * min(width, height)) // 4 * 4
        raise PatchlightError(
            f"lightmap {width}x{height}: the bake needs about {needed / 2**30:.1f} GiB (and about "
            f"{estimate_seconds(width, height, directional) / 60:.0f} minutes) but only {usable / 2**30:.1f} GiB is available; "
            f"lower `resolution` (about {max(side, MIN_SIDE)}) or `texels_per_unit`")


def form_factor_budget(width: int, height: int, max_memory: int, available: int | None = None,
                       directional: bool = False) -> int:
    """Bytes F may keep: max_memory, or what the machine has left beside the rest of the bake."""
    available = available_memory() if available is None else int(available)
    if available <= 0:
        return int(max_memory)
    left = HEADROOM * available - estimate_bake_bytes(width, height, directional)
    return int(max(0, min(max_memory, left)))
