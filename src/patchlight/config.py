"""Settings declared once: each field of a settings class carries its default, unit, range,
typical value and meaning (`setting`). The declarations drive the checks (`validate_fields`,
SettingError naming the field), the commands' --help texts (cli/options.py `about`) and the
tables in docs/settings.md (`settings_table`; a test checks that the file holds exactly those
tables). BakeSettings lives here; the other classes live beside the code they configure
(volumes/probes.py VolumeSettings, volumes/grid.py GridSettings, ground/groundmap.py
GroundMapSettings, shading/models.py ShadingSettings, render/camera.py Camera,
normalmap.py NormalMapSettings).
"""
from __future__ import annotations

import math
import numbers
from dataclasses import MISSING, asdict, dataclass, field, fields

import numpy as np

from .errors import SettingError

GiB = 1 << 30
FALLOFFS = ("inverse-square", "range")
GATHERS = ("stratified", "hemicube")
DIRECTIONAL_MODES = ("sh", "dominant")  # L1 spherical harmonics, or the dominant direction and its share
TEXELS_PER_UNIT = (1e-3, 1e4)  # the range taken, texels per metre
PLAIN_UNITS = ("", "ratio", "count", "int", "bool", "str")  # units the help texts and errors leave unsaid


def setting(default=MISSING, unit: str = "", meaning: str = "", *, lo=None, hi=None, lo_open: bool = False,
            hi_open: bool = False, whole: bool = False, even: bool = False, choices: tuple = (), typical: str = "",
            none: str = "", each: bool = False, length: int = 0, factory=None):
    """A settings field with its metadata: unit; meaning; the accepted range lo..hi (either
    end may be open or absent); whole: an int; even; choices: the accepted strings (beside a
    number, when a range is given too); typical: the usual values; none: what None means
    (None is refused when empty); each: the value is a {name: value} dict (default: empty),
    every value checked; length: the value is a sequence of that many numbers, each checked;
    factory: makes the default (arrays); default MISSING (and no factory): a required field."""
    meta = {"unit": unit, "meaning": meaning, "lo": lo, "hi": hi, "lo_open": lo_open, "hi_open": hi_open,
            "whole": whole, "even": even, "choices": choices, "typical": typical, "none": none, "each": each,
            "length": length}
    if each:
        factory = dict
    if factory is not None:
        return field(default_factory=factory, metadata=meta)
    return field(default=default, metadata=meta)


def declared(cls) -> list:
    """The fields of a settings class (or instance) that carry `setting` metadata."""
    return [f for f in fields(cls) if "unit" in f.metadata]


def accepted(meta: dict, unit: bool = False) -> str:
    """The accepted values of a field, as the table and the errors word them (unit: with the
    unit after the range)."""
    choices = meta["choices"]
    parts = [choices[0] if len(choices) == 1 else f"one of {', '.join(choices)}"] if choices else []
    lo, hi = meta["lo"], meta["hi"]
    if lo is not None or hi is not None:
        kind = "even whole number" if meta["even"] else "whole number" if meta["whole"] else "number"
        if lo is not None and hi is not None and not (meta["lo_open"] or meta["hi_open"]):
            parts.append(f"{kind} in {_number(lo)}..{_number(hi)}")
        else:
            bounds = ([f"{'>' if meta['lo_open'] else '>='} {_number(lo)}"] if lo is not None else []) + \
                     ([f"{'<' if meta['hi_open'] else '<='} {_number(hi)}"] if hi is not None else [])
            parts.append(f"{kind} {' and '.join(bounds)}")
    if meta["length"]:
        parts = [f"{meta['length']} numbers" + (f", each a {parts[0]}" if parts else "")]
    if unit and parts and meta["unit"] not in PLAIN_UNITS:
        parts[-1] += f" ({meta['unit']})"
    if meta["none"]:
        parts.append(f"unset ({meta['none']})")
    return " or ".join(parts)


def _number(v) -> str:
    """A bound as the texts show it: whole numbers in full, others shortest (%g)."""
    return str(v) if isinstance(v, int) else f"{v:g}"


def check(name: str, value, meta: dict) -> None:
    """SettingError naming the field when `value` is outside what `meta` accepts."""
    if meta["each"]:
        if not isinstance(value, dict):
            raise SettingError(name, value, "must be a {name: value} mapping")
        for key, item in value.items():
            try:
                check(name, item, {**meta, "each": False})
            except SettingError as exc:  # named as the command line gives it: NAME=VALUE
                raise SettingError(name, f"{key}={item}", exc.problem) from None
        return
    if value is None and meta["none"]:
        return
    if meta["length"]:
        items = list(np.ravel(value)) if isinstance(value, (list, tuple, np.ndarray)) else []
        each = {**meta, "length": 0, "none": "", "choices": ()}
        if each["lo"] is None and each["hi"] is None:
            each["lo"] = -math.inf  # any finite number
        if len(items) != meta["length"] or not all(_fits(name, item, each) for item in items):
            raise SettingError(name, value, f"must be {accepted(meta, unit=True)}")
        return
    if isinstance(value, str) and value in meta["choices"]:
        return
    lo, hi = meta["lo"], meta["hi"]
    if lo is None and hi is None:
        if meta["choices"]:
            raise SettingError(name, value, f"must be one of {', '.join(meta['choices'])}")
        return
    number = isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)) and math.isfinite(value)
    ok = (number and (not meta["whole"] or isinstance(value, numbers.Integral)) and
          (not meta["even"] or value % 2 == 0)
          and (lo is None or (value > lo if meta["lo_open"] else value >= lo))
          and (hi is None or (value < hi if meta["hi_open"] else value <= hi)))
    if not ok:
        article = "" if meta["choices"] else "a "
        raise SettingError(name, value, f"must be {article}{accepted(meta, unit=True)}")


def _fits(name: str, value, meta: dict) -> bool:
    try:
        check(name, value, meta)
    except SettingError:
        return False
    return True


def validate_fields(settings) -> None:
    """SettingError naming the first declared field of `settings` outside what it accepts."""
    for f in declared(settings):
        check(f.name, getattr(settings, f.name), f.metadata)


@dataclass
class BakeSettings:
    resolution: int | None = setting(None, "texels", "lightmap width = height", lo=16, hi=8192, whole=True,
                                     typical="256-2048", none="from `texels_per_unit`")
    texels_per_unit: float = setting(16.0, "texels / m", "lightmap density when UVs are made", lo=TEXELS_PER_UNIT[0],
                                     hi=TEXELS_PER_UNIT[1], typical="8-64")
    padding: int = setting(2, "texels", "gap between UV charts", typical="2")
    max_atlas: int = setting(4096, "texels", "the largest atlas edge: charts that do not fit one such atlas go to "
                             "several (lightmap_0.exr, lightmap_1.exr, ...)", lo=64, hi=8192, whole=True,
                             typical="2048-8192")
    gather: str = setting("stratified", "", "gather rays: stratified cosine rays, or hemicubes (measured slower "
                          "to a given error)", choices=GATHERS)
    hemicube_size: int = setting(32, "pixels", "hemicube front face N x N", lo=2, hi=512, even=True, whole=True,
                                 typical="32-128")
    rays: int = setting(512, "rays / patch", "stratified rays, rounded down to an a x b grid", lo=1, hi=16384,
                        whole=True, typical="256-4096")
    passes: int = setting(100, "count", "upper bound on passes (1 = direct + sky + emitters)", lo=1, whole=True,
                          typical="100")
    tolerance: float = setting(1e-3, "ratio", "stop when the largest relative change still to come is below",
                               lo=0, lo_open=True, typical="1e-3")
    adaptive: bool = setting(True, "bool", "gather every 4th texel, then where neighbours differ")
    first_accuracy: float = setting(0.5, "ratio", "the adaptive sampler's first run, for the first passes",
                                    lo=0, hi=1, lo_open=True, hi_open=True, typical="0.5")
    accuracy: float = setting(0.98, "ratio", "the sampler's final run: gather where neighbours differ by more than "
                              "accuracy ^ spacing", lo=0, hi=1, lo_open=True, hi_open=True, typical="0.98")
    sun_samples: int = setting(16, "rays / texel", "shadow rays over the sun's disc when its angle is > 0", lo=1,
                               whole=True, typical="16")
    emitter_samples: int = setting(64, "rays / texel", "shadow rays to emissive triangles, n x n over the texel "
                                   "(0: the gather alone finds them)", lo=0, hi=1024, whole=True, typical="64")
    texel_samples: int = setting(2, "per axis", "direct light averaged over n x n points of each texel", lo=1, hi=4,
                                 whole=True, typical="2")
    sun_angle: float | None = setting(None, "degrees", "the sun's angular diameter (0 = hard shadows)", lo=0, hi=90,
                                      hi_open=True, typical="0.53 (the real sun)", none="each light's own")
    falloff: str = setting("inverse-square", "", "point/spot falloff for lights that name none", choices=FALLOFFS)
    exposure: float | str = setting("auto", "1 / radiance", "PNG = 1 - exp(-k I); auto puts the 90th percentile at "
                                    "0.8", lo=0, lo_open=True, choices=("auto",))
    max_memory: int = setting(8 * GiB, "bytes", "the most the form-factor matrix may keep; beyond, every pass "
                              "re-gathers", lo=0, hi=1 << 50, whole=True, typical="8 GiB")
    seed: int = setting(1, "int", "the jitter of the ray pattern and its rotation per patch", lo=0, whole=True)
    denoise: bool = setting(False, "bool", "OIDN on the gathered light, chart by chart; direct stays sharp")
    save_passes: bool = setting(False, "bool", "also a PNG per pass (pass_01.png, ...); texels.npz has them all")
    stitch: bool = setting(True, "bool", "least-squares agreement of the lookups across UV chart seams")
    directional: str | None = setting(None, "", "also bake the light's direction: L1 spherical harmonics "
                                      "(lightmap_sh.exr) or the dominant direction and its share (lightmap_dir.exr)",
                                      choices=DIRECTIONAL_MODES, none="no directional map")
    ray: str | None = setting(None, "str", "Ray head HOST:PORT for the gather (\"auto\", or \"local\": start one)",
                              none="gather here")
    density: dict = setting(None, "texels / m", "the density of the objects (glTF nodes or meshes) so named, over "
                            "their extras", lo=TEXELS_PER_UNIT[0], hi=TEXELS_PER_UNIT[1], each=True)

    def to_json(self) -> dict:
        return asdict(self)

    def validate(self) -> None:
        """SettingError naming the first setting outside what its field accepts."""
        validate_fields(self)


def settings_table(cls=BakeSettings) -> str:
    """The Markdown table of a settings class's declared fields: name, unit, default, accepted
    values, typical values, meaning."""
    rows = ["| name | unit | default | accepted | typical | meaning |", "|---|---|---|---|---|---|"]
    for f in declared(cls):
        m = f.metadata
        rows.append(f"| {f.name} | {m['unit']} | {default_text(f)} | {accepted(m)} | {m['typical']} | {m['meaning']} |")
    return "\n".join(rows) + "\n"


def default_text(f) -> str:
    """A field's default as the table shows it ("required" when it has none)."""
    if f.default is MISSING and f.default_factory is MISSING:
        return "required"
    value = f.default_factory() if f.default is MISSING else f.default
    if isinstance(value, np.ndarray):
        value = value.tolist()
    return repr(value) if isinstance(value, str) else str(value)
