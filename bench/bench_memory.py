"""The memory estimate against the measured peak: bakes a scene through the CLI, one child
process per resolution, and prints bake.json's estimated peak beside the child's peak
resident memory (its whole life, writing the files included), their ratio, the seconds and
the CPU seconds over the cores (what an idle machine would take) beside bake.json's
estimate of them, and F.
Run by hand, one resolution at a time on a shared machine:
    .venv/bin/python bench/bench_memory.py [--scene room] [--resolution 1024 2048 ...] [--directional sh]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def measure(scene: str, resolution: int, out: Path, directional: str | None) -> None:
    start = time.perf_counter()
    more = ["--directional", directional] if directional else []
    child = subprocess.Popen([sys.executable, "-m", "patchlight.cli.main", "bake", scene, "--resolution",
                              str(resolution), "-o", str(out), "--quiet", *more])
    _, status, usage = os.wait4(child.pid, 0)
    seconds = time.perf_counter() - start
    if os.waitstatus_to_exitcode(status) != 0:
        print(f"{scene} {resolution}: the bake failed (exit status {os.waitstatus_to_exitcode(status)})")
        return
    summary = json.loads((out / "bake.json").read_text())
    estimate, peak = summary["memory"]["estimated_peak_bytes"], usage.ru_maxrss * 1024
    cpu, cores = usage.ru_utime + usage.ru_stime, os.cpu_count() or 1
    f = summary["form_factor_matrix"]
    print(f"{scene} {resolution}x{resolution}{f' --directional {directional}' if directional else ''}: estimate {estimate / 2**30:.2f} GiB, peak {peak / 2**30:.2f} GiB, "
          f"estimate / peak {estimate / peak:.2f}; {seconds:.0f} s, CPU {cpu:.0f} s = {cpu / cores:.0f} s on "
          f"{cores} idle cores (estimate {summary['estimated_seconds']:.0f} s); "
          f"F {f['bytes'] / 2**30:.2f} GiB "
          f"{'kept' if f['kept'] else 'dropped'}, {summary['computed_patches']} of {summary['patches']} gathered")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="room")
    parser.add_argument("--resolution", type=int, nargs="+", default=[1024, 2048])
    parser.add_argument("--directional", choices=("sh", "dominant"), help="bake directional maps too")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="patchlight-memory") as temp:
        for resolution in args.resolution:
            measure(args.scene, resolution, Path(temp) / str(resolution), args.directional)


if __name__ == "__main__":
    main()
