"""Benchmark: the separable and Burley passes on the ``gl`` backend (GLSL compute), ms per frame and per pass.

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

The Burley pass (``--burley-spp``): Skin1's Burley parameters on the same frame, samplers exact and
xie, with and without the mip pyramid, GPU time per frame (pyramid included) and samples per second;
with ``--cpu`` the numba backend on the same frame.

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

COPY_BUFFER_SOURCE = """#version 430
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Src { vec4 src[]; };
layout(std430, binding = 1) writeonly buffer Dst { vec4 dst[]; };
uniform int u_n;
void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i < u_n) dst[i] = src[i];
}
"""

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


def parse_layout(text: str):
    """``default``, ``gpu``, ``cpu`` or ``HxW:VxW:SSS``: work-group sizes of the horizontal and vertical
    passes and the storage of the source, intermediate and output images (t = texture, b = buffer)."""
    from ssskit.backends.gl.separable import CPU_LAYOUT, GPU_LAYOUT, default_layout

    named = {"default": default_layout, "gpu": lambda: GPU_LAYOUT, "cpu": lambda: CPU_LAYOUT}
    if text in named:
        return named[text]()
    from ssskit.backends.gl.separable import Layout

    h, v, codes = text.split(":")
    return Layout(_size(h), _size(v), tuple("buffer" if c == "b" else "texture" for c in codes))


def time_gl(width: int, height: int, jitter: float, batches: int, batch: int, layout) -> dict:
    from ssskit.backends.gl.context import is_software, time_gpu
    from ssskit.backends.gl.separable import SeparableFrame
    from ssskit.backends.plan import build_separable_plan
    from ssskit.backends.numpy_backend import NumpyBackend

    image, depth = scene(width, height)
    f = FOCAL_1080P * width / 1920
    taps = taps_for("skin1")
    plan = build_separable_plan({1: taps}, f, f, jitter=jitter, depth_mode="follow")
    slots = np.ones((height, width), np.int32)
    frame = SeparableFrame(plan, image, depth, slots, layout=layout)
    frame.run()
    out = frame.read()
    per_frame = time_gpu(frame.run, batches, batch)
    passes = {name: statistics.median(time_gpu(lambda v=v: frame.dispatch(0, v), batches, batch))
              for name, v in (("horizontal", False), ("vertical", True))}
    # parity on a crop (the numpy oracle is slow): the same frame's top-left 256 x 128 window
    ch, cw = min(height, 128), min(width, 256)
    ref = NumpyBackend().separable(plan, image[:ch, :cw], depth[:ch, :cw], slots[:ch, :cw])
    small = SeparableFrame(plan, image[:ch, :cw], depth[:ch, :cw], slots[:ch, :cw], layout=layout)
    small.run()
    err = float(np.abs(small.read() - ref).max())
    return {"frame_ms": statistics.median(per_frame), "frame_ms_min": min(per_frame), "passes_ms": passes,
            "jittered_rows": int(plan.terms[0].n_jit[1]), "max_abs_vs_numpy_crop": err,
            "checksum": float(out.astype(np.float64).sum()),
            "timing": "wall time around glFinish" if is_software() else "GL_TIME_ELAPSED, batches of queued frames"}


def time_copy_floor(width: int, height: int, batches: int, batch: int) -> dict:
    """Two RGBA32F texture -> image copies: the bytes the two passes must move at least."""
    from ssskit.backends.gl.context import compile_compute, context, time_gpu

    ctx = context()
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

    times = time_gpu(run, batches, batch)
    ok = np.array_equal(np.frombuffer(c.read(), np.float32).reshape(height, width, 4), data)
    for t in (a, b, c):
        t.release()
    # the same bytes through storage buffers
    a, b, c = (ctx.buffer(reserve=16 * width * height) for _ in range(3))
    a.write(data.tobytes())
    bprog = compile_compute(COPY_BUFFER_SOURCE, "copy")
    bprog["u_n"] = width * height

    def run_buffers():
        for src, dst in ((a, b), (b, c)):
            src.bind_to_storage_buffer(0)
            dst.bind_to_storage_buffer(1)
            bprog.run(-(-width * height // 256), 1, 1)
            ctx.memory_barrier()

    btimes = time_gpu(run_buffers, batches, batch)
    ok = ok and np.array_equal(np.frombuffer(c.read(), np.float32).reshape(height, width, 4), data)
    for t in (a, b, c):
        t.release()
    nbytes = 4 * 16 * width * height
    ms = min(statistics.median(times), statistics.median(btimes))
    return {"frame_ms": ms, "texture_copy_ms": statistics.median(times), "buffer_copy_ms": statistics.median(btimes),
            "bytes": nbytes, "gb_per_s": nbytes / ms / 1e6, "copy_exact": bool(ok)}


def time_burley(width: int, height: int, spp: int, mips: bool, sampler: str, batches: int, batch: int,
                cpu: bool, cpu_repeats: int, filtered: bool = False) -> dict:
    """The Burley pass (Xie 2020) on the same frame: Skin1's Burley parameters (searchlight d), every
    pixel inside the mask; GPU time of a frame (mip pyramid included) and of the pyramid alone."""
    from ssskit.backends.burley_plan import build_burley_plan
    from ssskit.backends.gl.burley import BurleyFrame
    from ssskit.backends.gl.context import time_gpu
    from ssskit.backends.numpy_backend import NumpyBackend
    from ssskit.screenspace.burley import burley_params_for_material

    image, depth = scene(width, height)
    f = FOCAL_1080P * width / 1920
    plan = build_burley_plan({1: burley_params_for_material("skin1")}, f, f, sampler=sampler, mips=mips)
    slots = np.ones((height, width), np.int32)
    frame = BurleyFrame(plan, image, depth, slots, spp, filtered_mips=filtered)
    frame.run()
    per_frame = time_gpu(frame.run, batches, batch, warmup_ms=300.0)  # long frames: let the clocks settle
    mips_ms = statistics.median(time_gpu(frame.build_mips, batches, batch, warmup_ms=100.0)) if mips else 0.0
    frame.release()
    ms = statistics.median(per_frame)
    out = {"spp": spp, "mips": mips, "filtered_mips": filtered, "sampler": sampler, "frame_ms": ms,
           "mip_pyramid_ms": mips_ms,
           "gsamples_per_s": width * height * spp / ms / 1e6}
    # parity on a crop: the share of values off the float64 oracle by more than 1e-5
    ch, cw = min(height, 64), min(width, 96)
    crop = BurleyFrame(plan, image[:ch, :cw], depth[:ch, :cw], slots[:ch, :cw], spp, filtered_mips=filtered)
    crop.run()
    got = crop.read()
    crop.release()
    ref = NumpyBackend().burley(plan, image[:ch, :cw], depth[:ch, :cw], slots[:ch, :cw], spp)
    out["crop_share_off_by_1e-5"] = float((np.abs(got - ref) > 1e-5).mean())
    out["crop_max_abs"] = float(np.abs(got - ref).max())
    if cpu:
        from ssskit.backends import get_backend

        nb = get_backend("numba")
        nb.burley(plan, image, depth, slots, spp)
        times = []
        for _ in range(cpu_repeats):
            t0 = time.perf_counter()
            nb.burley(plan, image, depth, slots, spp)
            times.append(time.perf_counter() - t0)
        out["numba_ms"] = 1e3 * statistics.median(times)
    return out


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
    ap.add_argument("--batches", type=int, default=20, help="timed batches per case (medians)")
    ap.add_argument("--batch", type=int, default=10, help="frames queued back to back per timed batch")
    ap.add_argument("--jitter", type=float, nargs="+", default=[0.0, 0.1])
    ap.add_argument("--layout", nargs="+", default=["default"],
                    help="layouts to compare: default (this device's), gpu, cpu, or HxW:VxW:SSS (t/b per image)")
    ap.add_argument("--cpu", action="store_true", help="also time the numba backend on the same frames")
    ap.add_argument("--cpu-repeats", type=int, default=5)
    ap.add_argument("--burley-spp", type=int, nargs="*", default=[8, 16, 32, 64],
                    help="also time the Burley pass at these sample counts (none: skip it)")
    ap.add_argument("--burley-sizes", nargs="*", default=["1920x1080"])
    args = ap.parse_args(argv)
    from ssskit.backends.gl.context import renderer

    result = {"benchmark": "separable pass, gl backend", "renderer": renderer(), "python": platform.python_version(),
              "taps": 7, "depth_mode": "follow", "cases": []}
    for text in args.sizes:
        w, h = _size(text)
        floor = time_copy_floor(w, h, args.batches, args.batch)
        for jitter in args.jitter:
            for text in args.layout:
                layout = parse_layout(text)
                case = {"size": f"{w}x{h}", "jitter": jitter, "layout": text,
                        "gl": time_gl(w, h, jitter, args.batches, args.batch, layout), "copy_floor": floor}
                case["ratio_to_floor"] = case["gl"]["frame_ms"] / floor["frame_ms"]
                if args.cpu:
                    case["numba_ms"] = time_numba(w, h, jitter, args.cpu_repeats)
                    case["numba_over_gl"] = case["numba_ms"] / case["gl"]["frame_ms"]
                result["cases"].append(case)
                print(json.dumps(case), file=sys.stderr, flush=True)
    result["burley"] = []
    for text in args.burley_sizes if args.burley_spp else []:
        w, h = _size(text)
        for sampler in ("exact", "xie"):
            for mips, filtered in ((False, False), (True, False), (True, True)):
                for spp in args.burley_spp:
                    case = {"size": f"{w}x{h}", **time_burley(w, h, spp, mips, sampler, args.batches, args.batch,
                                                               args.cpu and not filtered, args.cpu_repeats, filtered)}
                    result["burley"].append(case)
                    print(json.dumps(case), file=sys.stderr, flush=True)
    print(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
