"""Benchmark: the live viewer (ssskit view) in headless Chromium, frames per second and ms per pass, with the
numba and gl backends timing the same frame (the page's own G-buffer read back) in the same run.

The page: the static folder of ``ssskit view --scene head --out DIR`` (the scanned head, the viewer's default scene,
70,736 triangles; ``--scene bust`` for the generated bust, 248,324; Skin1, the pre-integrated kernel, 7 taps,
jitter 0.1; Burley 16 spp). Per renderer (``swiftshader``: ANGLE on SwiftShader;
``gl``: ANGLE on the system's OpenGL ES through EGL, Mesa's llvmpipe here) and size, per pass (off, separable,
burley, adaptive, separable + transmittance; each drawing its G-buffer every frame, and separable and adaptive
again keeping the G-buffer of the frame before, as the page does on a still view), the median over ``--frames``
frames after one warm-up frame of: the frame's wall time to a finished
one-pixel readback (G-buffer pass, the pass, composite: fps = 1000 / ms) and each pass's wall time to a finished
readback (``?timer=wall``: the page then syncs after every pass, which adds a little to the frame).

In the same run, on the page's G-buffer: the numba backend's separable and Burley passes (wall time) and the gl
backend's (moderngl compute on llvmpipe or a GPU, wall time around a readback). Prints one JSON object with the
load average before and after.

    python benchmarks/bench_view.py [--sizes 960x540 1920x1080] [--frames 5] [--renderers swiftshader gl]
                                    [--scene head|bust]
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def cpu_seconds() -> float | None:
    """User + system CPU seconds of this process's descendants (the Playwright driver, the browser, its GPU process
    where SwiftShader runs), or None without psutil: what a frame costs the CPUs whatever else runs beside it."""
    try:
        import psutil
    except ImportError:
        return None
    total = 0.0
    for child in psutil.Process().children(recursive=True):
        try:
            t = child.cpu_times()
            total += t.user + t.system
        except psutil.Error:
            pass
    return total


def page_times(site: Path, gl: str, w: int, h: int, frames: int) -> dict:
    from ssskit.view.browser import headless_page

    out: dict = {}
    with headless_page(gl=gl, width=w + 320, height=h) as (page, log):
        page.goto((site / "index.html").as_uri() + f"?w={w}&h={h}&timer=wall")
        page.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=120_000)
        # every frame draws the G-buffer again (reuse_gbuffer: false), as a moving view or light does
        modes = {m: {"pass": m, "spp": 16, "auto": False, "transmission": False, "reuse_gbuffer": False}
                 for m in ("off", "separable", "burley", "adaptive")}
        # the separable frame with the transmittance pass (the light map included)
        modes["transmission"] = {"pass": "separable", "spp": 16, "auto": False, "transmission": True,
                                 "reuse_gbuffer": False}
        # the page's own behaviour on a still view: the G-buffer kept from the frame before (reported apart)
        for m in ("separable", "adaptive"):
            modes[m + " (G-buffer reused)"] = {"pass": m, "spp": 16, "auto": False, "transmission": False,
                                               "reuse_gbuffer": True}
        for mode, state in modes.items():
            page.evaluate(f"() => window.ssskit.set({json.dumps(state)})")
            page.evaluate("() => window.ssskit.render()")   # warm-up: shader compilation
            c0 = cpu_seconds()
            runs = page.evaluate("(n) => { const r = []; for (let i = 0; i < n; ++i) r.push(window.ssskit.render()); "
                                 "return r; }", frames)
            c1 = cpu_seconds()
            frame = statistics.median(r["frame_ms"] for r in runs)
            passes = {k: round(statistics.median(r["passes"][k] for r in runs), 2) for k in runs[0]["passes"]}
            assert all(r["gbuffer_reused"] == state["reuse_gbuffer"] for r in runs), mode
            out[mode] = {"frame_ms": round(frame, 2), "fps": round(1000.0 / frame, 2), "passes_ms": passes}
            if c0 is not None and c1 is not None:
                cpu = 1000.0 * (c1 - c0) / frames
                # on 2 otherwise idle cores a frame takes at least cpu / 2 (all of it spread over both) and at most
                # cpu (none of it in parallel)
                out[mode]["cpu_ms_per_frame"] = round(cpu, 1)
                out[mode]["fps_2_idle_cores_range"] = [round(1000.0 / cpu, 2), round(2000.0 / cpu, 2)]
        page.evaluate("() => window.ssskit.set({pass: 'off', transmission: false})")
        page.evaluate("() => window.ssskit.render()")
        raw = base64.b64decode(page.evaluate("() => window.ssskit.read('src')"))
        out["fx"] = page.evaluate("() => window.ssskit.render()")["fx"]
        out["gbuffer"] = np.frombuffer(raw, np.float32).reshape(h, w, 4)[::-1].copy()
        out["renderer"] = page.evaluate("""() => { const gl = document.createElement('canvas').getContext('webgl2');
            const e = gl.getExtension('WEBGL_debug_renderer_info');
            return e ? gl.getParameter(e.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER); }""")
        log.check()
    return out


def backend_times(src: np.ndarray, fx: float, frames: int) -> dict:
    from ssskit.backends import backend_status, build_separable_plan, get_backend
    from ssskit.backends.burley_plan import build_burley_plan
    from ssskit.materials import get_material
    from ssskit.screenspace.burley import burley_params_for_material
    from ssskit.screenspace.separable import default_depth_mode
    from ssskit.view.site import MaterialRequest, kernel_taps

    e = src[..., :3].astype(np.float32)
    slots = (src[..., 3] > 0).astype(np.int64)
    depth = np.where(slots > 0, src[..., 3], 1.0).astype(np.float32)
    _, _, taps = kernel_taps(MaterialRequest("skin1"))
    sep = build_separable_plan({1: taps}, fx, fx, jitter=0.1, depth_mode=default_depth_mode(taps))
    bur = build_burley_plan({1: burley_params_for_material(get_material("skin1"))}, fx, fx)
    out: dict = {}
    for name in ("numba", "gl"):
        if not backend_status()[name]["available"]:
            out[name] = {"unavailable": backend_status()[name]["details"]}
            continue
        b = get_backend(name)
        res = {}
        for label, run in (("separable", lambda: b.separable(sep, e, depth, slots)),
                           ("burley", lambda: b.burley(bur, e, depth, slots, 16))):
            run()  # warm-up (compilation)
            ts = []
            for _ in range(frames):
                t0 = time.perf_counter()
                run()
                ts.append((time.perf_counter() - t0) * 1000)
            res[label + "_ms"] = round(statistics.median(ts), 2)
        out[name] = res
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["960x540", "1920x1080"])
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--renderers", nargs="+", default=["swiftshader", "gl"])
    ap.add_argument("--scene", default="head", help="the page's scene (ssskit view --scene): head (the viewer's "
                    "default, the scan: 70,736 triangles) or bust (248,324)")
    args = ap.parse_args()
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench-view-") as tmp:
        site = Path(tmp) / "site"
        subprocess.run([sys.executable, "-m", "ssskit", "view", "--scene", args.scene, "--no-open", "--out", str(site)],
                       check=True, capture_output=True)
        results: dict = {}
        for size in args.sizes:
            w, h = (int(v) for v in size.split("x"))
            for gl in args.renderers:
                key = f"{gl} {size}"
                try:
                    r = page_times(site, gl, w, h, args.frames)
                except Exception as exc:  # a renderer that does not start here is reported, not fatal
                    results[key] = {"error": str(exc).splitlines()[0][:300]}
                    continue
                g = r.pop("gbuffer")
                r["backends_same_frame"] = backend_times(g, r["fx"], max(1, args.frames // 2))
                results[key] = r
    print(json.dumps({"machine": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
                      "load_before": [round(x, 2) for x in load_before],
                      "load_after": [round(x, 2) for x in os.getloadavg()], "frames": args.frames,
                      "scene": args.scene, "scene_is_the_viewers_default": args.scene == "head",
                      "results": results}, indent=1))


if __name__ == "__main__":
    main()
