"""Benchmark: the separable pass on the ``gl`` backend (GLSL compute), ms per frame and per pass.

The scene of ``bench_separable.py``: 7 importance-sampled taps of the pre-integrated Skin1 kernel,
the follow-surface depth test, float32 RGB, every pixel inside the SSS mask, a tilted plane; without
jitter and with the paper's 10% jitter; 720p, 1080p and 4K.

Timing: on a GPU, GL timer queries (GL_TIME_ELAPSED), one per pass and, in separate frames, one
around the whole frame (queries cannot nest); on llvmpipe (Mesa's CPU driver) wall time around
glFinish. Medians over ``--frames`` frames after warm-up, images resident on the GPU (no upload or
readback inside a timed frame). In the same run:

* the floor: a compute shader that copies the same bytes the two passes move (RGBA32F texel read
  and written twice per pixel, no arithmetic), timed the same way;
* on the CPU (``--cpu``): the numba backend's pass on the same frame (wall time, medians).

Prints one JSON object.

    python benchmarks/bench_gl.py [--sizes 1280x720 1920x1080 3840x2160] [--frames 50] [--cpu]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from bench_separable import FOCAL_1080P, scene, taps_for  # noqa: E402

COPY_SOURCE = """#version 430
layout(local_size_x = 16, local_size_y = 16) in;
layout(binding = 0) uniform sampler2D u_src;
layout(rgba32f, binding = 0) writeonly uniform image2D u_dst;
uniform ivec2 u_size;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= u_size.x || p.y >= u_size.y) return;
    imageStore(u_dst, p, texelFetch(u_src, p, 0));
}
"""


def _size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def _median(v):
    return statistics.median(v) if v else None


def time_gl(width: int, height: int, jitter: float, frames: int, local_size) -> dict:
    from ssskit.backends.gl.context import GpuTimer, context
    from ssskit.backends.gl.separable import SeparableFrame
    from ssskit.backends.plan import build_separable_plan

    image, depth = scene(width, height)
    f = FOCAL_1080P * width / 1920
    taps = taps_for("skin1")
    plan = build_separable_plan({1: taps}, f, f, jitter=jitter, depth_mode="follow")
    slots = np.ones((height, width), np.int32)
    ctx = context()
    with ctx:
        frame = SeparableFrame(plan, image, depth, slots, local_size=local_size)
        for _ in range(5):
            frame.run()
        ctx.finish()
        timer = GpuTimer()
        for _ in range(frames):
            frame.run(timer=timer)
        passes = {k: _median(v) for k, v in timer.results().items()}
        for _ in range(frames):
            with timer("frame"):
                frame.run()
        per_frame = timer.results()["frame"]
        out = frame.read()
    return {"frame_ms": _median(per_frame), "frame_ms_min": min(per_frame), "passes_ms": passes,
            "jittered_rows": int(plan.terms[0].n_jit[1]), "checksum": float(out.astype(np.float64).sum()),
            "timing": "GL_TIME_ELAPSED" if timer.gpu else "wall time around glFinish"}


def time_copy_floor(width: int, height: int, frames: int) -> dict:
    """Two RGBA32F texture -> image copies: the bytes the two passes must move at least."""
    from ssskit.backends.gl.context import GpuTimer, compile_compute, context

    ctx = context()
    with ctx:
        data = np.random.default_rng(0).random((height, width, 4), dtype=np.float32)
        a, b, c = (ctx.texture((width, height), 4, dtype="f4") for _ in range(3))
        a.write(data.tobytes())
        prog = compile_compute(COPY_SOURCE, "copy")
        prog["u_size"] = (width, height)
        groups = (-(-width // 16), -(-height // 16))

        def run():
            for src, dst in ((a, b), (b, c)):
                src.use(0)
                dst.bind_to_image(0, read=False, write=True)
                prog.run(*groups, 1)
                ctx.memory_barrier()

        for _ in range(5):
            run()
        timer = GpuTimer()
        for _ in range(frames):
            with timer("copy"):
                run()
        times = timer.results()["copy"]
        ok = np.array_equal(np.frombuffer(c.read(), np.float32).reshape(height, width, 4), data)
        for t in (a, b, c):
            t.release()
    return {"frame_ms": _median(times), "frame_ms_min": min(times), "bytes": 4 * 16 * width * height,
            "copy_exact": bool(ok)}


def time_numba(width: int, height: int, jitter: float, repeats: int) -> float:
    from ssskit.screenspace.separable import filter_arrays

    image, depth = scene(width, height)
    f = FOCAL_1080P * width / 1920
    taps = taps_for("skin1")
    run = lambda: filter_arrays(image, depth, f, f, taps, jitter=jitter, depth_mode="follow", backend="numba")  # noqa: E731
    run()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        run()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["1280x720", "1920x1080", "3840x2160"])
    ap.add_argument("--frames", type=int, default=50, help="timed frames per case (medians)")
    ap.add_argument("--jitter", type=float, nargs="+", default=[0.0, 0.1])
    ap.add_argument("--local-size", nargs="+", default=["16x16"], help="work-group sizes to compare, WxH")
    ap.add_argument("--cpu", action="store_true", help="also time the numba backend on the same frames")
    ap.add_argument("--cpu-repeats", type=int, default=5)
    args = ap.parse_args(argv)
    from ssskit.backends.gl.context import renderer

    result = {"benchmark": "separable pass, gl backend", "renderer": renderer(), "python": platform.python_version(),
              "taps": 7, "depth_mode": "follow", "cases": []}
    for text in args.sizes:
        w, h = _size(text)
        floor = time_copy_floor(w, h, args.frames)
        for jitter in args.jitter:
            for ls in args.local_size:
                case = {"size": f"{w}x{h}", "jitter": jitter, "local_size": ls,
                        "gl": time_gl(w, h, jitter, args.frames, _size(ls)), "copy_floor": floor}
                case["ratio_to_floor"] = case["gl"]["frame_ms"] / floor["frame_ms"]
                if args.cpu:
                    case["numba_ms"] = time_numba(w, h, jitter, args.cpu_repeats)
                    case["numba_over_gl"] = case["numba_ms"] / case["gl"]["frame_ms"]
                result["cases"].append(case)
                print(json.dumps(case), file=sys.stderr, flush=True)
    print(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
