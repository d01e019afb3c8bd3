"""The viewer's server: 127.0.0.1 only, its own files and the scene's, 404 for anything else."""
from __future__ import annotations

import http.client
import json
import os
import signal
import socket
import subprocess
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from browser_support import three_missing
from render_scenes import closed_sphere_under_a_sun, showcase_target

from patchlight.errors import PatchlightError
from patchlight.imaging.io import encode_png
from patchlight.render import Renderer, target_settings
from patchlight.viewer.app import make_server
from patchlight.viewer.server import ViewerServer, safe_file

pytestmark = pytest.mark.skipif(three_missing() is not None, reason=str(three_missing()))


@pytest.fixture(scope="module")
def bake_like(tmp_path_factory):
    """A target with a bake directory holding pictures and a file the viewer must not serve."""
    target = showcase_target(8, 16)
    bake = tmp_path_factory.mktemp("bake")
    picture = encode_png(np.full((4, 4, 3), 200, np.uint8))
    for name in ("lightmap.png", "pass_01.png", "adaptive.png"):
        (bake / name).write_bytes(picture)
    (bake / "secret.txt").write_text("not for the browser")
    target.bake_dir = bake
    return target


@pytest.fixture(scope="module")
def server(bake_like):
    with make_server(bake_like, target_settings(bake_like), exposure=1.0) as srv:
        yield srv


def get(server: ViewerServer, path: str, method: str = "GET", host: str | None = "") -> tuple[int, bytes]:
    """host "": the Host header http.client sends (127.0.0.1:PORT); None: no Host header."""
    conn = http.client.HTTPConnection("127.0.0.1", server.httpd.server_address[1], timeout=10)
    conn.putrequest(method, path, skip_accept_encoding=True, skip_host=host != "")
    if host:
        conn.putheader("Host", host)
    conn.endheaders()
    response = conn.getresponse()
    body = response.read()
    conn.close()
    return response.status, body


def test_listens_on_loopback_only(server):
    assert server.httpd.server_address[0] == "127.0.0.1"
    assert server.url.startswith("http://127.0.0.1:")


@pytest.mark.parametrize("path", ["/", "/static/viewer.js", "/static/bundle.js", "/shaders/common.glsl",
                                  "/shaders/surface_fragment.glsl", "/three/build/three.module.js",
                                  "/three/build/three.core.js", "/three/examples/jsm/controls/OrbitControls.js",
                                  "/scene/manifest.json", "/scene/data.bin", "/static/camera.js",
                                  "/static/inspect.js", "/static/patchview.js", "/static/viewer.js?v=1"])
def test_serves_its_files(server, path):
    status, body = get(server, path)
    assert status == 200 and body


def test_manifest_without_texels_has_no_inspection_and_no_patch_route(server):
    manifest = json.loads(get(server, "/scene/manifest.json")[1])
    assert manifest["texels"] is None and manifest["patch"] is None
    assert manifest["settings"]["exposure"] == 1.0 and len(manifest["lights"]) == 3
    assert manifest["exposure_rule"] == {"percentile": 90.0, "target": 0.8, "luminance": [0.2126, 0.7152, 0.0722]}
    assert get(server, "/scene/patch?x=1&y=1")[0] == 404


def bundled_env(server: ViewerServer) -> tuple[dict, np.ndarray]:
    """(manifest, the environment cube the page draws with)."""
    manifest = json.loads(get(server, "/scene/manifest.json")[1])
    spec = manifest["arrays"][manifest["env"]]
    data = get(server, "/scene/data.bin")[1]
    return manifest, np.frombuffer(data, "<f4", int(np.prod(spec["shape"])), spec["offset"]).reshape(spec["shape"])


@pytest.mark.parametrize("envmap_from", [None, (0.0, 0.5, 2.5)])
def test_the_page_gets_the_cpu_renderers_environment(bake_like, envmap_from):
    settings = target_settings(bake_like, model="hemisphere-radiosity")
    with make_server(bake_like, settings, exposure=1.0, envmap_from=envmap_from) as srv:
        _, env = bundled_env(srv)
    np.testing.assert_array_equal(env, Renderer(bake_like, envmap_from).environment(settings))


@pytest.mark.parametrize("model", ["lambert", "envmap"])
def test_a_closed_object_without_a_sky_is_served_for_every_model(model):
    """`patchlight view sphere.glb`: the environment cube comes from the default camera's eye,
    outside the sphere, whichever model the page starts with."""
    target = closed_sphere_under_a_sun()
    with make_server(target, target_settings(target, model=model)) as srv:
        manifest, env = bundled_env(srv)
    assert manifest["env_note"] is None and env[..., :3].max() > 0
    np.testing.assert_array_equal(env, Renderer(target).environment(target_settings(target)))


def test_without_any_point_for_the_environment_the_page_gets_a_note_naming_the_options():
    """The scene's own camera inside the sphere too: no point for the cube. A model that does
    not read it is served (a black cube and a note); envmap is refused in one line."""
    target = closed_sphere_under_a_sun({"eye": [0.0, 0.0, 0.5], "target": [0.0, 0.0, -1.0], "fov": 45.0})
    with make_server(target, target_settings(target, model="lambert"), exposure=1.0) as srv:
        manifest, env = bundled_env(srv)
    assert env.max() == 0 and "`envmap_from`" in manifest["env_note"] and "`sky`" in manifest["env_note"]
    with pytest.raises(PatchlightError, match="`envmap_from`"):
        make_server(target, target_settings(target, model="envmap"), exposure=1.0)


@pytest.mark.parametrize("path", [
    "/../../etc/passwd", "/static/../../errors.py", "/static/%2e%2e/%2e%2e/errors.py", "/static/%252e%252e/x",
    "/static//etc/passwd", "/static/..%2f..%2ferrors.py", "/static/%2fetc%2fpasswd", "/static/..\\..\\errors.py",
    "/shaders/../render/renderer.py", "/shaders/%2e%2e%2frender%2frenderer.py", "/shaders/__init__.py",
    "/three/package.json", "/three/build/../../../etc/passwd", "/three/src/Three.js",
    "/scene/files/secret.txt", "/scene/files/../secret.txt", "/scene/files/%2e%2e%2fsecret.txt",
    "/scene/files/lightmap.png", "/scene/files/pass_01.png", "/scene/lightmap.png",
    "/static/", "/static/%00", "/static/%ff", "/etc/passwd", "//etc/passwd", "/node_modules/three/package.json",
])
def test_refuses_everything_else(server, path):
    status, body = get(server, path)
    assert status == 404, path
    assert b"root:" not in body and b"not for the browser" not in body


def test_only_requests_addressed_to_the_server_itself_are_answered(server):
    """DNS rebinding: a page of evil.example whose name now resolves to 127.0.0.1 sends
    Host: evil.example; it must not read the scene."""
    port = server.httpd.server_address[1]
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", f"LocalHost:{port}"):
        assert get(server, "/scene/manifest.json", host=host)[0] == 200, host
    for host in ("evil.example", f"evil.example:{port}", f"127.0.0.1:{port + 1}", "127.0.0.1", "localhost",
                 f"127.0.0.1.evil.example:{port}", f"localhost:{port}@evil.example", None):
        for path in ("/scene/manifest.json", "/scene/data.bin", "/", "/scene/files/lightmap.png"):
            status, body = get(server, path, host=host)
            assert status == 403 and b"arrays" not in body, (host, path)


def test_head_works_and_other_methods_do_not(server):
    assert get(server, "/scene/manifest.json", "HEAD") == (200, b"")
    assert get(server, "/scene/manifest.json", "POST")[0] == 501


def test_symlinks_leading_out_are_not_followed(tmp_path):
    root = tmp_path / "root"
    root.mkdir()
    (root / "inside.txt").write_text("ok")
    (tmp_path / "outside.txt").write_text("secret")
    (root / "link.txt").symlink_to(tmp_path / "outside.txt")
    (root / "dir").symlink_to(tmp_path)
    assert safe_file(root, "inside.txt") == (root / "inside.txt").resolve()
    assert safe_file(root, "link.txt") is None
    assert safe_file(root, "dir/outside.txt") is None
    assert safe_file(root, "../outside.txt") is None


@pytest.mark.parametrize("path, expected", [
    ("/static/" + "a" * 256, 404), ("/scene/files/" + "b" * 300 + ".png", 404), ("/static/" + "c/" * 900, 404),
    ("/static/" + "%41" * 300, 404), ("/" + "d" * 5000, 414), ("/static/" + "e" * 3000, 414)])
def test_long_or_odd_paths_are_answered(server, path, expected):
    assert get(server, path)[0] == expected
    assert get(server, "/scene/manifest.json")[0] == 200  # and the server goes on


def test_fifty_parallel_clients_are_all_answered(server):
    """50 clients on 127.0.0.1 at once, 4 requests each, within a bounded time: every one gets
    its 200 (the standard backlog of 5 dropped some)."""
    barrier = threading.Barrier(50)

    def client(_):
        barrier.wait(timeout=30)
        return [get(server, "/scene/manifest.json")[0] for _ in range(4)]

    with ThreadPoolExecutor(50) as pool:
        statuses = [s for result in pool.map(client, range(50), timeout=120) for s in result]
    assert statuses == [200] * 200


def test_a_port_in_use_is_a_one_line_error():
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        with pytest.raises(PatchlightError, match=f"{port}.*in use"):
            ViewerServer(b"{}", b"", port=port)


@pytest.mark.parametrize("number, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_view_command_prints_the_address_serves_and_stops_on_ctrl_c(tmp_path, number, status):
    proc = subprocess.Popen([sys.executable, "-m", "patchlight.cli.main", "view", "room", "--exposure", "1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert "http://127.0.0.1:" in line, proc.stderr.read() if proc.poll() is not None else line
        port = int(line.split("http://127.0.0.1:")[1].split("/")[0])
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
        conn.request("GET", "/scene/manifest.json")
        manifest = json.loads(conn.getresponse().read())
        assert manifest["name"] == "room" and manifest["settings"]["model"] == "lambert"
        # Ctrl-C while requests are under way: one half sent, one whose answer is not read.
        half_sent = socket.create_connection(("127.0.0.1", port), timeout=10)
        half_sent.sendall(b"GET /scene/da")
        unread = socket.create_connection(("127.0.0.1", port), timeout=10)
        unread.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        unread.sendall(f"GET /scene/data.bin HTTP/1.0\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
        assert unread.recv(12).startswith(b"HTTP/1.0 200")
        proc.send_signal(number)
        assert proc.wait(timeout=20) == status
        assert "viewer stopped" in proc.stdout.read()
        half_sent.close()
        unread.close()
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait()


def test_view_command_bad_input_is_one_line(capsys):
    from patchlight.cli.main import main

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        assert main(["view", "room", "--exposure", "1", "--port", str(busy.getsockname()[1])]) == 2
    assert "in use" in capsys.readouterr().err
    assert main(["view", "room", "--model", "lightmap"]) == 2
    assert "lightmap" in capsys.readouterr().err
