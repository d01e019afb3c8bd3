"""Ctrl-C and SIGTERM from the first instant: exit 128 + the signal, one line on stderr, no
traceback, whether the signal lands in the imports, the argument parsing or a numba kernel."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from patchlight.cli.main import main

PATCHLIGHT = str(Path(sys.executable).with_name("patchlight"))
LONG_BAKE = ["bake", "room", "--resolution", "256", "-o"]  # seconds of work, so a signal 0.4 s in lands mid-bake


def caught_signals(pid: int) -> int:
    """The process's mask of caught signals (/proc/PID/status SigCgt)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("SigCgt:"):
            return int(line.split()[1], 16)
    return 0


def signalled(argv, number, delay):
    """Run `patchlight argv`, send `number` `delay` s after its handlers are installed (its
    SIGTERM is caught: before that, the interpreter itself is starting), return (status, stderr)."""
    proc = subprocess.Popen([PATCHLIGHT, *argv], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not caught_signals(proc.pid) & (1 << (signal.SIGTERM - 1)):
            assert proc.poll() is None and time.monotonic() < deadline, "the handlers never came"
            time.sleep(0.002)
        time.sleep(delay)
        proc.send_signal(number)
        return proc.wait(timeout=120), proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.fixture(scope="module")
def room_bake(tmp_path_factory):
    out = tmp_path_factory.mktemp("bake") / "room"
    assert main(["bake", "room", "--resolution", "64", "--quiet", "-o", str(out)]) == 0
    return out


def one_line_after_the_bars(err: str, line: str) -> bool:
    """stderr is `line`, after the progress bars of the stages that had started, if any (with
    fast imports a signal 0.2 s in can land in the first stage; a stderr that is not a
    terminal gets the bars when they stop): no traceback, no other line."""
    lines = err.strip().splitlines()
    return lines[-1:] == [line] and all(" left " in bar for bar in lines[:-1])


@pytest.mark.parametrize("delay", [0.0, 0.02, 0.05, 0.1, 0.2, 0.4])
def test_ctrl_c_while_starting_is_one_line_and_130(tmp_path, delay):
    status, err = signalled(LONG_BAKE + [str(tmp_path / "out")], signal.SIGINT, delay)
    assert status == 130 and one_line_after_the_bars(err, "patchlight: interrupted; nothing partial was written"), err
    assert not (tmp_path / "out").exists()


def test_sigterm_is_handled_like_ctrl_c(tmp_path):
    status, err = signalled(LONG_BAKE + [str(tmp_path / "out")], signal.SIGTERM, 0.3)
    assert status == 143 and one_line_after_the_bars(err, "patchlight: terminated; nothing partial was written"), err


@pytest.mark.parametrize("delay", [0.3, 0.5, 0.7, 0.9, 1.1])
def test_ctrl_c_in_the_volume_kernels_is_one_line_and_130(tmp_path, room_bake, delay):
    """The numba kernels of the probes: an interrupt raised as one returns surfaces as a
    SystemError from the dispatcher; it still ends as a plain interrupt."""
    out = tmp_path / "volume"
    status, err = signalled(["volume", str(room_bake), "--rays", "256", "--quiet", "-o", str(out)], signal.SIGINT,
                            delay)
    if status == 0:  # finished before the signal came (an idle machine)
        assert (out / "light_volume.json").exists()
        return
    assert status == 130 and "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def run_as_command(monkeypatch, work) -> int:
    """main() with work(args) as its only command: the command line's signal handling around it."""
    import argparse

    import patchlight.cli.parser as parser_module

    def build_parser():
        parser = argparse.ArgumentParser()
        parser.set_defaults(func=work)
        return parser

    monkeypatch.setattr(parser_module, "build_parser", build_parser)
    return main([])


def test_an_interrupt_dropped_in_a_del_comes_again(monkeypatch, capsys):
    """A Ctrl-C landing in a __del__ (Python can only drop it there: "Exception ignored in")
    is delivered again a moment later, so the command still stops, with one line."""
    class Dropper:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(1000):  # the handler runs here, inside __del__
                pass

    def work(args):
        Dropper()
        time.sleep(5)  # interrupted by the second delivery
        return 0

    started = time.monotonic()
    assert run_as_command(monkeypatch, work) == 130
    assert time.monotonic() - started < 4
    assert capsys.readouterr().err.strip() == "patchlight: interrupted; nothing partial was written"


def test_an_interrupt_swallowed_on_its_way_stops_the_command_at_its_next_step(monkeypatch, capsys):
    """Ctrl-C raises once; code that swallows the interrupt (as a C extension that clears
    errors can) does not make the command run on: the next stage raises it again."""
    from patchlight.progress import Progress

    stages = []

    def work(args):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        except BaseException:
            pass  # swallowed
        with Progress(quiet=True) as progress:
            for name in ("first", "second"):
                with progress.stage(name):
                    stages.append(name)
        return 0

    assert run_as_command(monkeypatch, work) == 130
    assert stages == []
    assert capsys.readouterr().err.strip() == "patchlight: interrupted; nothing partial was written"
    with Progress(quiet=True) as progress, progress.stage("after"):  # the command over, stages run again
        pass


class DroppedIn:
    """Sends `number` to the process in its __del__, where Python can only drop the interrupt."""

    def __init__(self, number):
        self.number = number

    def __del__(self):
        os.kill(os.getpid(), self.number)
        for _ in range(1000):  # the handler runs here
            pass


def test_a_dropped_sigterm_raised_again_by_a_stage_still_says_terminated(monkeypatch, capsys):
    """The next stage raises a dropped interrupt before the 5 ms re-delivery: the status
    and the line still name the signal that came, and the cleanup after it is not cut short
    by a second interrupt."""
    from patchlight.progress import Progress

    cleaned = []

    def work(args):
        DroppedIn(signal.SIGTERM)
        try:
            with Progress(quiet=True) as progress, progress.stage("next"):
                pass
        finally:
            started = time.monotonic()
            while time.monotonic() - started < 0.02:  # a 20 ms cleanup, past the re-delivery
                pass
            cleaned.append(True)
        return 0

    assert run_as_command(monkeypatch, work) == 143
    assert capsys.readouterr().err.strip() == "patchlight: terminated; nothing partial was written"
    assert cleaned == [True]


def test_an_interrupt_swallowed_while_the_output_is_written_leaves_it_untouched(monkeypatch, capsys, tmp_path):
    """Swallowed after the last stage (a C writer can): the new set is not swapped in, so the
    line "nothing partial was written" stays true."""
    from patchlight.outputs import staged_output

    out = tmp_path / "bake"

    def work(args):
        with staged_output(out) as staging:
            try:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(5)
            except BaseException:
                pass  # swallowed
            (staging / "lightmap.exr").write_bytes(b"written")
        return 0

    assert run_as_command(monkeypatch, work) == 130
    assert capsys.readouterr().err.strip() == "patchlight: interrupted; nothing partial was written"
    assert not out.exists()


def test_a_del_failing_because_of_the_interrupt_adds_no_lines(monkeypatch, capsys):
    """An object the interrupt left half built (llvmlite's, when Ctrl-C lands while numba
    compiles) fails in its __del__ as the stop unwinds: still one line, no "Exception ignored"
    traceback after it."""
    class HalfBuilt:
        def __del__(self):
            del self.handle  # never set: the interrupt came first

    def work(args):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        finally:
            HalfBuilt()
        return 0

    monkeypatch.setattr(sys, "unraisablehook", sys.__unraisablehook__)  # Python's, which prints; not pytest's
    assert run_as_command(monkeypatch, work) == 130
    assert capsys.readouterr().err.strip() == "patchlight: interrupted; nothing partial was written"


def test_the_process_ends_after_the_work_and_a_signal_while_winding_down_ends_it_at_once():
    """main() of the command line runs the exit handlers and ends the process (no slow
    teardown); a Ctrl-C during those handlers ends it at once with 130, no traceback."""
    script = ("import atexit, os, signal, sys, time\n"
              "from patchlight.cli.main import main\n"
              "mode = sys.argv[1]\n"
              "def slow():\n"
              "    if mode == 'signal':\n"
              "        os.kill(os.getpid(), signal.SIGINT)\n"
              "    time.sleep(2)\n"
              "    print('handler finished', flush=True)\n"
              "atexit.register(slow)\n"
              "sys.argv = ['patchlight', '--help']\n"
              "main()\n"
              "print('main returned')\n")
    quiet = subprocess.run([sys.executable, "-c", script, "quiet"], capture_output=True, text=True, timeout=60)
    assert quiet.returncode == 0 and "handler finished" in quiet.stdout and "main returned" not in quiet.stdout
    stopped = subprocess.run([sys.executable, "-c", script, "signal"], capture_output=True, text=True, timeout=60)
    assert stopped.returncode == 130 and "handler finished" not in stopped.stdout
    assert "Traceback" not in stopped.stderr


def test_an_interrupt_waits_out_numba_but_not_an_import_or_plain_code(tmp_path, monkeypatch):
    """Inside numba the interrupt comes again later; in an import and in the package's own
    code it is raised at once (deferred past an import, the first stage's bar came first)."""
    from patchlight.cli.main import _unsafe_to_raise

    (tmp_path / "being_imported.py").write_text("import sys\nFRAME = sys._getframe()\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import being_imported  # its body's frame, captured while the import ran

    in_numba = {"__name__": "numba.core"}
    exec("import sys\nFRAME = sys._getframe()", in_numba)
    assert _unsafe_to_raise(in_numba["FRAME"])
    assert not _unsafe_to_raise(being_imported.FRAME) and not _unsafe_to_raise(sys._getframe())
