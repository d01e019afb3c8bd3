"""The fuzzer's runner process: imports the command line once, then forks a child per case.

Reads one JSON request a line on stdin ({"argv": [...], "cwd": DIR, "out": FILE, "err": FILE}),
forks, runs `patchlight.cli.main.main(argv)` in the child exactly as the `patchlight` command
does (an uncaught exception prints its traceback and exits 1), and answers one JSON line:
{"status": exit status or null, "signal": N or null, "seconds": wall time, "peak_mib": the
child's peak resident memory, "killed": null, "time" or "memory"}. A child over the time or
memory limit is killed (SIGKILL) at once, so a memory bomb never takes the machine.

The parent never runs a kernel or starts a thread, so every child starts single-threaded.
"""
from __future__ import annotations

import importlib
import json
import os
import signal
import sys
import time
import traceback

PRELOAD = ("patchlight.bake", "patchlight.solved", "patchlight.render.renderer", "patchlight.volumes.probes",
           "patchlight.ground.groundmap", "patchlight.volumes.vertex", "patchlight.viewer.app")


def _run_child(request: dict) -> None:
    """In the forked child: redirect stdout/stderr to files and run the command."""
    code = 1
    try:
        os.chdir(request["cwd"])
        devnull = os.open(os.devnull, os.O_RDONLY)
        os.dup2(devnull, 0)
        os.close(devnull)
        for fd, name in ((1, request["out"]), (2, request["err"])):
            file = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(file, fd)
            os.close(file)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        from patchlight.cli.main import main

        try:
            code = main(request["argv"])
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        except BaseException:
            traceback.print_exc()
            code = 1
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code if isinstance(code, int) else 1)


def _peak_mib(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def _watch(pid: int, seconds: float, mib: float) -> dict:
    """Wait for the child, killing it once over `seconds` of wall time or `mib` resident."""
    start, peak, killed = time.monotonic(), 0.0, None
    while True:
        done, status, usage = os.wait4(pid, os.WNOHANG)
        if done:
            peak = max(peak, usage.ru_maxrss / 1024)
            break
        peak = max(peak, _peak_mib(pid))
        if killed is None and (peak > mib or time.monotonic() - start > seconds):
            killed = "memory" if peak > mib else "time"
            os.kill(pid, signal.SIGKILL)
        time.sleep(0.02)
    return {"status": os.WEXITSTATUS(status) if os.WIFEXITED(status) else None,
            "signal": os.WTERMSIG(status) if os.WIFSIGNALED(status) else None,
            "seconds": round(time.monotonic() - start, 3), "peak_mib": round(peak, 1), "killed": killed}


def serve(seconds: float, mib: float) -> None:
    from patchlight.cli.parser import build_parser

    build_parser()  # every subcommand's module, then what their work imports
    for module in PRELOAD:
        importlib.import_module(module)
    for line in sys.stdin:
        request = json.loads(line)
        pid = os.fork()
        if pid == 0:
            _run_child(request)
        print(json.dumps(_watch(pid, seconds, mib)), flush=True)


if __name__ == "__main__":
    serve(float(sys.argv[1]), float(sys.argv[2]))
