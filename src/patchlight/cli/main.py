"""`patchlight` command line (the parser is `cli/parser.py`, one module per subcommand).

User errors (PatchlightError) print one line and exit 2. SIGINT (Ctrl-C) and SIGTERM are
handled from the first instant (this module imports nothing heavy; `patchlight` loads its
names on first use): either one raises KeyboardInterrupt wherever the program is, the
subcommand cleans up, and the exit status is 128 + the signal (130, 143), after one line.
"""
from __future__ import annotations

import signal
import sys
import warnings


def main(argv: list[str] | None = None) -> int:
    received = []
    previous = _handle_stop_signals(received)
    try:
        return _run(argv)
    except BaseException as exc:
        # a signal's KeyboardInterrupt raised inside a numba dispatcher surfaces as a
        # SystemError ("returned a result with an exception set"), so any exception counts
        number = received[0] if received else signal.SIGINT if isinstance(exc, KeyboardInterrupt) else None
        if number is None:
            raise
        word = "interrupted" if number == signal.SIGINT else "terminated"
        print(f"patchlight: {word}; nothing partial was written", file=sys.stderr)
        return 128 + number
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def _run(argv: list[str] | None) -> int:
    from ..errors import PatchlightError
    from ..scene.gltf import outside_files_allowed
    from .parser import build_parser

    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # usage errors and --help, already printed
        return int(exc.code or 0)
    try:
        with outside_files_allowed(getattr(args, "allow_outside_files", False)), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the user gets patchlight's own lines, not NumPy's
            return int(args.func(args) or 0)
    except PatchlightError as exc:
        print(f"patchlight: error: {exc}", file=sys.stderr)
        return 2


def _handle_stop_signals(received: list) -> dict:
    """SIGINT and SIGTERM raise KeyboardInterrupt once and record their number; a second one
    while the first is being cleaned up is ignored. A signal landing in code that would
    swallow the exception comes again 5 ms later (SIGALRM). Returns the handlers it replaced."""
    pending = []

    def stop(number, frame):
        if received:
            return
        if _swallows(frame):
            pending[:] = [number]
            signal.setitimer(signal.ITIMER_REAL, 0.005)
            return
        received.append(number)
        raise KeyboardInterrupt

    def again(_, frame):
        stop(pending[0], frame)

    handlers = {signal.SIGINT: stop, signal.SIGTERM: stop, signal.SIGALRM: again}
    try:
        return {number: signal.signal(number, handler) for number, handler in handlers.items()}
    except ValueError:  # not the main thread (main() called from a test's thread): no handlers
        return {}


def _swallows(frame) -> bool:
    """Whether an exception raised in `frame` could be dropped: code that C calls back
    (llvmlite's object-cache callbacks while numba loads a kernel, import-lock callbacks)."""
    name = frame.f_code.co_filename if frame is not None else ""
    return "llvmlite" in name or name.startswith("<frozen importlib")


if __name__ == "__main__":
    sys.exit(main())
