"""The viewer's local server: hostile requests get a 4xx and a logged line and the server keeps serving; only the
page's files are served; a material change computes the kernel `ssskit kernel` writes; Ctrl-C exits 130."""
import http.client
import json
import os
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

from ssskit.view.site import MaterialRequest, page_data
from tests.view.serving import running


@pytest.fixture(scope="module")
def server():
    with running(page_data("icosphere", {"skin1": MaterialRequest("skin1")}, "skin1", served=True)) as (srv, log):
        yield srv, log


def raw(port, data: bytes) -> tuple[int, bytes]:
    """Send raw bytes, return (status, body)."""
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        s.sendall(data)
        s.shutdown(socket.SHUT_WR)
        chunks = []
        while True:
            c = s.recv(65536)
            if not c:
                break
            chunks.append(c)
    reply = b"".join(chunks)
    head, _, body = reply.partition(b"\r\n\r\n")
    return int(head.split(b" ", 2)[1]), body


def request(port, method, path, body=None, host=None, ctype="application/json", length=None):
    h = [f"{method} {path} HTTP/1.0"]
    if host is not False:
        h.append(f"Host: {host or f'127.0.0.1:{port}'}")
    data = b"" if body is None else (body if isinstance(body, bytes) else body.encode())
    if ctype:
        h.append(f"Content-Type: {ctype}")
    if length is not False and (body is not None or length is not None):
        h.append(f"Content-Length: {len(data) if length is None else length}")
    return raw(port, ("\r\n".join(h) + "\r\n\r\n").encode() + data)


def test_the_page_is_served(server):
    srv, _ = server
    for path in ("/", "/index.html", "/viewer.js", "/viewer.css", "/data.js"):
        status, body = request(srv.port, "GET", path)
        assert status == 200 and body, path


def test_hostile_requests_each_get_a_4xx_and_the_server_answers_the_next(server):
    """The issue's 25 hostile requests and those of the later routes (the export, the parts, the adaptive limits)."""
    srv, log = server
    p = srv.port
    post = lambda body, **kw: request(p, "POST", "/api/material", body, **kw)  # noqa: E731
    export = lambda body, **kw: request(p, "POST", "/api/export", body, **kw)  # noqa: E731
    ref = lambda body, **kw: request(p, "POST", "/api/reference", body, **kw)  # noqa: E731
    hostile = [
        lambda: request(p, "GET", "/../../../../etc/passwd"),
        lambda: request(p, "GET", "/%2e%2e/%2e%2e/etc/passwd"),
        lambda: request(p, "GET", "/..%2f..%2f..%2fetc%2fpasswd"),
        lambda: request(p, "GET", "//etc/passwd"),
        lambda: request(p, "GET", "/static/../site.py"),
        lambda: request(p, "GET", "/server.py"),
        lambda: request(p, "GET", "http://evil.example/index.html"),
        lambda: request(p, "GET", "/", host="evil.example"),
        lambda: request(p, "GET", "/", host=f"127.0.0.1.evil.example:{p}"),
        lambda: request(p, "GET", "/index.html", host=False),
        lambda: request(p, "GET", "/api/material"),
        lambda: post("x", length=10_000_000),
        lambda: post("{"),
        lambda: post("[1, 2, 3]"),
        lambda: post(json.dumps({"material": "../../etc/passwd"})),
        lambda: post(json.dumps({"material": "/etc/passwd"})),
        lambda: post('{"albedo": [NaN, 0.5, 0.5], "mfp": [1, 1, 1]}'),
        lambda: post(json.dumps({"albedo": [0.5, 0.5, 0.5], "mfp": [-1.0, 1.0, 1.0]})),
        lambda: post(json.dumps({"albedo": [1.5, 0.5, 0.5], "mfp": [1.0, 1.0, 1.0]})),
        lambda: post(json.dumps({"material": "skin1", "taps": 100001})),
        lambda: post(json.dumps({"material": "skin1", "kernel": "svd:999"})),
        lambda: post(json.dumps({"material": "skin1"}), ctype="text/plain"),
        lambda: post(json.dumps({"material": "skin1"}), length=False),
        lambda: request(p, "DELETE", "/index.html"),
        lambda: raw(p, b"GARBAGE\r\n\r\n"),
        # the parts and the adaptive limits
        lambda: post(json.dumps({"material": "skin1", "parts": ["../../etc/passwd"]})),
        lambda: post(json.dumps({"material": "skin1", "parts": []})),
        lambda: post(json.dumps({"material": "skin1", "adaptive": {"b_min": -1}})),
        lambda: post(json.dumps({"material": "skin1", "adaptive": {"b_min": 40, "b_max": 32}})),
        lambda: post('{"material": "skin1", "adaptive": {"sigma0_sq": NaN}}'),
        lambda: post(json.dumps({"material": "skin1", "adaptive": {"alpha": 0}})),
        lambda: post(json.dumps({"material": "skin1", "adaptive": {"b_min": True}})),
        lambda: post(json.dumps({"material": "skin1", "adaptive": {"open": "/etc/passwd"}})),
        # the export: no path from the request, an engine format of the registry and one of its suffixes
        lambda: export(json.dumps({"material": "skin1", "format": "unreal", "out": "/tmp/x.json"})),
        lambda: export(json.dumps({"material": "/etc/passwd", "format": "unreal"})),
        lambda: export(json.dumps({"material": "skin1", "format": "../../etc/passwd"})),
        lambda: export(json.dumps({"material": "skin1", "format": "glsl"})),
        lambda: export(json.dumps({"material": "skin1", "format": "unreal", "suffix": "/../../x.py"})),
        lambda: export(json.dumps({"material": "skin1", "format": "unreal", "suffix": ".mtlx"})),
        lambda: export(json.dumps({"format": "unreal"})),
        lambda: export(json.dumps({"material": "skin1", "albedo": [0.5, 0.5, 0.5], "mfp": [1, 1, 1],
                                   "format": "unreal"})),
        lambda: export('{"albedo": [0.5, 0.5, Infinity], "mfp": [1, 1, 1], "format": "unreal"}'),
        lambda: export(json.dumps({"material": "skin1", "format": "unreal"}), ctype="text/plain"),
        lambda: export("x" * 5000),
        lambda: request(p, "GET", "/api/export"),
        # the reference: a view of the scene, a preset, the page's size; never a path
        lambda: ref(json.dumps({"view": "../../etc/passwd", "material": "skin1", "w": 96, "h": 72})),
        lambda: ref(json.dumps({"view": "front", "material": "/etc/passwd", "w": 96, "h": 72})),
        lambda: ref(json.dumps({"view": "front", "material": "skin1", "w": 10**9, "h": 72})),
        lambda: ref(json.dumps({"view": "front", "material": "skin1", "w": 96, "h": 72, "file": "/etc/passwd"})),
        # nested deeper than the JSON parser recurses, within MAX_BODY (a new user's trial: a dropped connection)
        lambda: post("[" * 2000 + "]" * 2000),
        lambda: export("[" * 2000 + "]" * 2000),
        lambda: ref("[" * 2000 + "]" * 2000),
    ]
    assert len(hostile) == 52
    before = log.getvalue().count("\n")
    for i, send in enumerate(hostile):
        status, body = send()
        assert 400 <= status < 500, (i, status, body[:200])
        assert b"root:" not in body and b"import" not in body, i      # nothing outside the page
        assert request(p, "GET", "/index.html")[0] == 200, i          # and the server answers the next request
    assert log.getvalue().count("\n") - before == len(hostile)      # one logged line each
    assert not os.path.exists("/tmp/x.json")


def _reply(port, path, body) -> tuple[int, dict, bytes]:
    """POST JSON through http.client: (status, headers, body)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=300)
    try:
        conn.request("POST", path, json.dumps(body), {"Content-Type": "application/json"})
        r = conn.getresponse()
        return r.status, dict(r.getheaders()), r.read()
    finally:
        conn.close()


def test_the_export_route_answers_the_bytes_ssskit_export_writes(server, tmp_path):
    """Every engine format of the registry and each of its suffixes, a preset and artists' terms (the viewer's
    eta): the bytes served as a download equal the file ``ssskit export`` writes for the same request."""
    from ssskit.export import FORMATS

    srv, _ = server
    engines = [(f.name, s) for _, f in FORMATS.items() if f.kind == "engine" for s in f.suffixes]
    assert {name for name, _ in engines} >= {"unreal", "unity", "blender", "materialx", "babylon"}
    cases = [({"material": "marble"}, ["--material", "marble"], name, s) for name, s in engines]
    cases.append(({"albedo": [0.7, 0.5, 0.4], "mfp": [1.7, 0.9, 0.5]},
                  ["--albedo", "0.7,0.5,0.4", "--mfp", "1.7,0.9,0.5", "--eta", "1.4"], "unreal", ".json"))
    import importlib.util

    has_materialx = importlib.util.find_spec("MaterialX") is not None
    for body, flags, name, suffix in cases:
        status, headers, data = _reply(srv.port, "/api/export", {**body, "format": name, "suffix": suffix})
        if name == "materialx" and not has_materialx:  # the optional extra: the API says how to install it
            assert status == 422 and b"pip install" in data, data[:300]
            continue
        assert status == 200, data[:300]
        stem = body.get("material", "artist")
        assert headers["Content-Disposition"] == f'attachment; filename="{stem}_{name}{suffix}"'
        out = tmp_path / f"{stem}_{name}{suffix}"
        proc = subprocess.run([sys.executable, "-m", "ssskit", "export", "--format", name, *flags, "--out", str(out)],
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        assert data == out.read_bytes(), (name, suffix)
    assert not list(srv_tmp_folders()), "the server left a temporary folder behind"


def test_the_pages_own_material_file_is_served_and_exported_and_no_other_file(tmp_path):
    """`ssskit view --material FILE` (the README's step 2; a new user's trial found every request after the first
    frame refused): the page names the file by its key, the server resolves that key to the file given on the
    command line, computes its parts and exports it with the bytes `ssskit export --material FILE` writes; any
    other path stays refused."""
    f = tmp_path / "My.toml"
    f.write_text('name = "my skin"\nsigma_a = [0.032, 0.17, 0.48]\nsigma_s = [0.74, 0.88, 1.01]\neta = 1.3\n')
    key = str(f).lower()
    data = page_data("icosphere", {key: MaterialRequest(str(f))}, key, served=True)
    with running(data, given={key: str(f)}) as (srv, _):
        status, _, body = _reply(srv.port, "/api/material", {"material": key, "parts": ["separable"], "taps": 11})
        assert status == 200, body[:300]
        assert json.loads(body)["separable"]["taps"] == 11
        status, headers, body = _reply(srv.port, "/api/export", {"material": key, "format": "unreal", "suffix": ".json"})
        assert status == 200, body[:300]
        assert headers["Content-Disposition"] == 'attachment; filename="my_unreal.json"'
        out = tmp_path / "my_unreal.json"
        proc = subprocess.run([sys.executable, "-m", "ssskit", "export", "--format", "unreal", "--material", str(f),
                               "--out", str(out)], capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        assert body == out.read_bytes()
        other = tmp_path / "other.toml"
        other.write_text(f.read_text())
        for path in ("/api/material", "/api/export"):
            status, _, body = _reply(srv.port, path, {"material": str(other), "format": "unreal"} if "export" in path
                                     else {"material": str(other)})
            assert status == 400 and b"reads no other files" in body, body[:300]


def srv_tmp_folders():
    import tempfile
    from pathlib import Path

    return Path(tempfile.gettempdir()).glob("ssskit-view-export-*")


def test_material_parts_are_asked_for_and_cached(server, monkeypatch):
    """The separable pass always, the other parts only where asked; a part computed before is not computed again
    (the transmittance model replaced by a failure after the first request); a material whose transmittance
    table fails keeps its other parts and names the reason."""
    import ssskit.screenspace.transmission as tr
    import ssskit.view.site as site
    from ssskit.errors import ProfileError

    srv, _ = server
    status, _, body = _reply(srv.port, "/api/material", {"material": "ketchup", "parts": ["separable"]})
    assert status == 200
    assert set(json.loads(body)) >= {"separable", "albedo"} and "transmission" not in json.loads(body)
    status, _, body = _reply(srv.port, "/api/material", {"material": "ketchup", "parts": ["transmission"]})
    first = json.loads(body)["transmission"]
    assert status == 200 and "shader" in first

    def fail(*_a, **_k):
        raise ProfileError("the table does not converge (a stand-in)")

    monkeypatch.setattr(tr, "mcml_model", fail)
    status, _, body = _reply(srv.port, "/api/material", {"material": "ketchup", "parts": ["transmission"]})
    assert status == 200 and json.loads(body)["transmission"] == first        # from the cache: no new fit
    site._transmission_part.cache_clear()                 # the cache emptied: the fit is asked again, and fails
    status, _, body = _reply(srv.port, "/api/material", {"material": "ketchup", "parts": ["transmission"]})
    assert json.loads(body)["transmission"]["error"] == "the table does not converge (a stand-in)"
    status, _, body = _reply(srv.port, "/api/material", {"material": "apple", "parts": ["separable", "transmission"]})
    payload = json.loads(body)
    assert status == 200 and payload["transmission"] == {"error": "the table does not converge (a stand-in)"}
    assert "shader" in payload["separable"]                  # the material keeps its other parts


def test_a_warmed_server_answers_the_presets_from_memory(server, monkeypatch):
    """``ssskit view`` warms the presets the page lists (their separable and transmittance parts) after it
    listens: afterwards no transmittance model is fitted for them (the fit replaced by a failure)."""
    import ssskit.screenspace.transmission as tr

    srv, _ = server
    srv.warm(("skin2", "marble")).join(timeout=600)

    def fail(*_a, **_k):
        raise AssertionError("fitted again")

    monkeypatch.setattr(tr, "mcml_model", fail)
    for name in ("skin2", "marble"):
        status, _, body = _reply(srv.port, "/api/material", {"material": name, "parts": ["separable", "transmission"]})
        assert status == 200 and "shader" in json.loads(body)["transmission"], body[:300]


def test_adaptive_limits_reach_the_shaders_and_the_ranges_are_pythons(server):
    """The page's inputs carry AdaptivePass's declared ranges: for every bound, a value beyond it is refused by
    AdaptivePass (the pipeline's settings) and by the server alike; a valid request gives the shaders of that guide."""
    import math

    from ssskit.backends.adaptive_plan import as_plan
    from ssskit.backends.gl.adaptive import adaptive_fragment_source
    from ssskit.errors import SettingsError
    from ssskit.pipeline.settings import AdaptivePass
    from ssskit.screenspace.adaptive import AdaptiveSettings
    from ssskit.view.site import adaptive_controls

    srv, _ = server
    controls = adaptive_controls()
    assert [c["name"] for c in controls] == ["b_min", "b_max", "sigma0_sq", "kappa", "alpha", "frames"]
    for c in controls:
        AdaptivePass(**{c["name"]: c["default"]})
        for bound, is_open, step in (("lo", c["lo_open"], -1), ("hi", c["hi_open"], 1)):
            v = c[bound]
            if v is None:
                continue
            beyond = v + step if c["integer"] else (v if is_open else v + step * max(abs(v), 1.0) * 1e-6)
            if c["name"] == "b_min" and bound == "hi":      # beyond b_max's default too: the budget rule
                continue
            with pytest.raises(SettingsError):
                AdaptivePass(**{c["name"]: beyond})
            if c["served_only"] and math.isfinite(beyond):
                status, _, body = _reply(srv.port, "/api/material", {"material": "skin1", "parts": ["adaptive"],
                                                                      "adaptive": {c["name"]: beyond}})
                assert status == 400, (c["name"], beyond, body)
    guide = {"b_min": 4, "b_max": 32, "sigma0_sq": 2e-3, "kappa": 0.5, "alpha": 0.1}
    status, _, body = _reply(srv.port, "/api/material", {"material": "skin1", "parts": ["adaptive"], "adaptive": guide})
    got = json.loads(body)["adaptive"]
    plan = as_plan(AdaptiveSettings(**guide))
    assert status == 200 and got["settings"] == guide and (got["b_min"], got["b_max"]) == (4, 32)
    assert got["estimate"] == adaptive_fragment_source(plan, False)
    assert got["update"] == adaptive_fragment_source(plan, True)


def test_a_served_material_change_gives_the_kernel_ssskit_kernel_writes(server, tmp_path):
    from ssskit.kernels.base import load_kernel
    from ssskit.sampling.taps import make_taps

    srv, _ = server
    status, body = request(srv.port, "POST", "/api/material", json.dumps({"material": "marble", "taps": 7}))
    assert status == 200, body
    sep = json.loads(body)["separable"]
    out = tmp_path / "k.json"
    proc = subprocess.run([sys.executable, "-m", "ssskit", "kernel", "--material", "marble", "--method", "preintegrated",
                           "--model", "dipole", "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    taps = make_taps(load_kernel(out), 7, "importance")
    np.testing.assert_allclose(sep["offsets_mm"], taps.offsets_mm, rtol=1e-12, atol=0)
    np.testing.assert_allclose(sep["weights"], taps.weights, rtol=1e-12, atol=0)


def test_ctrl_c_ends_the_server_with_130():
    proc = subprocess.Popen([sys.executable, "-m", "ssskit", "view", "--scene", "icosphere", "--no-open", "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = ""
        while "ssskit view at http://127.0.0.1:" not in line:   # after any progress lines of the page's data
            line = proc.stderr.readline()
            assert line, "the server exited before it listened"
        port = int(line.split("127.0.0.1:")[1].split("/")[0])
        assert request(port, "GET", "/")[0] == 200
        t0 = time.monotonic()
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=10) == 130
        assert time.monotonic() - t0 < 5
        assert "still working" not in proc.stderr.read()          # no heartbeat while waiting for requests
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)


def test_the_head_is_the_viewers_default_scene_with_its_credit():
    """The papers' scan (70,736 triangles, closed once welded) is what ``ssskit view`` shows by default, credited
    as its CC BY 3.0 licence asks."""
    from ssskit.cli.view import view
    from ssskit.settings import HEAD_ATTRIBUTION
    from ssskit.view.site import scene_payload

    assert next(p for p in view.params if p.name == "scene").default == "head"
    head = scene_payload("head")
    assert head["triangles"] == 70736 and head["cull"] != "none"
    assert head["about"]["attribution"] == HEAD_ATTRIBUTION


def test_a_request_that_fails_outside_the_handler_is_one_logged_line(server, capsys):
    """A new user's trial: Ctrl-C during a slow request left socketserver's "Exception occurred during processing
    of request" banner and a traceback after "ssskit: interrupted"; the server logs one line instead."""
    srv, log = server
    before = log.getvalue()
    try:
        raise ConnectionResetError("the client went away")
    except ConnectionResetError:
        srv.handle_error(None, ("127.0.0.1", 5))
    assert log.getvalue()[len(before):] == "ssskit view: a request from 127.0.0.1 ended early: ConnectionResetError\n"
    assert capsys.readouterr().err == ""
