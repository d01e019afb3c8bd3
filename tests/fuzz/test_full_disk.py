"""A full disk: the command says so in one line (exit 2) and the earlier output stays whole.

Each case runs in a private mount namespace (`unshare`) on a 16 MiB tmpfs: the command
writes its output once (bake: the fuzzer's seed scene; volume and groundmap: its bake), the
rest of the disk is filled, then it writes again into the same place. Skipped where the
machine does not allow such mounts."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fuzzing import BAKE, GROUND, VOLUME

UNSHARE = ["unshare", "--user", "--map-root-user", "--mount"]


def _mount_allowed() -> str | None:
    if shutil.which("unshare") is None:
        return "no unshare command"
    probe = subprocess.run([*UNSHARE, "sh", "-c", "mount -t tmpfs -o size=1m tmpfs /mnt || exit 1"],
                           capture_output=True, text=True)
    return None if probe.returncode == 0 else f"cannot mount a tmpfs here ({probe.stderr.strip()[:80]})"


pytestmark = pytest.mark.skipif(_mount_allowed() is not None, reason=str(_mount_allowed()))

PATCHLIGHT = f"{sys.executable} -m patchlight.cli.main"
SCRIPT = """
set -u
mount -t tmpfs -o size=16m tmpfs "$DISK" || exit 90
{patchlight} $COMMAND "$DISK/out" $OPTIONS 2> "$LOG/first.err" || exit 91
(cd "$DISK/out" && sha256sum * > "$LOG/before.sums")
cat /dev/zero > "$DISK/filler" 2> /dev/null
{patchlight} $COMMAND "$DISK/out" $OPTIONS 2> "$LOG/second.err"
echo $? > "$LOG/status"
(cd "$DISK/out" && sha256sum * > "$LOG/after.sums")
ls -A "$DISK" > "$LOG/listing"
""".format(patchlight=PATCHLIGHT)



@pytest.mark.parametrize("command", ["bake", "volume", "groundmap"])
def test_a_full_disk_is_one_line_and_keeps_the_earlier_output(command, seeds, tmp_path):
    disk, log = tmp_path / "disk", tmp_path / "log"
    disk.mkdir()
    log.mkdir()
    source, options = {"bake": (seeds.glb, BAKE), "volume": (seeds.bake, VOLUME), "groundmap": (seeds.bake, GROUND)}[command]
    words = f"{command} {source} -o"
    options = " ".join(options)
    env = {"PATH": "/usr/bin:/bin", "DISK": str(disk), "LOG": str(log), "COMMAND": words, "OPTIONS": options}
    run = subprocess.run([*UNSHARE, "sh", "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, (run.returncode, run.stderr, _read(log / "first.err"))
    err = _read(log / "second.err").strip().splitlines()
    assert _read(log / "status").strip() == "2", err
    assert len(err) == 1 and "No space left on device" in err[0], err
    assert _read(log / "after.sums") == _read(log / "before.sums")
    assert _read(log / "listing").split() == ["filler", "out"]


def _read(path: Path) -> str:
    return path.read_text() if path.exists() else ""

