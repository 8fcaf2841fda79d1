"""The viewer's local server: the standard library's :class:`http.server.ThreadingHTTPServer` (no dependency to
keep up to date for a few routes; one thread per request, so a slow kernel does not stall the page's files).

Safe by construction:

* bound to 127.0.0.1 only; a request whose ``Host`` header names another host is refused (403), which defeats
  DNS rebinding;
* it serves the page's own files by name (:data:`ssskit.view.site.PAGE_FILES` and the generated ``data.js``),
  nothing read from a path taken from the request, so no traversal can reach another file;
* one API route, ``POST /api/material``: a JSON object of at most :data:`MAX_BODY` bytes naming a preset (never a
  file: the API reads no user path) or artists' terms, with the separable pass's options; every value checked
  (:class:`ssskit.view.site.MaterialRequest`) before any work;
* a malformed or hostile request gets a 4xx with a JSON error and one logged line, and the server keeps serving.
"""

from __future__ import annotations

import json
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, TextIO
from urllib.parse import urlsplit

from ..errors import SsskitError
from .site import PAGE_FILES, MaterialRequest, data_script, material_payload, page_file

#: the largest request body the API reads (bytes)
MAX_BODY = 4096
#: the keys of an API request
API_KEYS = frozenset({"material", "albedo", "mfp", "kernel", "taps", "jitter"})
_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8", ".css": "text/css; charset=utf-8"}


class RequestError(Exception):
    """A refused request: its HTTP status and the reason."""

    def __init__(self, status: int, reason: str) -> None:
        super().__init__(reason)
        self.status = status


def parse_material_request(body: Any) -> MaterialRequest:
    """An API body (parsed JSON) as a checked :class:`MaterialRequest`, or a :class:`RequestError` (400)."""
    from ..materials import MATERIALS

    if not isinstance(body, dict):
        raise RequestError(400, "the body must be a JSON object")
    unknown = set(body) - API_KEYS
    if unknown:
        raise RequestError(400, f"unknown keys: {', '.join(sorted(map(str, unknown)))}")
    material = body.get("material")
    if material is not None and (not isinstance(material, str) or material not in MATERIALS):
        raise RequestError(400, f"material must be a preset name ({', '.join(MATERIALS.names())}); the API reads no files")
    if "kernel" in body and (not isinstance(body["kernel"], str) or len(body["kernel"]) > 40):
        raise RequestError(400, "kernel must be a method spec such as 'svd:2'")  # (bounded work per request)
    # the values are checked once, by the request (MaterialRequest.check: the quantities' wording)
    kw: dict[str, Any] = {"material": material, **{k: tuple(body[k]) if isinstance(body[k], list) else body[k]
                                                   for k in ("albedo", "mfp", "kernel", "taps", "jitter") if k in body}}
    try:
        req = MaterialRequest(**kw)  # (checked when made)
    except SsskitError as exc:
        raise RequestError(400, str(exc)) from None
    return req


class ViewServer(ThreadingHTTPServer):
    """The server of one page: its ``data.js`` bytes, the port, where refusals are logged."""

    daemon_threads = True

    def __init__(self, data: dict[str, Any], port: int = 0, log: TextIO | None = None) -> None:
        super().__init__(("127.0.0.1", int(port)), _Handler)
        self.data_js = data_script(data).encode("utf-8")
        self.log = log if log is not None else sys.stderr
        self.lock = threading.Lock()

    @property
    def port(self) -> int:
        return int(self.server_address[1])

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/"


class _Handler(BaseHTTPRequestHandler):
    server: ViewServer
    server_version = "ssskit-view"
    sys_version = ""
    protocol_version = "HTTP/1.0"

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (the base class's name)
        pass  # successful requests are not logged; refusals are (_refuse)

    def _send(self, status: int, body: bytes, ctype: str) -> None:
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        if getattr(self, "command", None) != "HEAD":
            self.wfile.write(body)

    def _refuse(self, status: int, reason: str) -> None:
        with self.server.lock:
            # a malformed request line leaves no command or path (the base class refuses it before parsing them)
            command, path = getattr(self, "command", None) or "-", getattr(self, "path", "") or ""
            print(f"ssskit view: refused {command} {path[:200]!r} from {self.client_address[0]}: "
                  f"{status} {reason}", file=self.server.log, flush=True)
        self._send(status, json.dumps({"error": reason}).encode(), "application/json")

    def send_error(self, code: int, message: str | None = None, explain: str | None = None) -> None:
        """The base class's errors (malformed request lines, unsupported methods) as a logged JSON 4xx, with a
        status line even where the request line parsed as HTTP/0.9 (which has none)."""
        self.request_version = "HTTP/1.0"
        self._refuse(code, message or "bad request")

    def _host_ok(self) -> bool:
        host = self.headers.get("Host", "")
        return host in (f"127.0.0.1:{self.server.port}", f"localhost:{self.server.port}")

    def _route(self) -> tuple[str, str] | None:
        if not self._host_ok():
            raise RequestError(403, "the Host header must name this server (127.0.0.1)")
        parts = urlsplit(self.path)
        if parts.scheme or parts.netloc or not self.path.startswith("/"):
            raise RequestError(400, "the request target must be a path")
        return self.command, parts.path

    def do_GET(self) -> None:
        try:
            _, path = self._route()  # type: ignore[misc]
            name = "index.html" if path == "/" else path[1:]
            if name == "data.js":
                self._send(200, self.server.data_js, _TYPES[".js"])
            elif name in PAGE_FILES:
                self._send(200, page_file(name), _TYPES["." + name.rsplit(".", 1)[1]])
            else:
                raise RequestError(404, "not a file of the page")
        except RequestError as exc:
            self._refuse(exc.status, str(exc))

    do_HEAD = do_GET

    def do_POST(self) -> None:
        try:
            _, path = self._route()  # type: ignore[misc]
            if path != "/api/material":
                raise RequestError(404, "unknown route")
            if self.headers.get("Content-Type", "").split(";")[0].strip() != "application/json":
                raise RequestError(415, "the body must be application/json")
            length = self.headers.get("Content-Length")
            if length is None or not length.isdigit():
                raise RequestError(411, "a Content-Length is required")
            if int(length) > MAX_BODY:
                raise RequestError(413, f"the body is larger than {MAX_BODY} bytes")
            raw = self.rfile.read(int(length))
            try:
                body = json.loads(raw.decode("utf-8"), parse_constant=_no_constant)
            except (UnicodeDecodeError, json.JSONDecodeError, ValueError) as exc:
                raise RequestError(400, f"malformed JSON: {exc}") from None
            req = parse_material_request(body)
            try:
                payload = material_payload(req)
            except SsskitError as exc:
                raise RequestError(422, str(exc)) from None
            payload["request"] = {k: v for k, v in body.items()}
            self._send(200, json.dumps(payload).encode(), "application/json")
        except RequestError as exc:
            self._refuse(exc.status, str(exc))

    def _other(self) -> None:
        self._refuse(405, f"method {self.command} is not allowed")

    do_PUT = do_DELETE = do_PATCH = do_OPTIONS = _other


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number JSON allows")


def serve(server: ViewServer) -> None:
    """Serve until Ctrl-C (KeyboardInterrupt propagates at once: request threads are daemons); the CLI's
    heartbeat is quiet meanwhile (waiting for requests is not work)."""
    from ..progress import idle

    try:
        with idle():
            server.serve_forever(poll_interval=0.2)
    finally:
        server.server_close()


__all__ = ["API_KEYS", "MAX_BODY", "RequestError", "ViewServer", "parse_material_request", "serve"]
