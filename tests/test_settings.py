"""The bake settings are declared once (config.setting on each field of BakeSettings): the
checks, the --help texts and the documented tables must all say what the declarations say."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from patchlight.cli.parser import build_parser
from patchlight.config import BakeSettings, settings_table
from patchlight.errors import SettingError

REPO = Path(__file__).resolve().parents[1]


def test_docs_hold_the_table_the_declarations_make():
    assert settings_table() in (REPO / "docs" / "settings.md").read_text()


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
