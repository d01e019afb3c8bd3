"""Progress bars for long stages: stage name, count, time left. Silent when quiet."""
from __future__ import annotations

import time
from contextlib import contextmanager


class Progress:
    """One bar per stage on stderr (rich), and the seconds each stage took."""

    def __init__(self, quiet: bool = False):
        self.quiet = quiet
        self.seconds: dict[str, float] = {}
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
        """Time a stage; yields advance(n=1, note="") to move its bar."""
        task = None
        if self._bar is not None:
            task = self._bar.add_task(name, total=total, note="")
        start = time.perf_counter()

        def advance(n: float = 1, note: str | None = None):
            if task is not None:
                fields = {} if note is None else {"note": note}
                self._bar.update(task, advance=n, **fields)

        try:
            yield advance
            if task is not None:  # a finished stage shows full, however many it skipped
                total = self._bar.tasks[task].total or 1
                self._bar.update(task, completed=total, total=total)
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start
