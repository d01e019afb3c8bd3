"""Every settings class is declared once (config.setting on each field): the checks, the
--help texts, the command line's errors and the documented tables must all say what the
declarations say."""
from __future__ import annotations

import math
import re
from dataclasses import MISSING
from pathlib import Path

import pytest

from patchlight.cli.parser import build_parser
from patchlight.config import BakeSettings, declared, settings_table
from patchlight.errors import SettingError
from patchlight.ground.groundmap import GroundMapSettings
from patchlight.normalmap import NormalMapSettings
from patchlight.render.camera import Camera
from patchlight.shading.models import ShadingSettings
from patchlight.volumes.grid import GridSettings
from patchlight.volumes.probes import VolumeSettings

REPO = Path(__file__).resolve().parents[1]
# every settings class, with what its table in docs/settings.md says about it
SETTINGS = {
    BakeSettings: "`patchlight bake` (and the bakes `volume` and `groundmap` make of a scene).",
    VolumeSettings: "How each probe of a light volume gathers (`patchlight volume`).",
    GridSettings: "Where a light volume's probes go (`patchlight volume --spacing/--dims/--bounds`).",
    GroundMapSettings: "`patchlight groundmap` (`offset` is the flag `--offset-distance`).",
    ShadingSettings: "What decides a shaded pixel in `patchlight render` and `view` (`lightmap_specular` is "
                     "`--specular`, `ambient_cube_naive` `--naive-weights`).",
    Camera: "`patchlight render --camera EX,EY,EZ TX,TY,TZ FOV`.",
    NormalMapSettings: "`patchlight normalmap` (`dilation` is `--dilate`; `width` and `height` are `--size WxH`).",
}
DOC_HEAD = """# Settings

Generated from the declarations on the fields of each settings class (`patchlight.config.setting`,
tables by `settings_table(cls)`; `python tests/test_settings.py` writes this file). The same
declarations check the settings (`validate`, a `SettingError` naming the field; the command line
names the flag instead) and give the commands' `--help` texts with their defaults.
`tests/test_settings.py` fails when this file and the code disagree.
"""
REQUIRED = {Camera: {"eye": (0.0, 1.0, 5.0), "target": (0.0, 0.0, 0.0)}}  # fields without a default
COMMANDS = {"bake": (BakeSettings,), "volume": (VolumeSettings, GridSettings), "groundmap": (GroundMapSettings,),
            "normalmap": (NormalMapSettings,), "render": (ShadingSettings, Camera), "view": (ShadingSettings,)}


def make(cls, **changes):
    """An instance of a settings class, validated: its defaults (REQUIRED where it has none) changed by `changes`."""
    settings = cls(**{**REQUIRED.get(cls, {}), **changes})
    settings.validate()
    return settings


def probes(meta: dict) -> tuple[list, list]:
    """(values the declaration accepts, values it refuses), at the edges of its range."""
    lo, hi, step = meta["lo"], meta["hi"], 1 if meta["whole"] else 1e-3
    accepted, refused = list(meta["choices"]), ["no such choice"] if meta["choices"] else []
    if lo is not None:
        (refused if meta["lo_open"] else accepted).append(lo)
        refused.append(lo - step * (2 if meta["even"] else 1))
        accepted.append(lo + step * (2 if meta["even"] else 1))
    if hi is not None:
        (refused if meta["hi_open"] else accepted).append(hi)
        refused.append(hi + step * (2 if meta["even"] else 1))
    if lo is not None or hi is not None:
        refused += [math.nan, True] + ([(lo if lo is not None else hi) + 0.5] if meta["whole"] else [])
    if meta["length"]:
        accepted, refused = [tuple(v for _ in range(meta["length"])) for v in accepted], \
                            [tuple(v for _ in range(meta["length"])) for v in refused] + [(1.0,) * (meta["length"] + 1)]
        if lo is None and hi is None:
            accepted, refused = [(0.5,) * meta["length"]], [(math.inf,) * meta["length"], (1.0,) * (meta["length"] - 1)]
    if meta["each"]:
        accepted, refused = [{"room": v} for v in accepted], [{"room": v} for v in refused] + [0.5]
    if meta["none"]:
        accepted.append(None)
    return accepted, refused


def settings_doc() -> str:
    """docs/settings.md as the declarations make it."""
    return DOC_HEAD + "".join(f"\n## {cls.__name__}\n\n`{cls.__module__}.{cls.__name__}`: {about}\n\n"
                              f"{settings_table(cls)}" for cls, about in SETTINGS.items())


def test_docs_hold_the_tables_the_declarations_make():
    assert (REPO / "docs" / "settings.md").read_text() == settings_doc(), "run python tests/test_settings.py"


@pytest.mark.parametrize("cls", SETTINGS, ids=lambda c: c.__name__)
def test_every_settings_class_validates_exactly_its_declarations(cls):
    for f in declared(cls):
        accepted, refused = probes(f.metadata)
        if cls is Camera and f.name in ("eye", "target"):
            accepted = [v for v in accepted if v != (0.5,) * 3] + [(0.5, 0.7, 0.25)]  # not the other point
        for value in accepted:
            make(cls, **{f.name: value})
        for value in refused:
            with pytest.raises(SettingError) as err:
                make(cls, **{f.name: value})
            assert err.value.field == f.name and str(err.value).startswith(f"{f.name}: "), (f.name, value)


@pytest.mark.parametrize("command", COMMANDS)
def test_each_flag_of_a_declared_field_shows_its_meaning_and_default(command):
    parser = build_parser().commands[command]
    shown = 0
    for cls in COMMANDS[command]:
        for f in declared(cls):
            action = next((a for a in parser._actions if a.dest == f.name and a.option_strings), None)
            if action is not None and f.metadata["unit"] == "bool" and action.const is True:  # a switch on
                assert f.metadata["meaning"] in re.sub(r"\s+", " ", action.help), (command, action.option_strings)
                shown += 1
            if action is None or f.metadata["unit"] == "bool" or action.help is None or "%(default)" not in action.help:
                continue
            text = re.sub(r"\s+", " ", action.help % {"default": action.default})
            assert f.metadata["meaning"] in text, (command, action.option_strings)
            default = f.default if f.default is not MISSING else None
            if command == "bake" and f.name == "max_memory":  # the flag counts GiB
                default /= 2**30
            if default is not None:
                assert action.default == default and f"(default {default})" in text, (command, action.option_strings)
            shown += 1
    assert shown


@pytest.mark.parametrize("command", COMMANDS)
def test_the_command_line_names_the_flag_where_the_library_names_the_field(command):
    """Every declared field a command has a flag for: its SettingError reads as that flag."""
    parser = build_parser().commands[command]
    for cls in COMMANDS[command]:
        for f in declared(cls):
            flag = parser.flag(f.name)
            refused = probes(f.metadata)[1]
            if flag is None or not refused:
                continue
            with pytest.raises(SettingError) as err:
                make(cls, **{f.name: refused[0]})
            line = parser.user_line(err.value)
            assert str(err.value).startswith(f"{f.name}: ") and "--" not in str(err.value)
            assert line.startswith(f"{flag} ") and f": {f.name.replace('_', ' ')} must be" in line, line


@pytest.mark.parametrize("name, accepted, refused", [
    ("resolution", [16, 8192, None], [15, 8193, 64.0, True]),
    ("hemicube_size", [2, 32, 512], [0, 3, 514]),           # the table once said 8..512; the check always took 2
    ("rays", [1, 16384], [0, 16385, 2.5]),                  # ... and 16..16384 where the check took 1
    ("accuracy", [0.5, 0.999], [0.0, 1.0, float("nan")]),
    ("sun_angle", [None, 0.0, 89.9], [-1.0, 90.0]),
    ("gather", ["stratified", "hemicube"], ["radiosity"]),
    ("exposure", ["auto", 0.1], [0.0, "bright"]),
    ("max_memory", [0, 1 << 30], [-1]),
])
def test_validate_takes_exactly_the_declared_range(name, accepted, refused):
    for value in accepted:
        BakeSettings(**{name: value}).validate()
    for value in refused:
        with pytest.raises(SettingError) as err:
            BakeSettings(**{name: value}).validate()
        assert err.value.field == name and str(err.value).startswith(f"{name}: ")


def test_bake_help_shows_each_flags_default():
    help_text = re.sub(r"\s+", " ", build_parser().commands["bake"].format_help())
    help_text = help_text[help_text.index("options:"):]  # past the usage line
    defaults = BakeSettings()
    for flag, name in [("--texels-per-unit", "texels_per_unit"), ("--hemicube-size", "hemicube_size"),
                       ("--rays", "rays"), ("--passes", "passes"), ("--tolerance", "tolerance"),
                       ("--accuracy", "accuracy"), ("--first-accuracy", "first_accuracy"), ("--seed", "seed"),
                       ("--gather", "gather"), ("--exposure", "exposure")]:
        after = help_text[help_text.index(f" {flag} "):]
        assert f"(default {getattr(defaults, name)})" in after[:400], flag


def test_the_cli_names_the_flag_the_library_names_the_field(capsys):
    from patchlight.cli.main import main

    assert main(["bake", "cornell", "-o", "unused", "--rays", "0"]) == 2
    assert "--rays 0: rays must be a whole number in 1..16384" in capsys.readouterr().err
    with pytest.raises(SettingError, match=r"^rays: 0 must be a whole number in 1\.\.16384"):
        BakeSettings(rays=0).validate()


def test_readme_defaults_agree_with_the_declarations():
    """The README's option table gives the defaults of the flags it lists."""
    rows = {}
    for line in (REPO / "README.md").read_text().splitlines():
        cells = [c.strip() for c in line.split("|")[1:-1]]
        if len(cells) == 3 and cells[0].startswith("`--"):
            rows[cells[0]] = cells[1]
    d = BakeSettings()

    def numbers(flags):
        return [float(v) for v in re.findall(r"\d+(?:\.\d+)?(?:e-?\d+)?", rows[flags])]

    assert numbers("`--rays N`, `--hemicube-size N`") == [d.rays, d.hemicube_size]
    assert numbers("`--passes N`, `--tolerance T`") == [d.passes, d.tolerance]
    assert numbers("`--accuracy A`, `--first-accuracy A0`, `--no-adaptive`") == [d.accuracy, d.first_accuracy]
    assert numbers("`--max-memory GiB`") == [d.max_memory / 2**30]
    assert numbers("`--resolution N` / `--texels-per-unit T`") == [d.texels_per_unit]


if __name__ == "__main__":
    (REPO / "docs" / "settings.md").write_text(settings_doc())
