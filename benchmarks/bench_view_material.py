"""Benchmark: a material change in the served viewer (``ssskit view``), the time of the server's answers.

Per preset the page had not shown (skin2, marble, ketchup, apple) and a pair of artists' terms, a fresh server
(its own process, so nothing is cached in memory; the Monte Carlo tables ssskit caches on disk are as this
machine's cache holds them, stated per run by ``disk_cache``) answers:

* ``full``: the request the page sent before the parts existed: every part (the separable, Burley and adaptive
  shaders and the transmittance pass's MCML slab fit); what a served material change cost;
* ``frame``: the page's first request now (``parts: ["separable"]``, the default pass): the new material's frame
  is drawn when it arrives;
* ``transmission``: the page's second request (``parts: ["transmission"]``), drawn when it arrives;
* ``again``: the material asked a second time with every part (a preset shown before: the in-memory cache).

``--mode full`` alone runs against a server without parts (the code before them: ``PYTHONPATH=OLD/src``).
``--browser`` adds the page's side: the served bust in headless Chromium (SwiftShader) at ``--size``, each preset
chosen in the page's material list, the seconds until the first frame with the new material is drawn
(``frame``: the server's answer, the new shaders compiled, one frame) and until the frame with its transmittance
pass (``transmission``), with a fresh server (no warm-up: the worst case). Prints one JSON object with the load
average before and after.

    python benchmarks/bench_view_material.py [--mode all|full] [--presets skin2 marble ketchup apple]
                                             [--browser] [--size 960x540]
"""

from __future__ import annotations

import argparse
import http.client
import io
import json
import os
import platform
import subprocess
import sys
import threading
import time

ARTIST = {"albedo": [0.7, 0.5, 0.4], "mfp": [1.7, 0.9, 0.5]}


def _post(port: int, body: dict) -> tuple[int, float]:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=600)
    t0 = time.perf_counter()
    conn.request("POST", "/api/material", json.dumps(body), {"Content-Type": "application/json"})
    r = conn.getresponse()
    r.read()
    conn.close()
    return r.status, time.perf_counter() - t0


def worker(mode: str, material: dict) -> dict:
    """One fresh server in this process; the requests of ``mode`` for ``material``, each timed."""
    from ssskit.view.server import ViewServer
    from ssskit.view.site import MaterialRequest, page_data

    srv = ViewServer(page_data("icosphere", {"skin1": MaterialRequest("skin1")}, "skin1", served=True), 0, io.StringIO())
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    opts = {"kernel": "preintegrated", "taps": 7, "jitter": 0.1}
    out = {}
    try:
        if mode == "full":
            out["full"] = _post(srv.port, {**material, **opts})
        else:
            out["frame"] = _post(srv.port, {**material, **opts, "parts": ["separable"]})
            out["transmission"] = _post(srv.port, {**material, **opts, "parts": ["transmission"]})
            out["again"] = _post(srv.port, {**material, **opts})
    finally:
        srv.shutdown()
        srv.server_close()
    for k, (status, _) in out.items():
        if status != 200:
            raise SystemExit(f"{k}: status {status}")
    return {k: round(s, 3) for k, (_, s) in out.items()}


#: the page's side of a material change: choose ``name`` in the list, wait for the frames (resolves to seconds)
CHANGE_JS = """async (name) => {
  const S = window.ssskit, D = window.SSSKIT_DATA, sel = document.getElementById('material');
  const next = (ok) => new Promise((done) => { const f = () => (ok() ? done() : requestAnimationFrame(f)); f(); });
  const t0 = performance.now();
  sel.value = name;
  sel.dispatchEvent(new Event('change'));
  await next(() => S.drawn().material === name);
  const frame = (performance.now() - t0) / 1000;
  await next(() => S.drawn().material === name && S.drawn().transmission);
  return [frame, (performance.now() - t0) / 1000];
}"""


def browser_times(presets: list[str], width: int, height: int) -> dict:
    """Seconds from choosing each preset in the served bust's page to its first frame and to its frame with the
    transmittance pass (a fresh server, no warm-up)."""
    from ssskit.view.browser import headless_page
    from ssskit.view.server import ViewServer
    from ssskit.view.site import MaterialRequest, page_data

    srv = ViewServer(page_data("bust", {"skin1": MaterialRequest("skin1")}, "skin1", served=True), 0, io.StringIO())
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    out = {}
    try:
        with headless_page(width=width + 420, height=max(height, 900)) as (page, log):
            page.goto(srv.url + f"?w={width}&h={height}")
            page.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=120_000)
            page.evaluate("() => window.ssskit.ready()")
            for name in presets:
                frame, trans = page.evaluate(CHANGE_JS, name)
                out[name] = {"frame": round(frame, 3), "transmission": round(trans, 3)}
            log.check()
    finally:
        srv.shutdown()
        srv.server_close()
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mode", choices=("all", "full"), default="all")
    ap.add_argument("--presets", nargs="+", default=["skin2", "marble", "ketchup", "apple"])
    ap.add_argument("--browser", action="store_true")
    ap.add_argument("--size", default="960x540")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker is not None:
        mode, material = json.loads(args.worker)
        print(json.dumps(worker(mode, material)))
        return {}
    from ssskit.cache import cache_root

    load0 = os.getloadavg()
    materials = {name: {"material": name} for name in args.presets}
    if args.mode == "all":
        materials["artist 0.7,0.5,0.4 / 1.7,0.9,0.5 mm"] = ARTIST
    modes = ("full",) if args.mode == "full" else ("full", "page")
    rows: dict = {}
    for name, material in materials.items():
        rows[name] = {}
        for mode in modes:
            proc = subprocess.run([sys.executable, __file__, "--worker", json.dumps([mode, material])],
                                  capture_output=True, text=True, timeout=1200)
            if proc.returncode != 0:
                raise SystemExit(proc.stderr)
            rows[name].update(json.loads(proc.stdout.strip().splitlines()[-1]))
    out = {"command": "python benchmarks/bench_view_material.py " + " ".join(argv or sys.argv[1:]),
           "seconds_per_request": rows, "disk_cache": str(cache_root()),
           "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "load_avg_before": load0,
                       "load_avg_after": os.getloadavg()}}
    if args.browser:
        w, _, h = args.size.partition("x")
        out["seconds_in_the_page"] = {"size": args.size, "renderer": "swiftshader",
                                      **browser_times(args.presets, int(w), int(h))}
        out["machine"]["load_avg_after"] = os.getloadavg()
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
