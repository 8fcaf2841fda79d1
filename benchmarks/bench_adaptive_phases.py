"""Benchmark: the adaptive sampler's guiding phase on numpy vs numba vs gl, and the per-phase times of a frame
(Xie 2020 Fig. 8 / Table 1: prefilter, sampling, history update, combine), all in the same run.

Part ``guide``: the guiding phase alone (:mod:`ssskit.backends.adaptive_plan`) at each size, on a history
that holds history everywhere, a random frame result and counts in [8, 64]; the *update* entry point
(reproject + Eqs. 6, 8, 9 + next counts), static and with motion vectors + a validity image, and the
*estimate* entry point with motion: ``ms_host`` is the backend method on host arrays (on gl that includes
the upload and the readback); for gl also ``ms_device``: the shader alone on images already on the
device (``time_gpu``: GL_TIME_ELAPSED on a GPU, wall time around glFinish on llvmpipe).

Part ``phases``: frames of the Burley pass with adaptive counts through each backend's AdaptiveRunner on a
static G-buffer (bench_adaptive's half-lit plane; exact sampler, R2 sequence, mips on as in Xie 2020):
median ms per frame of estimate (first frame; later frames take the counts the update made), prefilter
(the mip pyramid), sampling (the Burley pass), update (history + next counts) and combine (albedo x
result + specular, numpy, on the read-back result); on gl also the readback of the result. The numpy
Burley pass (the float64 oracle) is too slow for this and is left out of it by default.

Prints one JSON object. NUMBA_THREADING_LAYER is set to 'workqueue' unless given.

    python benchmarks/bench_adaptive_phases.py [--sizes 480x270,1920x1080] [--backends numpy,numba,gl]
        [--phase-sizes 480x270] [--phase-backends numba,gl] [--frames 8] [--repeats 7]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def _size(text: str) -> tuple[int, int]:
    w, h = (int(v) for v in text.lower().split("x"))
    return w, h


def _median_ms(fn, repeats: int) -> float:
    fn()  # warm up (compile)
    out = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        out.append(1e3 * (time.perf_counter() - t))
    return statistics.median(out)


def guide_inputs(w: int, h: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    hist = np.zeros((h, w, 4), np.float32)
    hist[..., 0] = rng.uniform(8, 64, (h, w))
    hist[..., 1] = rng.random((h, w))
    hist[..., 2] = rng.uniform(0, 3e-3, (h, w))
    hist[..., 3] = 1.0
    mask = np.ones((h, w), bool)
    motion = rng.normal(0, 2, (h, w, 2))
    valid = rng.random((h, w)) > 0.01
    rgb = rng.random((h, w, 3), dtype=np.float32)
    counts = rng.integers(8, 65, (h, w))
    return hist, mask, motion, valid, rgb, counts


def bench_guide(name: str, w: int, h: int, plan, repeats: int) -> dict:
    from ssskit.backends import get_backend

    b = get_backend(name)
    hist, mask, motion, valid, rgb, counts = guide_inputs(w, h)
    out = {
        "update_static": {"ms_host": _median_ms(lambda: b.adaptive_update(plan, hist, rgb, counts, mask), repeats)},
        "update_moving": {"ms_host": _median_ms(
            lambda: b.adaptive_update(plan, hist, rgb, counts, mask, motion, valid), repeats)},
        "estimate_moving": {"ms_host": _median_ms(lambda: b.adaptive_counts(plan, hist, mask, motion, valid),
                                                  repeats)},
    }
    if name == "gl":
        from ssskit.backends.gl.adaptive import GuideImages, _texture, dispatch
        from ssskit.backends.gl.context import context, time_gpu

        ctx = context()
        size = (w, h)
        rgba = np.zeros((h, w, 4), np.float32)
        rgba[..., :3] = rgb
        src, dst = _texture(ctx, size, 4, "f4", hist), _texture(ctx, size, 4, "f4")
        cnt = _texture(ctx, size, 1, "i4", counts.astype(np.int32))
        res = _texture(ctx, size, 4, "f4", rgba)
        still, moving = GuideImages(ctx, mask), GuideImages(ctx, mask, motion, valid)
        try:
            batches = max(3, repeats)
            out["update_static"]["ms_device"] = statistics.median(
                time_gpu(lambda: dispatch(plan, still, src, cnt, res, dst), batches=batches, batch=2))
            out["update_moving"]["ms_device"] = statistics.median(
                time_gpu(lambda: dispatch(plan, moving, src, cnt, res, dst), batches=batches, batch=2))
            out["estimate_moving"]["ms_device"] = statistics.median(
                time_gpu(lambda: dispatch(plan, moving, src, cnt), batches=batches, batch=2))
        finally:
            for obj in (src, dst, cnt, res, still, moving):
                obj.release()
    return out


def bench_phases(name: str, w: int, h: int, settings, frames: int) -> dict:
    from bench_adaptive import gbuffer

    from ssskit.screenspace import BurleyParams, BurleySettings
    from ssskit.screenspace.frames import run_frames

    gb = gbuffer(w, h)
    params = BurleyParams.from_dmfp((0.8, 0.5, 0.3), (2.0, 1.0, 0.5))
    bs = BurleySettings(sampler="exact", mips=True, backend=name)

    def run(n: int):
        combine: list[float] = []

        def on_frame(frame) -> None:  # the combine step after the loop's readback
            t = time.perf_counter()
            gb.composite(frame.sss)
            combine.append(1e3 * (time.perf_counter() - t))

        r = run_frames([gb] * n, params, bs, adaptive=settings, on_frame=on_frame)
        return r.phases, combine, r.mean_spp

    run(1)  # compile / warm up
    times, combine, spp = run(frames)
    med = {p: (statistics.median(v[1:] if len(v) > 1 else v) if any(v) else None) for p, v in times.items()
           if p != "readback"}
    med["estimate"] = times["estimate"][0] if times["estimate"] else None
    med["combine"] = statistics.median(combine[1:])
    if name == "gl":
        med["readback"] = statistics.median(times["readback"][1:])
    return {"ms_median": med, "mean_spp_per_frame": [round(v, 2) for v in spp],
            "note": "medians over frames 2..N; estimate: frame 1 only (a static camera); the library's frame loop "
                    "(ssskit.screenspace.frames.run_frames)"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="480x270,1920x1080")
    ap.add_argument("--backends", default="numpy,numba,gl")
    ap.add_argument("--phase-sizes", default="480x270")
    ap.add_argument("--phase-backends", default="numba,gl")
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--sigma0-sq", type=float, default=1e-3)
    ap.add_argument("--kappa", type=float, default=0.2)
    args = ap.parse_args()
    from ssskit.backends import backend_status
    from ssskit.backends.adaptive_plan import as_plan
    from ssskit.screenspace.adaptive import AdaptiveSettings

    settings = AdaptiveSettings(sigma0_sq=args.sigma0_sq, kappa=args.kappa)
    plan = as_plan(settings)
    status = backend_status()
    names = [n for n in args.backends.split(",") if n]
    skipped = {n: status[n]["details"] for n in names if not status[n]["available"]}
    guide = {}
    for size in args.sizes.split(","):
        w, h = _size(size)
        guide[size] = {n: bench_guide(n, w, h, plan, args.repeats) for n in names if n not in skipped}
    phases = {}
    for size in [s for s in args.phase_sizes.split(",") if s]:
        w, h = _size(size)
        phases[size] = {n: bench_phases(n, w, h, settings, args.frames)
                        for n in args.phase_backends.split(",") if n and n not in skipped}
    print(json.dumps({
        "machine": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
        "load_average": os.getloadavg(), "renderer": status.get("gl", {}).get("details"),
        "settings": settings.to_dict(), "history_format": "(H, W, 4) float32 / RGBA32F, 16 bytes per pixel",
        "skipped": skipped, "guide": guide, "phases": phases,
    }))


if __name__ == "__main__":
    main()
