"""The `patchlight` argument parser: one module per subcommand, each with register(subparsers)."""
from __future__ import annotations

import argparse
import functools
import importlib
import math
import re

def finite_number(text: str) -> float:
    """An argparse type: a finite float (argparse's float takes nan and inf)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def writes_output(run):
    """A subcommand's run(args) holding the writers' lock of args.output from the start
    (`patchlight.outputs.output_lock`), so a second writer into that folder stops at once."""

    @functools.wraps(run)
    def locked(args):
        from ..outputs import output_lock

        with output_lock(args.output):
            return run(args)

    return locked


# settings fields set through a flag whose dest is another name: field -> that dest
FIELD_FLAGS = {"eye": "camera", "fov": "camera"}

SUBCOMMANDS = ("bake", "demo", "render", "view", "groundmap", "volume", "vertexbake", "normalmap", "blender")
READS_SCENES = ("bake", "render", "view", "groundmap", "volume", "vertexbake", "normalmap")


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors, and coordinates such as `-3.2,2,4` taken as values
    (argparse 3.11 takes only a plain negative number for one)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def error(self, message):  # argparse's own usage errors also exit 2, in one line
        self.exit(2, f"patchlight: error: {message}\n")

    def flag(self, dest: str) -> str | None:
        """The option that sets `dest` (its long form; a field set through a flag of another
        name, FIELD_FLAGS), or None."""
        dest = FIELD_FLAGS.get(dest, dest)
        return next((a.option_strings[-1] for a in self._actions if a.dest == dest and a.option_strings), None)

    def user_line(self, exc) -> str:
        """The one line a PatchlightError from this command shows its user: the fields it names
        (a SettingError's field, and `field` in backquotes) said as the flags that set them."""
        from ..errors import SettingError

        line = str(exc)
        flag = self.flag(exc.field) if isinstance(exc, SettingError) else None
        if flag:
            value = exc.value
            if isinstance(value, (tuple, list)):
                value = ",".join(f"{v:g}" for v in value)
            line = f"{flag} {value}: {exc.field.replace('_', ' ')} {exc.problem}"
        return re.sub(r"`(\w+)`", lambda m: self.flag(m[1]) or m[0], line)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="patchlight", description="Baked radiosity lightmaps, light volumes, ground "
                     "maps and the classic real-time lighting models, on the CPU. "
                     "`patchlight COMMAND --help` for each command.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in SUBCOMMANDS:
        importlib.import_module(f"patchlight.cli.{name}").register(sub)
        if name in READS_SCENES:
            sub.choices[name].add_argument(
                "--allow-outside-files", action="store_true",
                help="let the glTF's uris name files outside its folder (absolute paths, '..', links)")
    parser.commands = sub.choices  # name -> its parser
    return parser
