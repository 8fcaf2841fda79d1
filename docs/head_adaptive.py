"""Xie 2020's headline on the scanned head (issue 35, Build 4): adaptive sampling against a fixed 64 spp with TAA,
the camera jittered as Xie's engine renders every frame. Regenerates docs/head_adaptive.json and the table of
docs/head.md (between its "adaptive" markers).

    nice -n 10 python docs/head_adaptive.py [--quick] [--views close ear front] [--seeds 0 1 2]
        [--size 128x96] [--frames 64] [--texture 0.16] [--json docs/head_adaptive.json] [--md docs/head.md]

What Xie et al. 2020 did (Sec. 3.2, 4.1.5, 6; Figs. 1, 10, 11): a still camera in UE4, whose TAA renders every
frame through a sub-pixel jittered projection (Karis 2014: "accumulate consecutive frames ... per jittered
pixel"; Xie's Eq. 5, the jittered pixel position p_i) and blends the frames (the history weight alpha_0 = 0.2 of
their guiding pass; the global TAA's own), final PSNR of the TAA output against a 2k-spp reference; adaptive
sigma0^2 = 0.001, kappa = 0.2, b = [8, 64] within 0.13 dB of fixed 64 spp on the close skin patch (40.26 vs
40.39 dB, Fig. 11). Here, per view of the head (close skin patch, ear, front: ``builtin/head.toml``), Skin1:

* **jittered**: frame f's G-buffer rendered (Mitsuba) through the camera moved by Unreal's TAA jitter, the
  8-frame Halton(2, 3) sub-pixel offset (:func:`ssskit.screenspace.taa.taa_jitter`; :attr:`ssskit.scenes.SceneSpec.pixel_jitter`), the
  8 G-buffers in turn; the camera does not move, so the TAA (ssskit's, Karis 2014, alpha = 0.1, no motion)
  blends the jittered frames as they come;
* **jittered, TAA unclamped**: the same with the TAA's neighbourhood clamp off (``neighbourhood = "none"``): what
  the clamp (Karis 2014's min/max box in YCoCg) does to the noisy frames;
* **still**: the unjittered G-buffer every frame (ssskit's figures' set-up), for comparison;
* with ``--texture C``: **jittered, textured skin**: the jittered run with the skin's albedo modulated by a
  band-limited 3D noise fixed to the surface (:func:`skin_texture`: relative SD C, wavelengths 0.5-2 mm, a
  stand-in for the pores of Xie's Digital Mike; the scan has no albedo map), so that the jitter's own error
  (the TAA floor) is set by a texture as in Xie's scenes; the truth is the unjittered frame with the same texture.

Both runs of a seed use the same pass: the exact sampler (inverse CDF), R2, no mips, numba; fixed: 64 spp per
pixel; adaptive: Xie's setting. The truth is the pass's **converged limit** (the exact sampler at 2048 spp, no
mips, :func:`ssskit.pipeline.burley_frame.burley_reference`), not the path trace: the limit is what the pass
converges to, so the PSNR measures only its Monte Carlo noise and the TAA (the path trace would add Burley's
profile against real transport, the same for both runs, and its own per-pixel noise). Scores: the PSNR of the
TAA output's composite inside the unjittered frame's SSS mask (peak: the reference's maximum there), against

* the **unjittered limit** (Xie's set-up: a still reference image): the jittered TAA has an error of its own
  even on noise-free frames (its ``floor``: the TAA run on the jittered frames' limits), which caps both runs;
* the **jittered limits through the same TAA** (the floor's output frame by frame): the jitter's own error
  removed, only the Monte Carlo noise after the jittered TAA is left.

Windows: the final PSNR is the mean over frames ``19-24`` (the figures' 24-frame window) and over the last 24
frames (late: the TAA's weight on frame 24 is then 0.9^40 < 2 %); the gap = fixed 64's final PSNR - adaptive's,
per seed (mean and sample SD over seeds). ``--quick``: a small case for the test (48 x 36, the front view, 32
frames, one seed, 256-spp limits).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import platform
import re
import statistics
import sys
import time
from pathlib import Path
from typing import Any, Callable

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numpy as np  # noqa: E402

from ssskit.screenspace.taa import taa_jitter  # noqa: E402

#: Xie 2020 Sec. 6 / Fig. 1: sigma0^2, kappa, b_min, b_max
XIE = {"sigma0_sq": 1e-3, "kappa": 0.2, "b_min": 8, "b_max": 64}
#: Xie 2020 Fig. 11 (close skin patch): final PSNR (TAA) of adaptive and of fixed 64 spp
XIE_CLOSE = {"adaptive_db": 40.26, "fixed64_db": 40.39}
BEGIN, END = "<!-- adaptive: docs/head_adaptive.py -->", "<!-- end of adaptive -->"
JITTER_FRAMES = 8


def skin_texture(points_mm: np.ndarray, contrast: float, waves: int = 32, seed: int = 0) -> np.ndarray:
    """(H, W) albedo factor 1 + contrast * n(p) of a band-limited 3D noise n (unit variance: ``waves`` plane waves
    of random directions, wavelengths 0.5-2 mm and phases, summed and scaled by sqrt(2 / waves)) at the surface
    points ``points_mm`` (H, W, 3): a stand-in for the pores of a skin albedo map (the scan has none), fixed to
    the surface, so that a jittered pixel sees the texture where its ray lands; clipped to [0.2, 1.8]."""
    rng = np.random.default_rng(seed)
    d = rng.standard_normal((waves, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    k = 2.0 * math.pi / rng.uniform(0.5, 2.0, waves)
    phase = rng.uniform(0.0, 2.0 * math.pi, waves)
    n = np.cos(points_mm @ (d * k[:, None]).T + phase).sum(axis=-1) * math.sqrt(2.0 / waves)
    return np.clip(1.0 + contrast * n, 0.2, 1.8)


def textured(gb: Any, jitter: tuple[float, float], contrast: float) -> Any:
    """``gb`` (rendered through the camera jittered by ``jitter`` pixels) with its SSS albedo times
    :func:`skin_texture` at the surface points its pixels see (the camera's principal point moved by the jitter)."""
    cam = dataclasses.replace(gb.camera, cx=gb.camera.cx - jitter[0], cy=gb.camera.cy - jitter[1])
    p = cam.unproject(np.where(np.isfinite(gb.depth), gb.depth, 1.0)) / cam.world_units_per_mm
    f = skin_texture(p, contrast)
    albedo = np.where(gb.mask[..., None], np.clip(gb.albedo * f[..., None], 0.0, 1.0), gb.albedo)
    return gb.with_layers(albedo=albedo.astype(np.float32))


def additive_gap(floor_db: float, fixed_db: float, adaptive_db: float) -> float:
    """The gap (dB) the two runs would show if their Monte Carlo errors (PSNR ``fixed_db``, ``adaptive_db``, the
    floor removed) and the TAA's own error (PSNR ``floor_db``) added as independent errors do (mean squared
    errors add): 10 log10((F + N_a) / (F + N_f)), each term 10^(-PSNR/10) of the same peak."""
    if math.isinf(floor_db):
        return fixed_db - adaptive_db
    f, nf, na = (10.0 ** (-x / 10.0) for x in (floor_db, fixed_db, adaptive_db))
    return 10.0 * math.log10((f + na) / (f + nf))


def _spread(values: list[float]) -> dict[str, Any]:
    return {"mean": statistics.fmean(values), "sd": statistics.stdev(values) if len(values) > 1 else None,
            "per_seed": values}


def view_study(view: str, seeds: list[int], size: tuple[int, int], frames: int, limit_spp: int, gbuffer_spp: int,
               say: Callable[[str], None], texture: float = 0.0) -> dict[str, Any]:
    """The jittered and still runs of one view (module docstring)."""
    from ssskit.figures.head import head_spec
    from ssskit.figures.views import study_gbuffer
    from ssskit.pipeline.burley_frame import burley_reference
    from ssskit.screenspace import BurleySettings
    from ssskit.screenspace.adaptive import AdaptiveSettings
    from ssskit.screenspace.frames import run_frames
    from ssskit.screenspace.taa import TAASettings, TemporalAA, reprojection_valid

    w, h = size
    base = head_spec(view)

    def scene(jitter: tuple[float, float]) -> Any:
        say(f"{view}: G-buffer, jitter ({jitter[0]:+.3f}, {jitter[1]:+.3f}) px, {w}x{h}, {gbuffer_spp} spp")
        return study_gbuffer(view, "skin1", w, h, spp=gbuffer_spp, scene=dataclasses.replace(base, pixel_jitter=jitter))

    still = scene((0.0, 0.0))
    params = still.params
    jit = [scene(taa_jitter(f, JITTER_FRAMES)) for f in range(JITTER_FRAMES)]
    say(f"{view}: converged limits ({limit_spp} spp, exact sampler, no mips)")
    lim0 = burley_reference(still.gbuffer, params, spp=limit_spp)
    lims = [burley_reference(s.gbuffer, params, spp=limit_spp) for s in jit]
    mask = still.gbuffer.mask
    peak = 1.0

    def psnr(image: np.ndarray, ref: np.ndarray) -> float:
        err = (np.asarray(image, np.float64) - ref)[mask]
        mse = float(np.mean(err * err))
        return 20.0 * math.log10(peak / math.sqrt(mse)) if mse > 0 else math.inf  # inf: the still floor

    jittered = [jit[f % JITTER_FRAMES].gbuffer for f in range(frames)]
    seqs = {"jittered": (jittered, TAASettings(alpha=0.1), still.gbuffer),
            "jittered, TAA unclamped": (jittered, TAASettings(alpha=0.1, neighbourhood="none"), still.gbuffer),
            "still": ([still.gbuffer] * frames, TAASettings(alpha=0.1), still.gbuffer)}
    limit_of = {id(s.gbuffer): lim for s, lim in zip(jit, lims)}
    limit_of[id(still.gbuffer)] = lim0
    if texture:  # the skin's albedo textured (pores), each frame's at the surface points its jittered pixels see
        tex = {f: textured(s.gbuffer, taa_jitter(f, JITTER_FRAMES), texture) for f, s in enumerate(jit)}
        tex_still = textured(still.gbuffer, (0.0, 0.0), texture)
        for f, g in tex.items():
            limit_of[id(g)] = lims[f]
        limit_of[id(tex_still)] = lim0
        seqs[f"jittered, textured skin ({texture:g})"] = ([tex[f % JITTER_FRAMES] for f in range(frames)],
                                                           TAASettings(alpha=0.1), tex_still)
    out: dict[str, Any] = {"view": view, "pixels": int(mask.sum()), "runs": {}}
    for name, (gbs, taa, truth_gb) in seqs.items():
        truth = truth_gb.composite(lim0).astype(np.float64)
        peak = float(truth[mask].max())
        # the TAA run on the noise-free frames (the limits), exactly as run_frames runs it: no motion (the camera
        # does not move), and where a frame's G-buffer is new its depth test against the previous one
        # (reprojection_valid) drops the history of the pixels it rejects: the jitter's own error, frame by frame
        resolver, kept = TemporalAA(taa), TemporalAA(taa)  # kept: the same without the depth test (all history kept)
        floor_out: list[np.ndarray] = []
        floor_kept: list[float] = []
        rejected: list[float] = []
        prev = None
        for gb in gbs:
            valid = None
            if gb is not prev and prev is not None:
                valid = reprojection_valid(gb.depth, gb.camera, prev.depth, prev.camera)
                rejected.append(float(1.0 - valid[mask].mean()))
            frame = gb.composite(limit_of[id(gb)])
            floor_out.append(resolver.resolve(frame, None, valid).astype(np.float64))
            floor_kept.append(psnr(kept.resolve(frame), truth))
            prev = gb
        floor = [psnr(x, truth) for x in floor_out]
        per: dict[str, list[list[float]]] = {"fixed64": [], "adaptive": []}
        per_floorless: dict[str, list[list[float]]] = {"fixed64": [], "adaptive": []}
        spp_used: list[float] = []
        for seed in seeds:
            for method in ("fixed64", "adaptive"):
                say(f"{view}: {name}, {method}, seed {seed}")
                a: list[float] = []
                b: list[float] = []
                n: list[float] = []

                def on_frame(fr: Any, a: list[float] = a, b: list[float] = b, n: list[float] = n) -> None:
                    a.append(psnr(fr.image_taa, truth))
                    b.append(psnr(fr.image_taa, floor_out[fr.index]))
                    n.append(float(fr.counts[fr.gbuffer.mask].mean()))

                run_frames(gbs, params, BurleySettings(sampler="exact", sequence="r2", mips=False, seed=seed,
                                                        backend="numba"),
                           adaptive=AdaptiveSettings(**XIE) if method == "adaptive" else None,
                           spp=None if method == "adaptive" else 64, taa=taa, on_frame=on_frame)
                per[method].append(a)
                per_floorless[method].append(b)
                if method == "adaptive":
                    spp_used.append(float(np.mean(n[-24:])))
        windows = {"frames 19-24": (19, 24), f"frames {frames - 23}-{frames}": (frames - 23, frames)}
        row: dict[str, Any] = {}
        for wname, (lo, hi) in windows.items():
            if hi > frames or lo < 1:
                continue

            def final(v: list[float], lo: int = lo, hi: int = hi) -> float:
                return float(np.mean(v[lo - 1:hi]))

            f64 = [final(v) for v in per["fixed64"]]
            ad = [final(v) for v in per["adaptive"]]
            f64b = [final(v) for v in per_floorless["fixed64"]]
            adb = [final(v) for v in per_floorless["adaptive"]]
            fl = final(floor)
            row[wname] = {"fixed64_db": _spread(f64), "adaptive_db": _spread(ad),
                          "gap_db": _spread([x - y for x, y in zip(f64, ad)]), "floor_db": fl,
                          "floor_without_depth_test_db": final(floor_kept),
                          "fixed64_floorless_db": _spread(f64b), "adaptive_floorless_db": _spread(adb),
                          "gap_floorless_db": _spread([x - y for x, y in zip(f64b, adb)]),
                          "gap_model_db": additive_gap(fl, statistics.fmean(f64b), statistics.fmean(adb)),
                          "gap_model_xie_floor_db": additive_gap(XIE_CLOSE["fixed64_db"], statistics.fmean(f64b),
                                                                 statistics.fmean(adb))}
        out["runs"][name] = {"windows": row, "adaptive_mean_spp_late": statistics.fmean(spp_used),
                             "taa_rejected": statistics.fmean(rejected) if rejected else 0.0}
    return out


def compute(views: list[str], seeds: list[int], size: tuple[int, int], frames: int, limit_spp: int,
            gbuffer_spp: int, say: Callable[[str], None] = print, texture: float = 0.0) -> dict[str, Any]:
    t0 = time.time()
    load0 = os.getloadavg()
    rows = [view_study(v, seeds, size, frames, limit_spp, gbuffer_spp, say, texture) for v in views]
    return {"experiment": "Xie 2020's adaptive vs fixed 64 spp with TAA on the head, jittered camera",
            "adaptive": XIE, "xie_close": XIE_CLOSE, "size": list(size), "frames": frames, "seeds": seeds,
            "limit_spp": limit_spp, "gbuffer_spp": gbuffer_spp, "texture": texture,
            "jitter": [taa_jitter(f, JITTER_FRAMES) for f in range(JITTER_FRAMES)],
            "pass": "exact sampler, r2, no mips, numba; TAA alpha 0.1, no motion", "views": rows,
            "seconds": time.time() - t0,
            "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "load_avg_before": load0,
                        "load_avg_after": os.getloadavg()}}


def _floor(db: float) -> str:
    """The TAA floor as shown: none where the frames' limits are all one image (still: only float rounding)."""
    return "none" if db > 150 else f"{db:.2f}"


def table(n: dict[str, Any]) -> str:
    """The markdown table of docs/head.md from the numbers."""
    late = f"frames {n['frames'] - 23}-{n['frames']}"
    lines = [f"`{n['command']}`: {n['seconds']:.0f} s on {n['machine']['cpus']} cores, load average "
             f"{n['machine']['load_avg_before'][0]:.1f}-{n['machine']['load_avg_after'][0]:.1f}; "
             f"{n['size'][0]} x {n['size'][1]}, {n['frames']} frames, seeds {', '.join(map(str, n['seeds']))}, "
             f"limits {n['limit_spp']} spp, G-buffers {n['gbuffer_spp']} spp.", "",
             "Final PSNR (dB, mean over seeds) of fixed 64 spp and adaptive (Xie: sigma0^2 = 1e-3, kappa = 0.2, "
             "[8, 64]) against the unjittered limit; the TAA floor (the same TAA run on the frames' limits), and that floor "
             "with the depth test off (every pixel's history kept); the gap "
             "(fixed - adaptive, mean +- SD over seeds) against the unjittered limit and against the floor's frames "
             "(floor removed: the Monte Carlo noise alone); the gap the additive model predicts from the floor and "
             "the floor-removed PSNRs, and at Xie's floor (40.39 dB, their fixed 64 on the close patch); the share "
             "of SSS pixels whose TAA history the depth test drops per frame; adaptive's mean spp (last 24 frames).",
             "",
             "| view | camera | window | fixed 64 | adaptive | TAA floor | floor without the depth test | gap | gap, floor "
             "removed | model | model at 40.39 dB | history dropped | adaptive spp |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]

    def pm(s: dict[str, Any]) -> str:
        return f"{s['mean']:.2f}" + (f" +- {s['sd']:.2f}" if s["sd"] is not None else "")

    for v in n["views"]:
        for cam in v["runs"]:
            r = v["runs"][cam]
            for wname in ("frames 19-24", late):
                x = r["windows"].get(wname)
                if x is None:
                    continue
                lines.append(f"| {v['view']} | {cam} | {wname.replace('frames ', '')} | {x['fixed64_db']['mean']:.2f} | "
                             f"{x['adaptive_db']['mean']:.2f} | {_floor(x['floor_db'])} | "
                             f"{_floor(x['floor_without_depth_test_db'])} | {pm(x['gap_db'])} | "
                             f"{pm(x['gap_floorless_db'])} | {x['gap_model_db']:.2f} | {x['gap_model_xie_floor_db']:.2f} | "
                             f"{100 * r['taa_rejected']:.1f} % | {r['adaptive_mean_spp_late']:.1f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--views", nargs="+", default=None, choices=["close", "ear", "front"])
    ap.add_argument("--seeds", nargs="+", type=int, default=None)
    ap.add_argument("--size", default=None)
    ap.add_argument("--frames", type=int, default=None)
    ap.add_argument("--texture", type=float, default=0.0, help="also a jittered run with the skin's albedo "
                    "textured (skin_texture) at this contrast (relative SD); 0: none")
    ap.add_argument("--json", default=None)
    ap.add_argument("--md", default=None)
    args = ap.parse_args(argv)
    q = args.quick
    views = args.views or (["front"] if q else ["close", "ear", "front"])
    seeds = args.seeds if args.seeds is not None else ([0] if q else [0, 1, 2])
    w, _, h = (args.size or ("48x36" if q else "128x96")).lower().partition("x")
    frames = args.frames or (32 if q else 64)
    if frames < 24:
        ap.error("--frames must be at least 24 (the 24-frame window)")
    n = compute(views, seeds, (int(w), int(h)), frames, 256 if q else 2048, 64, say=print, texture=args.texture)
    n["quick"] = q
    n["command"] = "python docs/head_adaptive.py " + " ".join(sys.argv[1:] if argv is None else argv)
    if args.json:
        Path(args.json).write_text(json.dumps(n, indent=1) + "\n")
    if args.md:
        md = Path(args.md)
        text = md.read_text()
        new = f"{BEGIN}\n{table(n)}{END}"
        if BEGIN not in text:
            raise SystemExit(f"{md} has no {BEGIN} marker")
        md.write_text(re.sub(re.escape(BEGIN) + ".*?" + re.escape(END), lambda m: new, text, flags=re.S))
    print(json.dumps({k: n[k] for k in ("seconds", "machine")}, indent=1))
    return n


if __name__ == "__main__":
    main()
