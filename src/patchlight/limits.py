"""Limits on what an input file may ask for, checked before anything is allocated.

A few bytes of JSON or PNG can ask for terabytes: an accessor count of 2^40, an image header of
100,000 x 100,000 pixels, a list nested thousands deep, an integer of thousands of digits.
Each reader checks sizes here first, so such a file is one clear line, never a process the
kernel kills or a traceback.

- JSON (`load_json`): nesting at most MAX_JSON_DEPTH deep, integers at most MAX_INT_DIGITS
  digits (every count, offset and index fits in 64 bits). Non-finite numbers are left to the
  readers, which say which field holds one.
- Images: at most `max_image_pixels()` pixels once decoded (PATCHLIGHT_MAX_IMAGE_PIXELS raises it).
- Arrays: `check_allocation` refuses what would not fit in the memory available now.
"""
from __future__ import annotations

import json
import os
import re

import numpy as np

from .errors import PatchlightError

MAX_JSON_DEPTH = 64
MAX_INT_DIGITS = 20
MAX_IMAGE_PIXELS = 1 << 26  # 8192 x 8192; PATCHLIGHT_MAX_IMAGE_PIXELS raises it
IMAGE_PIXELS_VARIABLE = "PATCHLIGHT_MAX_IMAGE_PIXELS"
HEADROOM = 0.9  # of the available memory, the share one input may ask for

_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"')
_OPENERS, _CLOSERS = np.frombuffer(b"[{", np.uint8), np.frombuffer(b"]}", np.uint8)


def available_memory() -> int:
    """Bytes of memory available now (Linux MemAvailable, else free pages; 0 when unknown)."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 0


def check_allocation(nbytes: int, what: str) -> None:
    """PatchlightError("<what> needs N GiB ...") when `nbytes` would not fit in the memory available."""
    usable = HEADROOM * available_memory()
    if usable > 0 and nbytes > usable:
        raise PatchlightError(f"{what} needs {nbytes / 2**30:.1f} GiB, more than the "
                              f"{usable / 2**30:.1f} GiB available")


def max_image_pixels() -> int:
    """The most pixels an image may decode to: MAX_IMAGE_PIXELS, or $PATCHLIGHT_MAX_IMAGE_PIXELS."""
    text = os.environ.get(IMAGE_PIXELS_VARIABLE, "")
    try:
        return max(int(text), 1) if text else MAX_IMAGE_PIXELS
    except ValueError:
        raise PatchlightError(f"{IMAGE_PIXELS_VARIABLE}={text[:40]!r}: want a whole number of pixels") from None


def check_image_size(width: int, height: int, channels: int, where: str) -> None:
    """Refuse an image header asking for more pixels than the limit, or more memory than there is
    (as float32, `channels` per pixel), before it is decoded."""
    limit = max_image_pixels()
    if width * height > limit:
        raise PatchlightError(f"{where}: image of {width} x {height} pixels is over the limit of {limit:,} "
                              f"(set {IMAGE_PIXELS_VARIABLE} to raise it)")
    check_allocation(width * height * channels * 4, f"{where}: image of {width} x {height} pixels")


def load_json(data: bytes | str, where: str):
    """Parse JSON text, refusing (PatchlightError) what is not JSON, nesting deeper than
    MAX_JSON_DEPTH and integers longer than MAX_INT_DIGITS digits."""
    raw = data.encode("utf-8", "surrogatepass") if isinstance(data, str) else data
    depth = _depth(raw)
    if depth > MAX_JSON_DEPTH:
        raise PatchlightError(f"{where}: JSON nested {depth} deep, more than the limit of {MAX_JSON_DEPTH}")
    try:
        return json.loads(data, parse_int=_integer)
    except _NumberError as exc:
        raise PatchlightError(f"{where}: JSON {exc}") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise PatchlightError(f"{where}: not JSON (invalid JSON: {exc})") from None


def _depth(raw: bytes) -> int:
    """Deepest nesting of [ and { outside strings, without recursion."""
    text = np.frombuffer(_STRING.sub(b'""', raw), np.uint8)
    steps = np.isin(text, _OPENERS).astype(np.int64) - np.isin(text, _CLOSERS)
    return int(np.cumsum(steps).max(initial=0))


class _NumberError(ValueError):
    pass


def _integer(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        raise _NumberError(f"integer of {len(text.lstrip('-'))} digits, more than the limit of {MAX_INT_DIGITS}")
    return int(text)
