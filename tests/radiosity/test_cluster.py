"""The gather on a real Ray cluster: a head and a second node started with `ray start` on
127.0.0.1 (bounded, torn down by their process groups) give the local bake bit for bit,
with both nodes running tasks; an address nobody answers fails in one line, in time."""
import json
import os
import secrets
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from patchlight.imaging.io import read_exr

ray = pytest.importorskip("ray")
RAY = Path(sys.executable).with_name("ray")
START_SECONDS = 60


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(process: subprocess.Popen) -> None:
    """`ray start --block` and everything it started share its process group."""
    for sig, grace in ((signal.SIGTERM, 10), (signal.SIGKILL, 5)):
        try:
            os.killpg(process.pid, sig)
            process.wait(grace)
            return
        except subprocess.TimeoutExpired:
            continue
        except ProcessLookupError:
            return


def _wait_for_nodes(address: str, env: dict, count: int) -> None:
    probe = ("import ray, sys; ray.init(address=sys.argv[1], log_to_driver=False); "
             "sys.exit(0 if sum(n['Alive'] for n in ray.nodes()) >= int(sys.argv[2]) else 1)")
    deadline = time.monotonic() + START_SECONDS
    while time.monotonic() < deadline:
        if subprocess.run([sys.executable, "-c", probe, address, str(count)], env=env,
                          capture_output=True, timeout=START_SECONDS).returncode == 0:
            return
        time.sleep(1)
    pytest.fail(f"the Ray cluster at {address} did not show {count} nodes in {START_SECONDS} s")


@pytest.fixture(scope="module")
def two_node_cluster():
    """(address, environment) of a Ray head plus one worker node on 127.0.0.1, one CPU each,
    small object stores and an authentication token of their own."""
    port = _free_port()
    address = f"127.0.0.1:{port}"
    env = dict(os.environ, RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(16))
    common = ["--block", "--node-ip-address=127.0.0.1", "--num-cpus=1", "--object-store-memory=100000000",
              "--disable-usage-stats"]
    processes = []
    with tempfile.TemporaryDirectory(prefix="plray") as temp:  # short: Ray's socket paths
        try:
            for argv in (["--head", f"--port={port}", "--include-dashboard=false", f"--temp-dir={temp}"],
                         [f"--address={address}"]):
                processes.append(subprocess.Popen([str(RAY), "start", *common, *argv], env=env,
                                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                                  start_new_session=True))
                _wait_for_nodes(address, env, len(processes))
            yield address, env
        finally:
            for process in reversed(processes):
                _stop(process)


def _cli_bake(out: Path, *options, env=None):
    """`patchlight bake cornell` at 48 x 48 in a process of its own: (run, seconds)."""
    start = time.monotonic()
    run = subprocess.run([sys.executable, "-m", "patchlight.cli.main", "bake", "cornell", "--resolution", "48",
                          "-o", str(out), *options], capture_output=True, text=True, timeout=300, env=env)
    return run, time.monotonic() - start


def test_a_bake_through_two_ray_nodes_equals_the_local_bake_bit_for_bit(tmp_path, two_node_cluster):
    address, env = two_node_cluster
    here, _ = _cli_bake(tmp_path / "here")
    there, _ = _cli_bake(tmp_path / "there", "--ray", address, env=env)
    assert here.returncode == 0 and there.returncode == 0, there.stderr
    tasks = json.loads((tmp_path / "there" / "bake.json").read_text())["ray"]["tasks_per_node"]
    assert len(tasks) == 2 and min(tasks.values()) > 0, tasks
    assert json.loads((tmp_path / "here" / "bake.json").read_text())["ray"] is None
    np.testing.assert_array_equal(read_exr(tmp_path / "there" / "lightmap.exr"),
                                  read_exr(tmp_path / "here" / "lightmap.exr"))


def _silent_listener():
    """A port that accepts connections and never says a word (not a Ray head)."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.2)
    held, stop = [], threading.Event()

    def accept():
        while not stop.is_set():
            try:
                held.append(server.accept()[0])
            except OSError:
                pass

    threading.Thread(target=accept, daemon=True).start()
    return server, stop, held


@pytest.mark.parametrize("listening", [False, True], ids=["nothing-listens", "not-a-ray-head"])
def test_an_unreachable_ray_address_fails_in_one_line_within_30_seconds(tmp_path, listening):
    if listening:
        server, stop, held = _silent_listener()
        address = f"127.0.0.1:{server.getsockname()[1]}"
    else:
        address = f"127.0.0.1:{_free_port()}"
    try:
        run, seconds = _cli_bake(tmp_path / "out", "--ray", address)
    finally:
        if listening:
            stop.set()
            server.close()
            for conn in held:
                conn.close()
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and address in lines[0] and "Traceback" not in run.stderr, run.stderr
    assert seconds < 30
    assert not (tmp_path / "out").exists()
