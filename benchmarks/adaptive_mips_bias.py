"""Bias of the prefiltered mips (Xie 2020 Eqs. 22-23, a = 1/16 in Xie's units) under the adaptive sampler
(Sec. 4.1) against fixed 64 spp (issue 14).

Eq. 22's mip level m = max(-log2(a n p(r) / (ell^2 t)), 0) / 2 depends on the pixel's sample count n:
fewer samples read a coarser level. So the adaptive pass, which takes fewer samples where the history's
variance is low, may read coarser levels than fixed 64 spp and carry more of the prefilter's bias. This
measures how much, on static G-buffers whose reference is exact:

* ``step``: the G-buffer of tests/screenspace/test_adaptive.py (32 x 32, 300 mm, 0.5 mm pixels, three
  flat patches), Burley albedo 0.8/0.6/0.4, dmfp 4/2.5/1.5 mm;
* ``plane``: the shadow-edge plane of the Xie figures (``ssskit.figures.adaptive.shadow_plane``, 160 x 90
  crop of 1080p's scale, 2.5 px per mm), albedo 0.8/0.5/0.3, dmfp 2/1/0.5 mm.

Per scene, mips on and off, ``--frames`` frames (exact sampler, random sequence so the frames are
independent, numba) of: the adaptive pass at each (sigma0^2, kappa) of ``--settings`` (b = [8, 64],
:func:`ssskit.screenspace.frames.adaptive_frames`), fixed 64 spp and fixed at the adaptive run's
mean count rounded up (the same loop with the budget [n, n]). Against the no-mips converged reference
(:func:`ssskit.pipeline.burley_frame.burley_exact`, the exact sampler's limit), inside the mask, all channels:

* ``mean_rmse`` / ``mean_psnr``: the average of the frames: the bias plus a noise floor ``noise_rms``
  (the RMS standard error of that average, from the spread across frames);
* ``bias_rms``: sqrt(max(mean_rmse^2 - noise_rms^2, 0)), the bias with the floor taken out;
* ``frame_rmse`` / ``frame_psnr``: the mean over frames of one frame's RMSE (noise + bias);
* ``vs_fixed64_rms`` / ``vs_fixed64_se``: the RMS distance of the average from fixed 64's average (same
  mips setting; independent seeds), and that over the RMS of the two averages' combined standard error
  (about 1: no difference beyond noise).

PSNR = 20 log10(peak / RMSE), peak the reference's maximum inside the mask. Prints one JSON object.

    python benchmarks/adaptive_mips_bias.py [--frames 128] [--settings 1e-4:0.2,1e-3:0.2] [--backend numba]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time

import numpy as np


def step_gbuffer(h: int = 32, w: int = 32):
    """tests/screenspace/test_adaptive.py::_step_gbuffer."""
    from ssskit.screenspace import Camera, GBuffer

    diffuse = np.full((h, w, 3), 0.05, np.float32)
    diffuse[:, w // 2:] = 0.8
    diffuse[h // 2:, : w // 4] = 0.4
    return GBuffer(diffuse=diffuse, albedo=np.ones((h, w, 3), np.float32), depth=np.full((h, w), 300.0, np.float32),
                   profile_id=np.ones((h, w), np.uint32), camera=Camera(w, h, 600.0, 600.0, w / 2, h / 2))


def stats(run, ref, mask) -> dict:
    peak = float(ref[mask].max())
    err = (run.mean - ref)[mask]
    mean_rmse = float(np.sqrt(np.mean(err**2)))
    noise = float(np.sqrt(np.mean(run.stderr[mask] ** 2)))
    frames = len(run.counts)
    # one frame's RMSE from the spread: E|frame - ref|^2 = bias^2 + per-frame variance (stderr^2 * frames)
    frame_rmse = float(np.sqrt(np.mean(err**2 + run.stderr[mask] ** 2 * frames)))
    return {"mean_spp": float(run.mean_spp.mean()), "mean_rmse": mean_rmse,
            "mean_psnr": 20 * math.log10(peak / mean_rmse), "noise_rms": noise,
            "bias_rms": math.sqrt(max(mean_rmse**2 - noise**2, 0.0)),
            "bias_psnr": 20 * math.log10(peak / max(math.sqrt(max(mean_rmse**2 - noise**2, 0.0)), 1e-30)),
            "frame_rmse": frame_rmse, "frame_psnr": 20 * math.log10(peak / frame_rmse)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=128)
    ap.add_argument("--settings", default="1e-4:0.2,1e-3:0.2", help="sigma0^2:kappa pairs")
    ap.add_argument("--backend", default="numba")
    ap.add_argument("--scenes", default="step,plane")
    args = ap.parse_args()

    from ssskit.figures.adaptive import plane_params, shadow_plane
    from ssskit.pipeline.burley_frame import burley_exact
    from ssskit.screenspace import BurleyParams, BurleySettings
    from ssskit.screenspace.adaptive import AdaptiveSettings
    from ssskit.screenspace.frames import adaptive_frames

    scenes = {"step": (step_gbuffer(), BurleyParams.from_dmfp((0.8, 0.6, 0.4), (4.0, 2.5, 1.5))),
              "plane": (shadow_plane(160, 90), plane_params())}
    settings = [tuple(float(v) for v in pair.split(":")) for pair in args.settings.split(",")]
    t0 = time.perf_counter()
    out = {}
    for name in args.scenes.split(","):
        gb, params = scenes[name]
        ref = burley_exact(gb, params)
        mask = gb.mask
        rows = {}
        for mips in (True, False):
            b = BurleySettings(sampler="exact", sequence="random", mips=mips, backend=args.backend)
            runs = {}

            def go(label, a):  # every run its own seed: independent of the others
                runs[label] = adaptive_frames(gb, params, a, args.frames, burley=b.replace(seed=len(runs) + 3),
                                              backend=args.backend)

            go("fixed 64", AdaptiveSettings(b_min=64, b_max=64))
            for s0, k in settings:
                label = f"adaptive {s0:g}, {k:g}"
                go(label, AdaptiveSettings(sigma0_sq=s0, kappa=k, b_min=8, b_max=64))
                n = int(math.ceil(runs[label].mean_spp.mean()))
                if f"fixed {n}" not in runs:
                    go(f"fixed {n}", AdaptiveSettings(b_min=n, b_max=n))
            f64 = runs["fixed 64"]
            for label, run in runs.items():
                row = stats(run, ref, mask)
                d = (run.mean - f64.mean)[mask]
                se = np.sqrt(np.mean(run.stderr[mask] ** 2 + f64.stderr[mask] ** 2))
                row["vs_fixed64_rms"] = float(np.sqrt(np.mean(d**2)))
                row["vs_fixed64_se"] = row["vs_fixed64_rms"] / float(se) if se > 0 else None
                rows[f"{label}, {'mips' if mips else 'no mips'}"] = row
        out[name] = {"size": list(gb.shape[::-1]), "rows": rows}
    print(json.dumps({
        "benchmark": "bias of the prefiltered mips (Xie Eqs. 22-23, a = 1/16) with adaptive counts vs fixed 64 spp",
        "frames": args.frames, "backend": args.backend, "sampler": "exact", "sequence": "random", "budget": [8, 64],
        "reference": "burley_exact (no mips)", "scenes": out, "seconds": time.perf_counter() - t0,
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(), "load_avg": os.getloadavg()},
    }, indent=1))


if __name__ == "__main__":
    main()
