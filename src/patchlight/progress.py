"""Progress bars for long stages: stage name, count, time left. Silent when quiet."""
from __future__ import annotations

import os
import threading
import time
from contextlib import contextmanager


_stop_signal: list = []  # (number, on_raise) of the stop signal the command line received


def stop_requested(number: int | None, on_raise=None) -> None:
    """Record a stop signal's number (None: forget it). From then on, in the main thread,
    every stage that starts and every bar that advances (`check_stop`) raises
    KeyboardInterrupt(number), after on_raise(): the signal's own interrupt was raised once,
    and a C extension that clears errors on its way could swallow it; the command then stops
    at its next step instead of running to the end."""
    _stop_signal[:] = [] if number is None else [(number, on_raise)]


def check_stop() -> None:
    """Raise the stop signal's interrupt again, if one came (`stop_requested`); in the main
    thread only (a pool's task that raised it would hand it to nobody)."""
    if _stop_signal and threading.current_thread() is threading.main_thread():
        number, on_raise = _stop_signal[0]
        if on_raise is not None:
            on_raise()
        raise KeyboardInterrupt(number)


def _cpu_seconds() -> float:
    """CPU seconds of this process's threads and of its finished children (xatlas runs in one)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


class Progress:
    """One bar per stage on stderr (rich), the seconds each stage took and the CPU seconds
    this process (every thread, and the children it waited for) spent in it."""

    def __init__(self, quiet: bool = False):
        self.quiet = quiet
        self.seconds: dict[str, float] = {}
        self.cpu_seconds: dict[str, float] = {}
        self._bar = None

    def __enter__(self):
        if not self.quiet:
            from rich.progress import (BarColumn, MofNCompleteColumn, Progress as Bar, TextColumn,
                                       TimeElapsedColumn, TimeRemainingColumn)
            from rich.console import Console

            self._bar = Bar(TextColumn("{task.description:<12}"), BarColumn(bar_width=16), MofNCompleteColumn(),
                            TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn(compact=True),
                            TextColumn("{task.fields[note]}"), console=Console(stderr=True),
                            transient=False)
            self._bar.__enter__()
        return self

    def __exit__(self, *exc):
        if self._bar is not None:
            self._bar.__exit__(*exc)
        return False

    @contextmanager
    def stage(self, name: str, total: float | None = None):
        """Time a stage; yields advance(n=1, note="") to move its bar. A stage that fails
        takes its bar away: the error line that follows says what happened, alone."""
        check_stop()
        task = None
        if self._bar is not None:
            task = self._bar.add_task(name, total=total, note="")
        start, cpu = time.perf_counter(), _cpu_seconds()

        def advance(n: float = 1, note: str | None = None):
            check_stop()
            if task is not None:
                fields = {} if note is None else {"note": note}
                self._bar.update(task, advance=n, **fields)

        try:
            yield advance
            if task is not None:  # a finished stage shows full, however many it skipped
                total = self._bar.tasks[task].total or 1
                self._bar.update(task, completed=total, total=total)
        except BaseException:
            if task is not None:
                self._bar.remove_task(task)
            raise
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start
            self.cpu_seconds[name] = self.cpu_seconds.get(name, 0.0) + _cpu_seconds() - cpu

    def utilisation(self) -> dict[str, float]:
        """Per stage, the share of all cores this process kept busy (1 = every core, all
        the time): CPU seconds / (seconds x cores)."""
        cores = os.cpu_count() or 1
        return {name: self.cpu_seconds[name] / max(seconds * cores, 1e-9) for name, seconds in self.seconds.items()}
