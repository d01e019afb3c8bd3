"""Output folders (a bake, a light volume, a ground map) replaced as a whole, in one atomic step.

The files are written into a staging folder beside the output, `.NAME.partial-PID-HEX`;
files of the old folder that the new set does not replace (and that do not match its
`stale` globs) are hard-linked into it; then one `renameat2(RENAME_EXCHANGE)` swaps the two
folders, and the old one, now under the staging name, is removed. A reader opening
`out/room/...` thus finds the whole old set or the whole new set, at the same top-level
paths, never a mixture, and an interrupt (or SIGKILL) at any instant leaves the old set
whole: before the swap nothing of `out` has changed, after it the new set is complete.
A first output is simply renamed into place. On a file system without the exchange the old
folder steps aside for a moment (readers then find no folder, never a mixture), and a run
killed in that moment has it put back by the next.

One writer at a time: `output_lock` (taken by the commands before any work, and by
`staged_output`) lets a second writer into the same folder fail at once with one line; the
kernel drops it when its process dies, so no lock outlives a killed run. Holding it, a run
removes the staging folders that killed runs left behind.

Readers that read several files of a folder call `read_consistently`, which re-reads when
the folder was swapped while they read. A writer may write its largest file on a thread of
its own while it writes the others (`alongside`).
"""
from __future__ import annotations

import ctypes
import errno
import hashlib
import os
import secrets
import shutil
import socket
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator, TypeVar

from .errors import PatchlightError
from .progress import check_stop

RENAME_EXCHANGE = 2      # linux/fs.h
AT_FDCWD = -100
READ_ATTEMPTS = 5        # re-reads of a folder swapped while it was read

_held: dict[str, int] = {}   # lock name -> depth, for the locks this process holds


@contextmanager
def output_lock(out_dir) -> Iterator[None]:
    """Hold the writers' lock of output folder `out_dir`, re-entrant within this process;
    PatchlightError when another process holds it. The lock is a Linux abstract socket
    named after the folder's resolved path: no file, and the kernel drops it with its process."""
    out = Path(out_dir).resolve()
    name = "\0patchlight-output:" + hashlib.sha256(os.fsencode(out)).hexdigest()
    if name in _held:
        _held[name] += 1
        try:
            yield
        finally:
            _held[name] -= 1
        return
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM | socket.SOCK_CLOEXEC) as sock:
        try:
            sock.bind(name)
        except OSError as exc:
            if exc.errno != errno.EADDRINUSE:
                raise
            raise PatchlightError(f"{out_dir}: another patchlight process is writing there; "
                                  f"wait for it to end or choose another output") from None
        _remove_stale_staging(out)
        _held[name] = 1
        try:
            yield
        finally:
            del _held[name]


def _remove_stale_staging(out: Path) -> None:
    """Staging folders of runs into `out` that were killed (the lock is ours, so no live
    process is using them); an old folder stepped aside (`_swap_in`) goes back when `out` is
    missing."""
    if not out.parent.is_dir():
        return
    for aside in out.parent.glob(f".{out.name}.previous-*"):
        if not out.exists():
            os.rename(aside, out)
        else:
            shutil.rmtree(aside, ignore_errors=True)
    for stale in out.parent.glob(f".{out.name}.partial-*"):
        shutil.rmtree(stale, ignore_errors=True)


@contextmanager
def staged_output(out_dir, stale: tuple[str, ...] = ()) -> Iterator[Path]:
    """Yield an empty staging folder; when the body returns, it replaces `out_dir` in one
    atomic step (module docstring), keeping the old folder's other files except those
    matching the `stale` globs. If the body raises (Ctrl-C included), or a stop signal came
    (`progress.check_stop`), the staging folder goes and `out_dir` is untouched."""
    from .imaging.io import check_output_dir

    out = check_output_dir(out_dir).absolute()
    with output_lock(out):
        staging = out.parent / f".{out.name}.partial-{os.getpid()}-{secrets.token_hex(4)}"
        made = [folder for folder in (out.parent, *out.parent.parents) if not folder.exists()]
        done = False
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
            staging.mkdir()
            yield staging
            check_stop()  # a stop signal whose interrupt was swallowed while the set was written
            if out.is_dir():
                _carry_over(out, staging, stale)
            _swap_in(staging, out)
            done = True
        except OSError as exc:
            raise PatchlightError(f"{out_dir}: cannot write ({exc.strerror or exc})") from exc
        finally:
            shutil.rmtree(staging, ignore_errors=True)  # the new set before the swap, the old after
            for folder in made if not done else ():  # parents made for an output that never came
                _remove_if_empty(folder)


def _remove_if_empty(folder: Path) -> None:
    try:
        folder.rmdir()
    except OSError:
        pass


def _carry_over(out: Path, staging: Path, stale: tuple[str, ...]) -> None:
    """Hard-link into `staging` what `out` holds beside the set: entries the staging folder
    does not replace and that match no `stale` glob (folders as trees of links)."""
    for entry in out.iterdir():
        target = staging / entry.name
        if target.exists() or target.is_symlink() or any(entry.match(pattern) for pattern in stale):
            continue
        if entry.is_symlink() or not entry.is_dir():
            _link_or_copy(entry, target)
        else:
            shutil.copytree(entry, target, symlinks=True, copy_function=_link_or_copy)


def _link_or_copy(source, target) -> None:
    """A hard link (a copy where the file system has none)."""
    try:
        os.link(source, target, follow_symlinks=False)
    except OSError:
        shutil.copy2(source, target, follow_symlinks=False)


def _swap_in(staging: Path, out: Path) -> None:
    """Make `staging` visible as `out` in one step; afterwards `staging` names the old folder
    (or nothing)."""
    if not out.exists():
        os.rename(staging, out)
        return
    code = _exchange(staging, out)
    if code == 0:
        return
    if code not in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        raise OSError(code, f"cannot swap in the new output ({os.strerror(code)})")
    # no exchange on this file system: the old folder steps aside for a moment, under a name
    # the next run puts back should this one be killed before the new folder is in place
    aside = out.parent / f".{out.name}.previous-{os.getpid()}"
    os.rename(out, aside)
    os.rename(staging, out)
    os.rename(aside, staging)


def _exchange(first: Path, second: Path) -> int:
    """Swap two paths atomically (renameat2 RENAME_EXCHANGE): 0, or the errno."""
    renameat2 = getattr(ctypes.CDLL(None, use_errno=True), "renameat2", None)
    if renameat2 is None:
        return errno.ENOSYS
    if renameat2(AT_FDCWD, os.fsencode(first), AT_FDCWD, os.fsencode(second), RENAME_EXCHANGE) == 0:
        return 0
    return ctypes.get_errno()


def folder_version(folder) -> tuple[int, int]:
    """What changes whenever `folder` is swapped for another: (inode, ctime ns)."""
    info = os.stat(folder)
    return info.st_ino, info.st_ctime_ns


def read_consistently(folder, read: Callable[[], _T]) -> _T:
    """read() (which reads several files of `folder`), again when the folder was swapped for
    a newer one meanwhile, so the result never pairs files of two sets."""
    for attempt in range(READ_ATTEMPTS):
        before = folder_version(folder)
        try:
            result = read()
        except PatchlightError:
            if attempt + 1 < READ_ATTEMPTS and _swapped(folder, before):
                continue
            raise
        if not _swapped(folder, before):
            return result
    raise PatchlightError(f"{folder}: rewritten {READ_ATTEMPTS} times while it was read; try again")


def _swapped(folder, before: tuple[int, int]) -> bool:
    try:
        return folder_version(folder) != before
    except OSError as exc:
        return exc.errno == errno.ENOENT


class _Cancelled(Exception):
    """Ends a writer run `alongside` a body that failed."""


@contextmanager
def alongside(write: Callable[..., None], *args) -> Iterator[None]:
    """Run write(*args, step) on a thread of its own while the body runs (zlib, NumPy and the
    kernels let go of the GIL, so both cores write); its error is raised when the body ends.
    write calls step() between its steps: once the body has failed (Ctrl-C included), step
    raises and the write ends there, so the caller's staging folder can go at once."""
    failed = threading.Event()

    def step() -> None:
        if failed.is_set():
            raise _Cancelled

    with ThreadPoolExecutor(1) as pool:
        future = pool.submit(write, *args, step)
        try:
            yield
            future.result()
        except BaseException:
            failed.set()
            raise
