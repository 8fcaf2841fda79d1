"""The viewer's local server: hostile requests get a 4xx and a logged line and the server keeps serving; only the
page's files are served; a material change computes the kernel `ssskit kernel` writes; Ctrl-C exits 130."""
import http.client
import io
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from ssskit.view.server import ViewServer, serve
from ssskit.view.site import MaterialRequest, page_data


@pytest.fixture(scope="module")
def server():
    log = io.StringIO()
    srv = ViewServer(page_data("icosphere", {"skin1": MaterialRequest("skin1")}, "skin1", served=True), 0, log)
    thread = threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    yield srv, log
    srv.shutdown()
    srv.server_close()


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


def test_25_hostile_requests_each_get_a_4xx_and_the_server_answers_the_next(server):
    srv, log = server
    p = srv.port
    post = lambda body, **kw: request(p, "POST", "/api/material", body, **kw)  # noqa: E731
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
    ]
    assert len(hostile) == 25
    before = log.getvalue().count("\n")
    for i, send in enumerate(hostile):
        status, body = send()
        assert 400 <= status < 500, (i, status, body[:200])
        assert b"root:" not in body and b"import" not in body, i      # nothing outside the page
        assert request(p, "GET", "/index.html")[0] == 200, i          # and the server answers the next request
    assert log.getvalue().count("\n") - before == 25                 # one logged line each


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
