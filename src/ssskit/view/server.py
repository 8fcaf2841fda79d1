"""The viewer's local server: the standard library's :class:`http.server.ThreadingHTTPServer` (no dependency to
keep up to date for a few routes; one thread per request, so a slow kernel does not stall the page's files).

Safe by construction:

* bound to 127.0.0.1 only; a request whose ``Host`` header names another host is refused (403), which defeats
  DNS rebinding;
* it serves the page's own files by name (:data:`ssskit.view.site.PAGE_FILES` and the generated ``data.js``),
  nothing read from a path taken from the request, so no traversal can reach another file;
* three API routes, each a JSON object of at most :data:`MAX_BODY` bytes naming a preset (never a file: the API
  reads no user path) or artists' terms, every value checked before any work: ``POST /api/material`` (with the
  separable pass's options, the adaptive guide's limits and the parts asked: :class:`ssskit.view.site.MaterialRequest`,
  :func:`~ssskit.view.site.material_payload`) answers the page's data; ``POST /api/export`` (an engine format of
  :data:`ssskit.export.FORMATS` and one of its suffixes) writes the engine file through :func:`ssskit.export.export`
  (the code of ``ssskit export``) into a temporary folder of its own and answers its bytes as a download
  (``Content-Disposition: attachment``): it never writes to a path the request names; ``POST /api/reference`` (a
  view of the scene, a preset, the page's size) answers the cached path trace of that view beside the page's frame
  (:func:`~ssskit.view.site.reference_payload`, from the ``references`` the CLI gives: the head's), never rendering one;
* a malformed or hostile request gets a 4xx with a JSON error and one logged line, and the server keeps serving.
"""

from __future__ import annotations

import json
import os
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO
from urllib.parse import urlsplit

from ..errors import SsskitError
from ..quantities import Choice, Quantity, check_fields, check_keys
from .site import (ADAPTIVE_FIELDS, ARTIST_ETA, PAGE_FILES, PARTS, MaterialRequest, data_script, engine_formats,
                   material_payload, page_file, reference_payload)

#: the largest request body the API reads (bytes)
MAX_BODY = 4096
#: the keys of a material request (``POST /api/material``)
API_KEYS = frozenset({"material", "albedo", "mfp", "kernel", "taps", "jitter", "parts", "adaptive"})
#: the keys of a reference request (``POST /api/reference``)
REFERENCE_KEYS = frozenset({"view", "material", "w", "h"})
#: the keys of an export request (``POST /api/export``)
EXPORT_KEYS = frozenset({"material", "albedo", "mfp", "format", "suffix"})
#: a side of the page's frame (a reference request's w and h)
PAGE_SIDE = Quantity("page size", 1, 8192, "px", "a side of the page's frame", integer=True)
_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8", ".css": "text/css; charset=utf-8"}


class RequestError(Exception):
    """A refused request: its HTTP status and the reason."""

    def __init__(self, status: int, reason: str) -> None:
        super().__init__(reason)
        self.status = status


def _material_keys(body: Any, allowed: frozenset[str], given: dict[str, str] | None = None) -> dict[str, Any]:
    """The material of a request body (a preset name, the key of a material file given to ``ssskit view`` on the
    command line: ``given`` maps it to that file, or albedo with mfp), its keys checked against ``allowed``."""
    from ..materials import MATERIALS

    check_keys(body, "the body", allowed)
    material = body.get("material")
    if isinstance(material, str) and given and material in given:
        material = given[material]  # the file named on the command line, never a path from the request
    elif material is not None:  # (the API reads no other files)
        material = Choice("material (a preset, or the page's own: the API reads no other files)",
                          MATERIALS.names()).check(material)
    # albedo and mfp: MaterialRequest's fields (one number or three each, in the artists' domain), checked there
    return {"material": material, **{k: body[k] for k in ("albedo", "mfp") if k in body}}


def parse_material_request(body: Any, given: dict[str, str] | None = None) -> tuple[MaterialRequest, tuple[str, ...]]:
    """An API body (parsed JSON) as a checked :class:`MaterialRequest` and the parts asked (all where not
    given), or a :class:`RequestError` or :class:`~ssskit.errors.SsskitError` (both answered 400). The adaptive
    guide's limits (``adaptive``: an object of :data:`~ssskit.view.site.ADAPTIVE_FIELDS`) are checked by
    :class:`~ssskit.screenspace.AdaptiveSettings`, the ranges the page was sent (:func:`ssskit.view.site.adaptive_controls`)."""
    from ..screenspace.adaptive import AdaptiveSettings

    kw = _material_keys(body, API_KEYS, given)
    # the values are checked once, by the request (MaterialRequest's fields: the kernel a spec that parses, whose
    # parameters have bounded ranges, so the work per request is bounded; the quantities' wording)
    kw.update({k: body[k] for k in ("kernel", "taps", "jitter") if k in body})
    parts: tuple[str, ...] = PARTS
    if "parts" in body:
        p = body["parts"]
        if not isinstance(p, list) or not p or not all(isinstance(x, str) and x in PARTS for x in p):
            raise RequestError(400, f"parts must be a non-empty list of {', '.join(PARTS)}")
        parts = tuple(x for x in PARTS if x in p)
    if "adaptive" in body:
        kw["adaptive"] = AdaptiveSettings(**check_keys(body["adaptive"], "adaptive", ADAPTIVE_FIELDS))
    return MaterialRequest(**kw), parts  # (checked when made)


def parse_export_request(body: Any, given: dict[str, str] | None = None) -> tuple[Any, str]:
    """An export body (parsed JSON) as the checked :class:`~ssskit.export.ExportSettings` of ``ssskit export``
    (its ``out`` a placeholder name in no folder: the server writes into a temporary folder of its own) and the
    download's file name, or a :class:`RequestError` or :class:`~ssskit.errors.SsskitError` (both answered 400).
    Artists' terms are exported with the viewer's relative index (:data:`~ssskit.view.site.ARTIST_ETA`), as
    ``ssskit export --albedo --mfp --eta 1.4``."""
    from ..export import ExportSettings

    kw = _material_keys(body, EXPORT_KEYS, given)
    formats = {f["name"]: f for f in engine_formats()}
    fmt = Choice("format (an engine format)", formats).check(body.get("format"))
    suffixes = formats[fmt]["suffixes"]
    suffix = Choice(f"suffix of {fmt}", suffixes).check(suffixes[0] if body.get("suffix") is None else body["suffix"])
    MaterialRequest(**kw)  # the page's material rules, stated once: the material once, artists' terms together
    artist = kw["material"] is None
    stem = "artist" if artist else Path(kw["material"]).stem.lower()
    name = f"{stem}_{fmt}{suffix}"
    if artist:
        return ExportSettings(format=fmt, out=name, albedo=kw.get("albedo"), mfp=kw.get("mfp"), eta=ARTIST_ETA), name
    return ExportSettings(format=fmt, out=name, material=kw["material"]), name


class ViewServer(ThreadingHTTPServer):
    """The server of one page: its ``data.js`` bytes, the port, where refusals are logged."""

    daemon_threads = True

    def __init__(self, data: dict[str, Any], port: int = 0, log: TextIO | None = None,
                 references: Callable[[str, str], dict[str, Any]] | None = None,
                 given: dict[str, str] | None = None) -> None:
        super().__init__(("127.0.0.1", int(port)), _Handler)
        self.data_js = data_script(data).encode("utf-8")
        self.log = log if log is not None else sys.stderr
        self.lock = threading.Lock()
        #: the scene's named views, and where the path-traced references of a (view, preset) come from
        #: (``ssskit view --scene head``: :func:`ssskit.figures.head.cached_reference_layers`), kept once read
        self.views = tuple(data["scene"].get("views", {}))
        self.references = references
        #: the page's own material files, named on the command line (``ssskit view --material FILE``): the page's
        #: key -> the file, the only files the API resolves a material from
        self.given = dict(given or {})
        self._layers: dict[tuple[str, str], dict[str, Any]] = {}

    def warm(self, presets: tuple[str, ...]) -> threading.Thread:
        """Compute the parts of ``presets`` the page's default state needs (the separable and transmittance
        passes) in a background thread (niced, a daemon: Ctrl-C does not wait for it) after the server listens,
        so that a preset the page switches to is answered from memory (the transmittance pass's MCML fit takes
        1-3 s a material: benchmarks/bench_view_material.py). Returns the thread."""
        def run() -> None:
            try:
                os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 10)
            except (AttributeError, OSError):
                pass
            for name in presets:
                try:
                    material_payload(MaterialRequest(name), ("separable", "transmission"))
                except SsskitError:
                    pass  # the request for it will say why
        thread = threading.Thread(target=run, name="ssskit-view-warm", daemon=True)
        thread.start()
        return thread

    def handle_error(self, request: Any, client_address: Any) -> None:
        """A request that failed outside the handler's own refusals (a client gone mid-answer, the server ending
        under Ctrl-C): one logged line instead of socketserver's traceback banner on stderr."""
        exc = sys.exc_info()[1]
        self.log.write(f"ssskit view: a request from {client_address[0]} ended early: {type(exc).__name__}\n")

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

    def _send(self, status: int, body: bytes, ctype: str, headers: dict[str, str] | None = None) -> None:
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        for key, value in (headers or {}).items():
            self.send_header(key, value)
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

    def _json_body(self) -> Any:
        if self.headers.get("Content-Type", "").split(";")[0].strip() != "application/json":
            raise RequestError(415, "the body must be application/json")
        length = self.headers.get("Content-Length")
        if length is None or not length.isdigit():
            raise RequestError(411, "a Content-Length is required")
        if int(length) > MAX_BODY:
            raise RequestError(413, f"the body is larger than {MAX_BODY} bytes")
        raw = self.rfile.read(int(length))
        try:
            return json.loads(raw.decode("utf-8"), parse_constant=_no_constant)
        except (UnicodeDecodeError, json.JSONDecodeError, ValueError) as exc:
            raise RequestError(400, f"malformed JSON: {exc}") from None
        except RecursionError:  # 4 KB of '[' nests deeper than the parser's recursion allows
            raise RequestError(400, "malformed JSON: nested too deeply") from None

    def _reference_request(self, body: Any) -> tuple[str, str, int, int]:
        """(view, preset, page width, page height) of a reference request, or a RequestError or SsskitError (400)."""
        from ..materials import MATERIALS

        fields: dict[str, Quantity | Choice] = {"view": Choice("view", self.server.views),
                                                "material": Choice("material", MATERIALS.names()),
                                                "w": PAGE_SIDE, "h": PAGE_SIDE}
        r = check_fields(check_keys(body, "a reference request", REFERENCE_KEYS, REFERENCE_KEYS), fields)
        if self.server.references is None:
            raise RequestError(404, "this scene has no path-traced references (the head's views have)")
        return r["view"], r["material"].lower(), r["w"], r["h"]

    def _reference_layers(self, view: str, material: str) -> dict[str, Any]:
        key = (view, material)
        with self.server.lock:
            layers = self.server._layers.get(key)
        if layers is None:
            assert self.server.references is not None
            try:
                layers = self.server.references(view, material)
            except SsskitError as exc:
                raise RequestError(404, str(exc)) from None
            with self.server.lock:
                self.server._layers[key] = layers
        return layers

    def do_POST(self) -> None:
        try:
            _, path = self._route()  # type: ignore[misc]
            if path == "/api/material":
                body = self._json_body()
                req, parts = parse_material_request(body, self.server.given)
                try:
                    payload = material_payload(req, parts)
                except SsskitError as exc:
                    raise RequestError(422, str(exc)) from None
                payload["request"] = {k: v for k, v in body.items() if k != "parts"}
                self._send(200, json.dumps(payload).encode(), "application/json")
            elif path == "/api/reference":
                view, material, w, h = self._reference_request(self._json_body())
                self._send(200, json.dumps(reference_payload(self._reference_layers(view, material), w, h)).encode(),
                           "application/json")
            elif path == "/api/export":
                settings, name = parse_export_request(self._json_body(), self.server.given)
                data = _export_bytes(settings)
                self._send(200, data, "application/octet-stream",
                           {"Content-Disposition": f'attachment; filename="{name}"'})
            else:
                raise RequestError(404, "unknown route")
        except RequestError as exc:
            self._refuse(exc.status, str(exc))
        except SsskitError as exc:  # a value of the body refused where it is checked (the quantities' wording)
            self._refuse(400, str(exc))

    def _other(self) -> None:
        self._refuse(405, f"method {self.command} is not allowed")

    do_PUT = do_DELETE = do_PATCH = do_OPTIONS = _other


def _export_bytes(settings: Any) -> bytes:
    """The engine file :func:`ssskit.export.export` writes for ``settings``, written into a temporary folder of the
    server's own (removed after, also when the export fails) and read back: the bytes ``ssskit export`` writes."""
    import tempfile
    from dataclasses import replace

    from ..export import export

    with tempfile.TemporaryDirectory(prefix="ssskit-view-export-") as tmp:
        out = Path(tmp) / Path(settings.out).name
        try:
            export(replace(settings, out=str(out)))
        except SsskitError as exc:
            raise RequestError(422, str(exc)) from None
        return out.read_bytes()


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


__all__ = ["API_KEYS", "EXPORT_KEYS", "MAX_BODY", "REFERENCE_KEYS", "RequestError", "ViewServer", "parse_export_request",
           "parse_material_request", "serve"]
