"""`patchlight` command line: one module per subcommand, each with register(subparsers).

User errors (PatchlightError) print one line and exit 2; Ctrl-C exits 130 after the
subcommand has cleaned up.
"""
from __future__ import annotations

import argparse
import re
import sys

from ..errors import PatchlightError

SUBCOMMANDS = ("bake", "demo", "render", "view", "groundmap", "volume", "vertexbake", "normalmap")


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors, and coordinates such as `-3.2,2,4` taken as values
    (argparse 3.11 takes only a plain negative number for one)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def error(self, message):  # argparse's own usage errors also exit 2, in one line
        self.exit(2, f"patchlight: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    import importlib

    parser = _Parser(prog="patchlight", description="Baked radiosity lightmaps, light volumes, ground "
                     "maps and the classic real-time lighting models, on the CPU. "
                     "`patchlight COMMAND --help` for each command.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in SUBCOMMANDS:
        importlib.import_module(f"patchlight.cli.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # usage errors and --help, already printed
        return int(exc.code or 0)
    try:
        return int(args.func(args) or 0)
    except PatchlightError as exc:
        print(f"patchlight: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("patchlight: interrupted; nothing partial was written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
