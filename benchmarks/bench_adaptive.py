"""Benchmark: the variance-guided adaptive sampler (Xie 2020 Sec. 4.1) vs fixed counts, same run.

A static frame sequence of the Burley pass (:func:`ssskit.screenspace.frames.adaptive_frames`) on a
synthetic G-buffer with structure where adaptation matters: a fronto-parallel SSS plane, half of it lit
(0.8) and half in shadow (0.05) with a lit disk inside the shadow, a skin-like Burley material (albedo
0.8/0.5/0.3, dmfp 2.0/1.0/0.5 mm; about 2.5 pixels per mm at 1080p). Per frame: mean samples per pixel,
the pass's time and the guiding phase's time (counts estimate + history update, vectorised numpy,
float32 arithmetic on the (H, W, 4) float32 history), and the PSNR of the frame against the pass's limit
(:func:`ssskit.pipeline.burley_frame.burley_exact`). Competitors, same run and G-buffer: the pass at a fixed
spp at b_min, at b_max and at the adaptive run's mean count rounded up (equal samples): time and
single-frame PSNR. The guiding phase is also timed alone at 1920x1080 through the public, checking API.

Exact sampler, no mips (the pass's limit is then the reference). Timings are medians. Prints one JSON object.

    NUMBA_THREADING_LAYER is set to 'workqueue' unless given.
    python benchmarks/bench_adaptive.py [--size 480x270] [--frames 24] [--sigma0-sq 1e-4] [--kappa 0.2]
                                        [--backend numba] [--repeats 5]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numpy as np  # noqa: E402

FOCAL_1080P = 1000.0


def gbuffer(width: int, height: int):
    from ssskit.screenspace import Camera, GBuffer

    yy, xx = np.mgrid[0:height, 0:width]
    diffuse = np.full((height, width, 3), 0.05, np.float32)
    diffuse[xx >= width // 2] = 0.8
    disk = (xx - width / 4) ** 2 + (yy - height / 2) ** 2 < (height / 5) ** 2
    diffuse[disk] = 0.8
    f = FOCAL_1080P * width / 1920
    return GBuffer(diffuse=diffuse, albedo=np.ones_like(diffuse), depth=np.full((height, width), 400.0, np.float32),
                   profile_id=np.ones((height, width), np.uint32), camera=Camera(width, height, f, f, width / 2,
                                                                                 height / 2))


def psnr(ref: np.ndarray, img: np.ndarray) -> float:
    from ssskit.metrics import psnr as _psnr

    return float(_psnr(ref, img))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="480x270")
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--sigma0-sq", type=float, default=1e-4)
    ap.add_argument("--kappa", type=float, default=0.2)
    ap.add_argument("--budget", default="8:64")
    ap.add_argument("--backend", default="numba")
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    from ssskit.pipeline.burley_frame import burley_exact
    from ssskit.screenspace import BurleyParams, BurleySettings, burley_sss
    from ssskit.screenspace.frames import adaptive_frames
    from ssskit.screenspace.adaptive import (
        AdaptiveSettings,
        new_history,
        sample_counts,
        shading_value,
        update_history,
    )

    w, h = (int(v) for v in args.size.split("x"))
    b_min, b_max = (int(v) for v in args.budget.split(":"))
    gb = gbuffer(w, h)
    params = BurleyParams.from_dmfp((0.8, 0.5, 0.3), (2.0, 1.0, 0.5))
    settings = AdaptiveSettings(sigma0_sq=args.sigma0_sq, kappa=args.kappa, b_min=b_min, b_max=b_max)
    b = BurleySettings(sampler="exact", sequence="random", mips=False, backend=args.backend)
    ref = burley_exact(gb, params)

    burley_sss(gb, params, b, counts=np.full((h, w), b_min, np.int64))  # compile / warm up
    psnrs: list[float] = []
    run = adaptive_frames(gb, params, settings, args.frames, burley=b,
                          on_frame=lambda f, sss, counts: psnrs.append(psnr(ref, sss)))
    tail = slice(args.frames // 2, None)
    fixed = {}
    equal = int(np.ceil(run.mean_spp[tail].mean()))
    for spp in sorted({b_min, equal, b_max}):
        fixed_ms, fixed_psnr = [], []
        for f in range(args.repeats):
            t0 = time.perf_counter()
            out = burley_sss(gb, params, b.replace(frame=f), counts=np.full((h, w), spp, np.int64))
            fixed_ms.append(1e3 * (time.perf_counter() - t0))
            fixed_psnr.append(psnr(ref, out))
        fixed[str(spp)] = {"ms_pass_median": statistics.median(fixed_ms), "psnr_median": statistics.median(fixed_psnr)}

    # the guiding phase alone at 1080p (its cost does not depend on the counts)
    big = new_history(1080, 1920, available=True)
    big[..., 0], big[..., 1], big[..., 2] = 30.0, 0.5, 2e-4
    rgb = np.random.default_rng(0).random((1080, 1920, 3), dtype=np.float32)
    upd = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        counts, _ = sample_counts(big, settings)
        big2 = update_history(big, shading_value(rgb, settings.gamma), counts, settings)
        upd.append(1e3 * (time.perf_counter() - t0))
    assert big2.shape == (1080, 1920, 4)

    adaptive_ms = statistics.median(run.ms_pass[tail])
    print(json.dumps({
        "machine": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
        "backend": args.backend, "size": [w, h], "frames": args.frames, "settings": settings.to_dict(),
        "history_bytes_per_pixel": int(big.itemsize * big.shape[2]),
        "adaptive": {"mean_spp_per_frame": [round(float(v), 2) for v in run.mean_spp],
                     "psnr_per_frame": [round(v, 2) for v in psnrs],
                     "ms_pass_median_second_half": adaptive_ms,
                     "ms_update_median": statistics.median(run.ms_update),
                     "mean_spp_second_half": float(run.mean_spp[tail].mean()),
                     "psnr_median_second_half": statistics.median(psnrs[tail])},
        "fixed": fixed, "equal_samples_spp": equal,
        "speedup_pass_vs_b_max": fixed[str(b_max)]["ms_pass_median"] / adaptive_ms,
        "sample_ratio": b_max / float(run.mean_spp[tail].mean()),
        "update_1080p_ms_median": statistics.median(upd),
    }))


if __name__ == "__main__":
    main()
