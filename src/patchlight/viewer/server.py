"""The viewer's local web server: 127.0.0.1 only, GET and HEAD only, a fixed set of files.

It serves the page (static/), the GLSL chunks (patchlight/shaders/*.glsl), the three.js
files the page imports (three_files.py: bundled into the package when it is built, else the
checkout's node_modules/three), the scene bundle (/scene/manifest.json, /scene/data.bin), a
bake's scene.glb (/scene/scene.glb, for the page's three.js view) and, for a bake, the view
from a patch (/scene/patch?x=X&y=Y: JSON, patchlight.patchview). Any other path (..,
absolute paths, encoded traversal, symlinks that lead out of the served directory, names too
long for the file system, files not on the list) gets 404; a request target longer than
MAX_TARGET characters gets 414. Connections queue up to BACKLOG deep, and a client silent for
CLIENT_TIMEOUT_S seconds is dropped.

Only requests addressed to the server itself are answered: a Host header other than
127.0.0.1:PORT or localhost:PORT (or none) gets 403, so a page of another site whose name
was rebound to 127.0.0.1 (DNS rebinding) cannot read the scene.
"""
from __future__ import annotations

import errno
import os
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Callable
from urllib.parse import parse_qs, unquote, urlsplit

from ..errors import PatchlightError
from .three_files import BUNDLED, THREE_FILES

HOST = "127.0.0.1"
MAX_TARGET = 2048       # characters in a request target; longer: 414
BACKLOG = 128           # connections waiting to be accepted (the standard library's 5 drops some of 50)
CLIENT_TIMEOUT_S = 10.0
STATIC = Path(__file__).resolve().parent / "static"
SHADERS = Path(__file__).resolve().parent.parent / "shaders"
CONTENT_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
                 ".css": "text/css; charset=utf-8", ".glsl": "text/plain; charset=utf-8",
                 ".json": "application/json", ".bin": "application/octet-stream", ".png": "image/png",
                 ".glb": "model/gltf-binary"}
GLB_ROUTE = "/scene/scene.glb"  # a bake's glTF, which the page loads through the GLTFLoader plugin


def find_three() -> Path:
    """The three.js files: bundled in the package (a built install, holding every file of the
    list), else node_modules/three from $PATCHLIGHT_NODE_MODULES or the nearest node_modules
    above this package or the working directory (a checkout after `npm ci`)."""
    bundled = Path(__file__).resolve().parent / BUNDLED
    if all((bundled / name).is_file() for name in THREE_FILES):
        return bundled
    candidates = []
    if os.environ.get("PATCHLIGHT_NODE_MODULES"):
        candidates.append(Path(os.environ["PATCHLIGHT_NODE_MODULES"]))
    for start in (Path(__file__).resolve(), Path.cwd().resolve()):
        candidates += [parent / "node_modules" for parent in start.parents]
    for modules in candidates:
        if all((modules / "three" / name).is_file() for name in THREE_FILES):
            return (modules / "three").resolve()
    raise PatchlightError("three.js not found: this patchlight was installed without its viewer files; "
                          "reinstall it with `pip install .` (or run `npm ci` in the checkout)")


def safe_file(root: Path, relative: str) -> Path | None:
    """The regular file `relative` names inside `root`, or None when the name is unsafe
    (empty, absolute, '..' or '.' segments, backslashes, NUL, too long for the file system)
    or resolves outside root."""
    if not relative or "\\" in relative or "\0" in relative or relative.startswith("/"):
        return None
    if any(part in ("", ".", "..") for part in relative.split("/")):
        return None
    try:
        root = root.resolve()
        candidate = (root / relative).resolve()
        if not candidate.is_relative_to(root) or not candidate.is_file():
            return None
    except OSError:  # a name too long, a loop of links
        return None
    return candidate


class ViewerServer:
    """Serves one scene bundle. port 0 picks a free port; `url` is the page's address."""

    def __init__(self, manifest: bytes, data: bytes, port: int = 0,
                 patch_view: Callable[[int, int], bytes] | None = None, scene_glb: bytes | None = None):
        """patch_view(x, y): the JSON body of the view from texel (x, y), or None without a bake;
        scene_glb: a bake's scene.glb, or None."""
        self.routes = {"/scene/manifest.json": manifest, "/scene/data.bin": data}
        if scene_glb is not None:
            self.routes[GLB_ROUTE] = scene_glb
        self.patch_view = patch_view
        self.three = find_three()
        handler = type("Handler", (_Handler,), {"viewer": self})
        try:
            self.httpd = _Server((HOST, port), handler)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise PatchlightError(f"`port` {port}: {HOST}:{port} is already in use") from None
            raise PatchlightError(f"`port` {port}: cannot listen on {HOST}:{port} ({exc.strerror})") from None
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        return f"http://{HOST}:{self.httpd.server_address[1]}/"

    def host_allowed(self, host: str | None) -> bool:
        """Whether a request's Host header names this server: 127.0.0.1 or localhost with its
        port (browsers leave the port out only when it is 80)."""
        if not host:
            return False
        port = self.httpd.server_address[1]
        names = (HOST, "localhost")
        allowed = {f"{name}:{port}" for name in names} | (set(names) if port == 80 else set())
        return host.strip().lower() in allowed

    def resolve(self, path: str, query: str = "") -> tuple[bytes | Path | None, str]:
        """(body or file, content type) for a request path and query, or (None, "") for 404."""
        if path == "/scene/patch" and self.patch_view is not None:
            texel = self._texel(query)
            return (None, "") if texel is None else (self.patch_view(*texel), CONTENT_TYPES[".json"])
        if path in ("/", "/index.html"):
            return STATIC / "index.html", CONTENT_TYPES[".html"]
        if path in self.routes:
            return self.routes[path], CONTENT_TYPES[Path(path).suffix]
        file = self._file(path)
        if file is None:
            return None, ""
        return file, CONTENT_TYPES.get(file.suffix, "application/octet-stream")

    @staticmethod
    def _texel(query: str) -> tuple[int, int] | None:
        """(x, y) of a query x=X&y=Y, whole numbers >= 0, or None."""
        fields = parse_qs(query, strict_parsing=False)
        try:
            x, y = (int(fields[k][0]) for k in ("x", "y"))
        except (KeyError, ValueError):
            return None
        return (x, y) if x >= 0 and y >= 0 else None

    def _file(self, path: str) -> Path | None:
        """The file a /static/, /shaders/ or /three/ path names, if it may be served."""
        prefix, _, rest = path[1:].partition("/")
        name = unquote(rest, errors="strict")
        if prefix == "static":
            return safe_file(STATIC, name)
        if prefix == "shaders" and "/" not in name and name.endswith(".glsl"):
            return safe_file(SHADERS, name)
        if prefix == "three" and name in THREE_FILES:
            return safe_file(self.three, name)
        return None

    def serve_forever(self) -> None:
        self.httpd.serve_forever()

    def start(self) -> "ViewerServer":
        """Serve from a background thread (tests)."""
        self._thread = threading.Thread(target=self.serve_forever, daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        if self._thread is not None:
            self.httpd.shutdown()
            self._thread.join()
        self.httpd.server_close()

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.close()


class _Server(ThreadingHTTPServer):
    request_queue_size = BACKLOG
    daemon_threads = True


class _Handler(BaseHTTPRequestHandler):
    viewer: ViewerServer
    server_version = "patchlight"
    timeout = CLIENT_TIMEOUT_S

    def do_GET(self):
        self._respond(send_body=True)

    def do_HEAD(self):
        self._respond(send_body=False)

    def _respond(self, send_body: bool) -> None:
        if not self.viewer.host_allowed(self.headers.get("Host")):
            self._send(HTTPStatus.FORBIDDEN, b"forbidden: unknown Host\n", "text/plain; charset=utf-8", send_body)
            return
        if len(self.path) > MAX_TARGET:
            self._send(HTTPStatus.REQUEST_URI_TOO_LONG, b"request target too long\n", "text/plain; charset=utf-8",
                       send_body)
            return
        try:
            url = urlsplit(self.path)
            body, content_type = self.viewer.resolve(url.path, url.query)
        except (UnicodeDecodeError, ValueError):
            body, content_type = None, ""
        if isinstance(body, Path):
            try:
                body = body.read_bytes()
            except OSError:  # gone or unreadable since it was checked
                body = None
        if body is None:
            self._send(HTTPStatus.NOT_FOUND, b"not found\n", "text/plain; charset=utf-8", send_body)
        else:
            self._send(HTTPStatus.OK, body, content_type, send_body)

    def _send(self, status: HTTPStatus, body: bytes, content_type: str, send_body: bool) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        if send_body:
            self.wfile.write(body)

    def log_message(self, format, *args):  # quiet: the terminal shows only the address
        pass
