"""`patchlight` command line (the parser is `cli/parser.py`, one module per subcommand).

User errors (PatchlightError) print one line and exit 2. SIGINT (Ctrl-C) and SIGTERM are
handled from the first instant (this module imports nothing heavy; `patchlight` loads its
names on first use): either one raises KeyboardInterrupt wherever the program is, the
subcommand cleans up, and the exit status is 128 + the signal (130, 143), after one line.
"""
from __future__ import annotations

import os
import signal
import sys
import warnings

from ..progress import stop_requested


def main(argv: list[str] | None = None) -> int:
    """Run `patchlight` with argv. None: the process's own command line; then main ends the
    process (`_end_process`)."""
    status = _main(argv)
    if argv is None:
        _end_process(status)
    return status


def _main(argv: list[str] | None) -> int:
    with _StopSignals(winding_down=argv is None) as signals:
        try:
            status = _run(argv)
        except BaseException as exc:
            # a signal's KeyboardInterrupt raised inside a numba dispatcher surfaces as a
            # SystemError ("returned a result with an exception set"), so any exception counts
            number = signals.received or (signal.SIGINT if isinstance(exc, KeyboardInterrupt) else None)
            if number is None:
                raise
            return _stopped(number)
        return status if signals.received is None else _stopped(signals.received)


def _end_process(status: int) -> None:
    """Run the exit handlers (Ray's shutdown, thread pools' joins), flush, and end without the
    interpreter's teardown: it walks every object the JIT made (seconds on a loaded machine)
    after Python has put SIGINT back to its default, so a Ctrl-C then killed the process."""
    import atexit

    atexit._run_exitfuncs()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


def _stopped(number: int) -> int:
    word = "interrupted" if number == signal.SIGINT else "terminated"
    print(f"patchlight: {word}; nothing partial was written", file=sys.stderr)
    return 128 + number


def _run(argv: list[str] | None) -> int:
    from ..errors import PatchlightError, PatchlightWarning
    from ..scene.gltf import outside_files_allowed
    from .parser import build_parser

    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # usage errors and --help, already printed
        return int(exc.code or 0)
    try:
        with outside_files_allowed(getattr(args, "allow_outside_files", False)), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the user gets patchlight's own lines, not NumPy's
            warnings.simplefilter("always", PatchlightWarning)
            warnings.showwarning = _warning_line
            return int(args.func(args) or 0)
    except PatchlightError as exc:  # the library names fields; the user set them by their flags
        print(f"patchlight: error: {parser.commands[args.command].user_line(exc)}", file=sys.stderr)
        return 2


def _warning_line(message, *_) -> None:
    """A PatchlightWarning as one line on stderr."""
    print(f"patchlight: warning: {message}", file=sys.stderr)


class _StopSignals:
    """SIGINT and SIGTERM raise KeyboardInterrupt(number) once, wherever the program is, and
    record their number (`received`, and `progress.stop_requested`: should the interrupt be
    swallowed, the next stage or bar raises it again); another one while the first is being
    cleaned up is ignored.
    An interrupt Python drops where it cannot raise (a __del__, a ctypes callback such as
    llvmlite's while numba loads a kernel, an import-lock callback) comes again 5 ms later
    (SIGALRM; unless a stage or bar raised it first), as does one that lands where raising is
    unsafe (`_unsafe_to_raise`): in
    numba's or llvmlite's own Python code, it left their objects half built, and the process
    crashed (SIGSEGV) when it freed them. Only in the main thread (main() called from a test's thread: no handlers).
    Afterwards the handlers before it come back, or, winding down (the process ends after
    main), `_exit_now`: the work is done; the exit handlers may take a while."""

    def __init__(self, winding_down: bool = False):
        self.winding_down = winding_down
        self.received: int | None = None
        self.stopping = False  # a signal came: the command is stopping
        self.dropped_once = False  # the interrupt was dropped; the timer raises it again
        self.pending = signal.SIGINT
        self.previous: dict = {}
        self.previous_hook = sys.unraisablehook

    def __enter__(self) -> "_StopSignals":
        stop_requested(None)
        try:
            for number, handler in ((signal.SIGINT, self.stop), (signal.SIGTERM, self.stop),
                                    (signal.SIGALRM, self.again)):
                self.previous[number] = signal.signal(number, handler)
        except ValueError:
            return self
        sys.unraisablehook = self.dropped
        return self

    def __exit__(self, *exc) -> None:
        try:
            if self.previous:
                signal.setitimer(signal.ITIMER_REAL, 0)
                stopped_for_good = self.stopping and self.winding_down
                sys.unraisablehook = _ignore if stopped_for_good else self.previous_hook
            for number, handler in self.previous.items():
                stop_now = self.winding_down and number != signal.SIGALRM
                signal.signal(number, _exit_now if stop_now else handler)
        finally:
            if self.previous:
                stop_requested(None)  # last, and whatever a signal raised meanwhile

    def stop(self, number, frame) -> None:
        self.stopping = True
        if self.received is None:
            if _unsafe_to_raise(frame):
                self.pending = number
                signal.setitimer(signal.ITIMER_REAL, 0.005)
                return
            self.received = number
            stop_requested(number, self.raised_again)
            raise KeyboardInterrupt(number)  # the number: for a command that ends the process itself (view)

    def again(self, number, frame) -> None:
        if self.received is None:  # deferred out of numba's code
            self.stop(self.pending, frame)
        elif self.dropped_once:  # dropped: raise it once more, where that is safe
            if _unsafe_to_raise(frame):
                signal.setitimer(signal.ITIMER_REAL, 0.005)
                return
            self.dropped_once = False
            raise KeyboardInterrupt(self.received)

    def raised_again(self) -> None:
        """A stage or bar raises the interrupt again (`progress.check_stop`): the timer need not."""
        signal.setitimer(signal.ITIMER_REAL, 0)
        self.dropped_once = False

    def dropped(self, unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt) and self.received is not None:
            self.dropped_once = True
            signal.setitimer(signal.ITIMER_REAL, 0.005)
        elif not self.stopping:
            self.previous_hook(unraisable)
        # else an object the interrupt left half built failed in its __del__ (llvmlite's, when
        # the signal lands while numba compiles): part of the stop, not news to the user


def _unsafe_to_raise(frame) -> bool:
    """At any depth of the stack, the Python code running is numba's or llvmlite's
    (compiling, loading or launching a kernel): raised there, an interrupt leaves their
    objects half built. (Imports are not deferred: the command's first stage would start
    before the interrupt came, and its progress bar would be left on the screen.)"""
    while frame is not None:
        if frame.f_globals.get("__name__", "").partition(".")[0] in ("numba", "llvmlite"):
            return True
        frame = frame.f_back
    return False


def _ignore(unraisable) -> None:
    """sys.unraisablehook once a stopped command winds down (_StopSignals.dropped)."""


def _exit_now(number, frame) -> None:
    """A signal while the process winds down: the output is complete; end at once."""
    try:
        sys.stdout.flush()
    finally:
        os._exit(128 + number)


if __name__ == "__main__":
    sys.exit(main())
