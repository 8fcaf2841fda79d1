"""Xie 2020's headline, adaptive sampling within 0.1-0.3 dB of a fixed 64 spp with TAA: what ssskit measures, and why.

Xie et al. 2020 (Sec. 6, Figs. 10-11) report the final PSNR (TAA output against a 2k-spp reference) of the
adaptive pass (sigma0^2 = 0.001, kappa = 0.2, b = [8, 64]) within 0.13-0.31 dB of fixed 64 spp (close skin
patch 40.26 vs 40.39 dB; Buddha 40.2 vs 40.51 dB at sigma0^2 = 1e-4). ssskit's figures (``xie-fig10``,
``xie-fig11``: the shadow-edge plane, 24 still frames, the final PSNR the mean of the last quarter, frames
19-24) give a gap of several dB. This script measures, on the same plane, per seed:

* **window**: the gap in the 24-frame window (frames 19-24, what the figures report) and in late windows
  (frames 49-72 and 73-96 of a 96-frame run: the TAA's weight on frame 24 is then 0.9^48 < 1 % and the
  adaptive history's 0.8^48 ~ 0); a run's first 24 frames are those of a 24-frame run (the frame number keys
  the samples), so the windows come from one run;
* **start**: the adaptive run with 64 spp on its first frame (``disocclusion_spp=64``, where the history is
  missing; the rest unchanged), which isolates the cold start's part of the 24-frame window;
* **history weighting**: the TAA's current-frame weight alpha 0.04 (Unreal's default
  ``r.TemporalAACurrentFrameWeight``) beside 0.1 (ssskit's default, Karis 2014);
* **mips**: Xie's prefiltered irradiance (Eqs. 22-23, a = 1/16) on both runs, against the same no-mips limit;
* **jitter** (the camera motion of every frame of Xie's figures, which render in Unreal with its TAA):
  each frame's camera is offset by the 8-sample Halton(2, 3) sub-pixel jitter of Unreal's TAA, the plane's
  pattern rendered at the jittered pixel centres, the TAA blending the jittered frames without motion
  (the camera did not move), against the unjittered limit. The jitter's own error (the TAA run on the
  jittered limits) is the floor that caps both runs, as Xie's fixed 64 spp reaches only 40.39-40.51 dB
  with TAA from 32.9-36.0 dB single-frame; once with the pattern point-sampled (aliased: a low floor) and
  once anti-aliased (4 x 4 samples per pixel: a higher floor, nearer Xie's).

``--scene NAME`` runs the still variants (window, start, history weighting, mips) on a built-in scene's
still frame instead (Skin1, 160x120, PSNR of the composite inside the SSS mask against the exact sampler at
2048 spp without mips): the jittered variants need the scene rendered through a jittered camera, which this
script does not do.

Every run: ssskit's frame loop (:func:`ssskit.screenspace.frames.run_frames`), numba, the exact sampler,
R2, no mips unless said (so the pass's limit :func:`ssskit.pipeline.burley_frame.burley_exact` is the reference, exact);
PSNR over the whole 160x90 plane (albedo 1, no specular). Seeds: the Burley pass's seed. Prints one JSON
object (per distance and variant: the gap per seed, mean and sample standard deviation).

    NUMBA_THREADING_LAYER=workqueue PYTHONPATH=src python experiments/adaptive_gap.py --seeds 0 1 2
        [--sigma0-sq 1e-4 --kappa 0] [--variants still jittered] [--scene slab --first 0] [--scene head --view close]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from typing import Any

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numpy as np  # noqa: E402

from ssskit.screenspace.taa import taa_jitter  # noqa: E402  (Unreal's Halton(2, 3) x 8 sub-pixel offsets)

#: Xie 2020 Sec. 6 / Fig. 1: sigma0^2, kappa, b_min, b_max
XIE = {"sigma0_sq": 1e-3, "kappa": 0.2, "b_min": 8, "b_max": 64}
#: frames of the runs, and the windows (1-based, inclusive): the figures' 24-frame window and two late ones
FRAMES = 96
WINDOWS = {"frames 19-24": (19, 24), "frames 49-72": (49, 72), "frames 73-96": (73, 96)}


def jittered_plane(width: int, height: int, distance: str, jx: float, jy: float, area: int = 1):
    """:func:`ssskit.figures.adaptive.shadow_plane` with its pattern sampled at pixel centres moved by
    (jx, jy) pixels (jx = jy = 0, area = 1 gives the same G-buffer): the scene seen through a jittered camera.
    ``area`` > 1: the mean of area x area point samples across each pixel (a box-filtered, anti-aliased
    irradiance, as a rendered shadow's penumbra is smooth)."""
    from ssskit.figures.adaptive import shadow_plane

    gb = shadow_plane(width, height, distance)
    yy, xx = np.mgrid[0:height, 0:width]
    diffuse = np.zeros((height, width, 3), np.float64)
    offsets = [0.0] if area == 1 else [(k + 0.5) / area - 0.5 for k in range(area)]
    for ox in offsets:
        for oy in offsets:
            x = xx + jx + ox
            y = yy + jy + oy
            lit = (x >= width // 2) | ((x - width / 4) ** 2 + (y - height / 2) ** 2 < (height / 5) ** 2)
            diffuse += np.where(lit, 0.8, 0.05)[..., None]
    return gb.with_layers(diffuse=(diffuse / len(offsets) ** 2).astype(np.float32))


def final(values: list[float], window: tuple[int, int]) -> float:
    return float(np.mean(values[window[0] - 1:window[1]]))


def run(gbuffers, score, params, *, adaptive: dict | None, seed: int, taa_alpha: float,
        disocclusion_spp: int | None = None, mips: bool = False) -> list[float]:
    """``score`` (the PSNR of an image) of every frame's TAA output (fixed 64 spp, or ``adaptive`` settings)."""
    from ssskit.screenspace import BurleySettings
    from ssskit.screenspace.adaptive import AdaptiveSettings
    from ssskit.screenspace.frames import run_frames
    from ssskit.screenspace.taa import TAASettings

    out: list[float] = []
    bs = BurleySettings(sampler="exact", sequence="r2", mips=mips, seed=seed, backend="numba")
    run_frames(gbuffers, params, bs, adaptive=AdaptiveSettings(**adaptive) if adaptive else None,
               spp=None if adaptive else 64, taa=TAASettings(alpha=taa_alpha),
               disocclusion_spp=disocclusion_spp if adaptive else None,
               on_frame=lambda f: out.append(score(f.image_taa)))
    return out


def taa_floor(gbuffers, limits, score, taa_alpha: float) -> list[float]:
    """The TAA run on the frames' exact limits (no Monte Carlo noise): its own error, per frame."""
    from ssskit.screenspace.taa import TAASettings, TemporalAA

    t = TemporalAA(TAASettings(alpha=taa_alpha))
    return [score(t.resolve(gb.composite(lim))) for gb, lim in zip(gbuffers, limits)]


def scene_source(scene: str, first: int, size: tuple[int, int], log, view: str | None = None):
    """A built-in scene's still frame ``first`` (Skin1, :func:`ssskit.pipeline.sequence.sequence_gbuffers`), its
    Burley parameters and the PSNR inside its SSS mask of a composite against the converged reference (the
    exact sampler at 2048 spp without mips, two cached halves: :func:`~ssskit.pipeline.sequence.sequence_references`)."""
    from ssskit.materials import MATERIALS
    from ssskit.pipeline.sequence import sequence_gbuffers, sequence_references
    from ssskit.screenspace.burley import burley_params_for_material

    mat = MATERIALS.get("skin1")
    params = burley_params_for_material(mat)
    if view is None:
        gb = sequence_gbuffers(scene, "skin1", 1, first, width=size[0], height=size[1], static=True,
                               progress=log)[0]
    else:  # a named view (the head's close, ear, front), rendered here (not cached)
        from ssskit.scenes import render_gbuffer, resolve_scene

        log(f"G-buffer {scene}, view {view} ({size[0]}x{size[1]}, 64 spp, Mitsuba)")
        gb = render_gbuffer(resolve_scene(scene, view=view).spec, np.clip(params.albedo, 0.0, 1.0), eta=mat.eta,
                            width=size[0], height=size[1], spp=64, frame=first, material=mat.name)
    ref = gb.composite(sequence_references([gb], params, spp=2048, progress=log)[0].sss)
    mask = gb.mask
    peak = float(ref[mask].max())

    def score(image) -> float:  # 20 log10(peak / RMSE) inside the mask, as ssskit render reports frames
        err = (np.asarray(image, np.float64) - ref)[mask]
        return 20.0 * math.log10(peak / math.sqrt(float(np.mean(err * err))))

    return gb, params, score


def spread(values: list[float]) -> dict[str, Any]:
    return {"mean": round(statistics.fmean(values), 3),
            "sd": round(statistics.stdev(values), 3) if len(values) > 1 else None,
            "min": round(min(values), 3), "max": round(max(values), 3), "per_seed": [round(v, 3) for v in values]}


def study(distance: str, seeds: list[int], size: tuple[int, int], frames: int, setting: dict, names: list[str] | None,
          log, scene: str | None = None, first: int = 0, view: str | None = None) -> dict[str, Any]:
    """The variants on the shadow plane at ``distance``, or (``scene``) on a built-in scene's still frame
    ``first`` (no jittered variants: those need the scene rendered through a jittered camera)."""
    from ssskit.figures.adaptive import plane_params, shadow_plane
    from ssskit.metrics import psnr
    from ssskit.pipeline.burley_frame import burley_exact

    if scene is not None:
        gb, params, score = scene_source(scene, first, size, log, view)
        names = [n for n in (names or ["still"]) if "jitter" not in n and "anti-aliased" not in n] or ["still"]
    else:
        params = plane_params()
        gb = shadow_plane(*size, distance)
        ref = burley_exact(gb, params)
        score = lambda image: psnr(ref, image)  # noqa: E731
    still = [gb] * frames
    if scene is not None:
        jit8 = area8 = []
        limits = {}
    else:
        limits = {id(gb): ref}
        # the jitter repeats every 8 frames: the same 8 G-buffer objects in turn (each new to the loop)
        jit8 = [jittered_plane(*size, distance, *taa_jitter(f)) for f in range(8)]
        area8 = [jittered_plane(*size, distance, *taa_jitter(f), area=4) for f in range(8)]
        for g in jit8 + area8:
            limits[id(g)] = burley_exact(g, params)
    jit_gbs = [jit8[f % 8] for f in range(frames)] if jit8 else []
    area_gbs = [area8[f % 8] for f in range(frames)] if area8 else []
    variants = {
        "still, TAA alpha 0.1 (the figures)": dict(gbs=still, alpha=0.1),
        "still, TAA alpha 0.1, 64 spp on the first frame": dict(gbs=still, alpha=0.1, disocclusion_spp=64),
        "still, TAA alpha 0.04 (Unreal's weight)": dict(gbs=still, alpha=0.04),
        "still, TAA alpha 0.1, mips (a = 1/16)": dict(gbs=still, alpha=0.1, mips=True),
        "jittered (Halton 2,3 x 8), TAA alpha 0.1": dict(gbs=jit_gbs, alpha=0.1),
        "jittered (Halton 2,3 x 8), TAA alpha 0.04": dict(gbs=jit_gbs, alpha=0.04),
        "jittered, anti-aliased pattern (4x4 per pixel), TAA alpha 0.1": dict(gbs=area_gbs, alpha=0.1),
    }
    out: dict[str, Any] = {}
    for name, v in variants.items():
        if names is not None and not any(n in name for n in names):
            continue
        fixed_runs, adaptive_runs = [], []
        for seed in seeds:
            log(f"{distance}: {name}, seed {seed}")
            fixed_runs.append(run(v["gbs"], score, params, adaptive=None, seed=seed, taa_alpha=v["alpha"],
                                  mips=v.get("mips", False)))
            adaptive_runs.append(run(v["gbs"], score, params, adaptive=setting, seed=seed, taa_alpha=v["alpha"],
                                     disocclusion_spp=v.get("disocclusion_spp"), mips=v.get("mips", False)))
        floor = (taa_floor(v["gbs"], [limits[id(g)] for g in v["gbs"]], score, v["alpha"]) if scene is None
                 else [math.nan] * frames)
        row: dict[str, Any] = {}
        for wname, win in WINDOWS.items():
            if win[1] > frames:
                continue
            f = [final(r, win) for r in fixed_runs]
            a = [final(r, win) for r in adaptive_runs]
            row[wname] = {"fixed64_db": spread(f), "adaptive_db": spread(a),
                          "gap_db": spread([x - y for x, y in zip(f, a)]),
                          "taa_floor_db": round(final(floor, win), 3) if math.isfinite(final(floor, win)) else None}
        out[name] = row
        log(json.dumps({"distance": scene or distance, "variant": name,
                        **{k: {"gap_db": r["gap_db"]["mean"], "sd": r["gap_db"]["sd"],
                               "fixed64_db": r["fixed64_db"]["mean"], "adaptive_db": r["adaptive_db"]["mean"],
                               "taa_floor_db": r["taa_floor_db"]} for k, r in row.items()}}))
    return out


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    ap.add_argument("--distances", nargs="+", default=["regular", "close"], choices=["regular", "close"])
    ap.add_argument("--size", default="160x90")
    ap.add_argument("--frames", type=int, default=FRAMES)
    ap.add_argument("--sigma0-sq", type=float, default=XIE["sigma0_sq"])
    ap.add_argument("--kappa", type=float, default=XIE["kappa"])
    ap.add_argument("--scene", default=None, help="a built-in scene's still frame instead of the plane (Skin1, "
                    "160x120 by default; the still variants only)")
    ap.add_argument("--first", type=int, default=0, help="--scene: the frame of its camera path")
    ap.add_argument("--view", default=None, help="--scene: one of its named views (the head's close, ear, front)")
    ap.add_argument("--variants", nargs="+", default=None,
                    help="run only the variants whose name contains one of these words (default: all)")
    args = ap.parse_args(argv)
    setting = {**XIE, "sigma0_sq": args.sigma0_sq, "kappa": args.kappa}
    w, h = (int(v) for v in args.size.lower().split("x"))
    if args.scene is not None and args.size == "160x90":
        w, h = 160, 120
    t0 = time.perf_counter()
    load0 = os.getloadavg()

    def log(msg: str) -> None:
        print(f"[{time.perf_counter() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)

    result = {"experiment": "adaptive (Xie's sigma0^2 = 1e-3, kappa 0.2, [8, 64]) vs fixed 64 spp with TAA: windows, "
                            "start, history weighting, jitter",
              "adaptive": setting, "size": [w, h], "frames": args.frames, "seeds": args.seeds,
              "sampler": "exact, r2, no mips unless said",
              "reference": ("the exact sampler at 2048 spp, no mips (inside the SSS mask, composite)" if args.scene
                            else "burley_exact (the pass's exact limit) of the unjittered plane"),
              "distances": ({args.scene: study(args.scene, args.seeds, (w, h), args.frames, setting, args.variants, log,
                                                scene=args.scene, first=args.first, view=args.view)}
                            if args.scene is not None
                            else {d: study(d, args.seeds, (w, h), args.frames, setting, args.variants, log)
                                  for d in args.distances}),
              "seconds": round(time.perf_counter() - t0, 1),
              "load_average": {"before": load0, "after": os.getloadavg()}}
    print(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
