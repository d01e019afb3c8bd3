"""Atomic outputs: a bake (volume, ground map) replaces its folder in one step. An interrupt
at every file-system step of a write leaves the old set or the new set, whole; readers
looping during re-bakes never pair two bakes' files; SIGKILL leaves nothing a later run
does not clean; a second writer into the same folder is refused at once."""
import hashlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from patchlight import outputs
from patchlight.bake import bake
from patchlight.bakedir import write_bake
from patchlight.cli.main import main
from patchlight.config import BakeSettings
from patchlight.scene import SceneBuilder, Sky
from patchlight.solved import load_solved

PATCHLIGHT = str(Path(sys.executable).with_name("patchlight"))
STEPS = ("replace", "rename", "link", "unlink", "rmdir", "mkdir")  # os functions a write calls


def floor_under(sky: float):
    """A 2 x 2 m floor under a uniform sky of radiance `sky`: every texel's I is `sky`."""
    b = SceneBuilder()
    b.quad([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], b.material("floor", (0.5, 0.5, 0.5)), (0, 1, 0))
    return b.scene("floor", sky=Sky.uniform((sky, sky, sky)))


@pytest.fixture(scope="module")
def two_bakes():
    settings = BakeSettings(resolution=16, rays=64)
    return [(bake(floor_under(sky), settings), settings) for sky in (1.0, 2.0)]


def snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def whole_set(folder: Path) -> float:
    """The sky of the complete bake in `folder`: every file of its bake.json present and
    lightmap.exr lit by scene.glb's sky; AssertionError otherwise."""
    summary = json.loads((folder / "bake.json").read_text())
    assert sorted(summary["files"]) == sorted(p.name for p in folder.iterdir())
    solved = load_solved(folder)
    sky = float(solved.scene.sky.colors[0][0])
    assert solved.lightmap.max() == pytest.approx(sky, rel=1e-3)
    return sky


class Interrupt:
    """Raises KeyboardInterrupt at the n-th call of an os step, before or after the call."""

    def __init__(self, monkeypatch, n: int, after: bool):
        self.n, self.after, self.calls = n, after, 0
        for name in STEPS:
            monkeypatch.setattr(os, name, self.wrap(getattr(os, name)))
        monkeypatch.setattr(outputs, "_swap_in", self.wrap(outputs._swap_in))

    def wrap(self, function):
        def step(*args, **kwargs):
            self.calls += 1
            hit = self.calls == self.n
            if hit and not self.after:
                raise KeyboardInterrupt
            try:
                return function(*args, **kwargs)
            finally:
                if hit and self.after:  # the step done (or failed), the signal comes
                    raise KeyboardInterrupt  # noqa: B012
        return step


@pytest.mark.parametrize("after", [False, True])
def test_an_interrupt_at_every_step_of_a_rewrite_leaves_one_whole_set(tmp_path, monkeypatch, two_bakes, after):
    """Old bake (sky 1) in place, a new one (sky 2) written with an interrupt before (after)
    the 1st, 2nd, ... file-system step, until a write runs through: each time the folder
    holds the old set byte for byte or the new set whole, and a following run leaves no
    staging folder behind."""
    out = tmp_path / "out"
    (old, settings), (new, _) = two_bakes
    write_bake(old, out, settings)
    before = snapshot(out)
    outcomes = []
    for n in range(1, 400):
        with monkeypatch.context() as patch:
            hook = Interrupt(patch, n, after)
            try:
                write_bake(new, out, settings)
                finished = True
            except KeyboardInterrupt:
                finished = False
        outcome = "old" if snapshot(out) == before else f"new {whole_set(out)}"
        assert outcome in ("old", "new 2.0")
        outcomes.append(outcome)
        if finished:
            break
        if outcome != "old":  # back to the old set for the next trial
            write_bake(old, out, settings)
            before = snapshot(out)
    assert finished and hook.calls < n  # every step was interrupted once
    assert "old" in outcomes and outcomes[-1] == "new 2.0"
    with outputs.output_lock(out):  # a later run cleans what interrupted clean-ups left
        pass
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_without_the_exchange_the_old_folder_steps_aside_and_comes_back(tmp_path, monkeypatch, two_bakes):
    """A file system without RENAME_EXCHANGE: the write still replaces the set; killed between
    stepping the old folder aside and moving the new one in, the next run puts the old back."""
    import errno

    (old, settings), (new, _) = two_bakes
    out = tmp_path / "out"
    write_bake(old, out, settings)
    before = snapshot(out)
    monkeypatch.setattr(outputs, "_exchange", lambda first, second: errno.EINVAL)
    write_bake(new, out, settings)
    assert whole_set(out) == 2.0 and sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    write_bake(old, out, settings)
    before = snapshot(out)
    renames = []

    def killed_after_the_first(source, target):
        renames.append(source)
        if len(renames) == 2:
            raise SystemExit("killed")  # no clean-up runs after SIGKILL: keep the staging folder
        os.replace(source, target)

    monkeypatch.setattr(os, "rename", killed_after_the_first)
    monkeypatch.setattr(shutil, "rmtree", lambda *args, **kwargs: None)
    with pytest.raises(SystemExit):
        write_bake(new, out, settings)
    monkeypatch.undo()
    assert not out.exists()
    with outputs.output_lock(out):
        pass
    assert snapshot(out) == before and sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_files_beside_the_set_stay_and_stale_pass_pictures_go(tmp_path, two_bakes):
    (old, settings), (new, _) = two_bakes
    out = tmp_path / "out"
    write_bake(old, out, settings)
    (out / "notes.txt").write_text("mine")
    (out / "pass_07.png").write_bytes(b"an older bake's")
    (out / "volume").mkdir()
    (out / "volume" / "light_volume.json").write_text("{}")
    write_bake(new, out, settings)
    assert (out / "notes.txt").read_text() == "mine" and (out / "volume" / "light_volume.json").exists()
    assert not (out / "pass_07.png").exists() and (out / "notes.txt").stat().st_nlink == 1


READER = """
import json, sys, time
from patchlight.solved import load_solved
from patchlight.errors import PatchlightError
loads = mixed = errors = 0
end = time.monotonic() + float(sys.argv[2])
while time.monotonic() < end:
    try:
        solved = load_solved(sys.argv[1])
    except PatchlightError as exc:
        errors += 1
        print(exc, file=sys.stderr)
        continue
    loads += 1
    mixed += abs(float(solved.lightmap.max()) - float(solved.scene.sky.colors[0][0])) > 1e-3
print(json.dumps({"loads": loads, "mixed": mixed, "errors": errors}))
"""


def test_a_reader_looping_during_rebakes_never_pairs_two_bakes(tmp_path, two_bakes):
    """The reader re-reads a folder swapped while it read (outputs.read_consistently): no
    load pairs one bake's scene.glb (its sky) with the other's lightmap.exr, none fails."""
    out = tmp_path / "out"
    (a, settings), (b, _) = two_bakes
    write_bake(a, out, settings)
    reader = subprocess.Popen([sys.executable, "-c", READER, str(out), "8"], stdout=subprocess.PIPE, text=True)
    writes = 0
    while reader.poll() is None:  # a re-bake every 0.2 s, while a load takes about 0.1-0.3 s
        write_bake(b if writes % 2 else a, out, settings)
        writes += 1
        time.sleep(0.2)
    counts = json.loads(reader.stdout.read())
    assert writes > 10 and counts["loads"] > 10, (writes, counts)
    assert counts["mixed"] == 0 and counts["errors"] == 0, counts


def held(out: Path) -> bool:
    """Whether some process holds the writers' lock of `out` (outputs.output_lock)."""
    name = "\0patchlight-output:" + hashlib.sha256(os.fsencode(out.resolve())).hexdigest()
    with socket.socket(socket.AF_UNIX) as probe:
        try:
            probe.bind(name)
        except OSError:
            return True
    return False


def test_a_second_bake_into_the_same_folder_is_refused_at_once(tmp_path):
    out = tmp_path / "out"
    first = subprocess.Popen([PATCHLIGHT, "bake", "room", "--resolution", "64", "--quiet", "-o", str(out)],
                             stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not held(out):
            assert first.poll() is None and time.monotonic() < deadline, first.stderr.read()
            time.sleep(0.01)
        first.send_signal(signal.SIGSTOP)  # holds the lock while the second starts, however fast its bake
        try:
            second = subprocess.run([PATCHLIGHT, "bake", "cornell", "--resolution", "64", "--quiet", "-o", str(out)],
                                    capture_output=True, text=True, timeout=60)
        finally:
            first.send_signal(signal.SIGCONT)
        assert second.returncode == 2 and "another patchlight process is writing there" in second.stderr
        assert len(second.stderr.strip().splitlines()) == 1
        assert first.wait(timeout=300) == 0
    finally:
        if first.poll() is None:
            first.kill()
            first.wait()
    assert json.loads((out / "bake.json").read_text())["scene"] == "room"


@pytest.mark.parametrize("delay", [0.6, 1.2, 1.8, 2.4])
def test_sigkill_leaves_the_old_set_or_the_new_and_the_next_run_cleans_up(tmp_path, delay):
    out = tmp_path / "out"
    argv = [PATCHLIGHT, "bake", "room", "--resolution", "64", "--quiet", "-o", str(out)]
    assert subprocess.run(argv, timeout=300).returncode == 0
    before = snapshot(out)
    proc = subprocess.Popen([*argv[:3], "--resolution", "48", *argv[5:]])
    time.sleep(delay)
    proc.kill()
    proc.wait()
    summary = json.loads((out / "bake.json").read_text())
    assert snapshot(out) == before or (summary["resolution"] == [48, 48]
                                       and sorted(summary["files"]) == sorted(p.name for p in out.iterdir()))
    assert subprocess.run(argv, timeout=300).returncode == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_stale_staging_folders_of_killed_runs_are_removed(tmp_path):
    out = tmp_path / "out"
    stale = tmp_path / ".out.partial-999999-deadbeef"
    stale.mkdir()
    (stale / "lightmap.exr").write_bytes(b"half")
    other = tmp_path / ".other.partial-1-00000000"
    other.mkdir()
    assert main(["bake", "room", "--resolution", "64", "--quiet", "-o", str(out)]) == 0
    assert not stale.exists() and other.exists()  # another folder's staging is not ours to remove
    shutil.rmtree(other)


def test_a_writer_alongside_runs_beside_the_body_and_its_error_comes_at_the_end():
    """`outputs.alongside`: the writer works on its own thread while the body runs; a writer
    that fails has its error raised once the body is done."""
    body_done, seen = [], []

    def writer(step):
        seen.append(threading.current_thread() is not threading.main_thread())
        step()
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space left"):
        with outputs.alongside(writer):
            body_done.append(True)
    assert body_done == [True] and seen == [True]


def test_a_writer_alongside_a_failing_body_stops_at_its_next_step():
    """Ctrl-C in the body: the writer ends at its next step, before the body's error leaves
    the block (the staging folder can go at once), not after all its steps."""
    steps = []

    def writer(step):
        for k in range(1000):
            step()
            steps.append(k)
            time.sleep(0.01)

    with pytest.raises(KeyboardInterrupt):
        with outputs.alongside(writer):
            while not steps:
                time.sleep(0.001)
            raise KeyboardInterrupt
    done = len(steps)
    time.sleep(0.05)
    assert 0 < done < 50 and len(steps) == done  # stopped, and stopped before the block ended
