"""Xie 2020's headline on the scanned head (issue 35, Build 4): adaptive sampling against a fixed 64 spp with TAA,
the camera jittered as Xie's engine renders every frame. Regenerates docs/head_adaptive.json and the table of
docs/head.md (between its "adaptive" markers).

    nice -n 10 python docs/head_adaptive.py [--quick] [--views close ear front] [--seeds 0 1 2]
        [--size 128x96] [--frames 64] [--texture 0.16] [--json docs/head_adaptive.json] [--md docs/head.md]
        [--runs jittered unclamped still textured textured-unclamped] [--taa-alpha 0.1] [--taa-filter]
        [--sampler-fixed exact|xie|golubev] [--sampler-adaptive exact|xie|golubev] [--mips]
        [--correction variance|sigma] [--metric rgb|gray] [--decompose]
    nice -n 15 python docs/head_adaptive.py --texture 0.16 --factors [I ...] \
        --json docs/head_adaptive_factors.json --md docs/head.md

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

**The remainder's factors** (``--factors``, issue 35: adaptive trails fixed 64 by 0.40 dB on the textured close
patch, Xie by 0.13 dB): the textured, jittered close run with one thing changed at a time (:data:`FACTORS`): the
global TAA's current-frame weight (UE4's ``r.TemporalAACurrentFrameWeight`` default is 0.04, PostProcessTemporalAA.cpp;
Xie's alpha_0 = 0.2 is their guiding pass's, Sec. 5, which ssskit's history already uses), the neighbourhood clamp,
the sampler (Eq. 21 against the exact inverse CDF), the prefiltered mips of Xie's pass (Eqs. 22-23: fewer samples
fetch coarser levels), Eq. 15 as printed, Xie's gray-scale PSNR, and UE4's TAA reconstruction filter of the current
frame (:class:`FilteredTAA`: a 3x3 Gaussian, sigma 0.47 px, of the jittered samples, as PostProcessTemporalAA.cpp
weights them), alone and together, each with the split of the error into the floor F, the noise N and their cross
term X (view_study's ``decompose``): the additive model is X = 0. Regenerates docs/head_adaptive_factors.json and
the factors table of docs/head.md (between its "adaptive factors" markers); some factors (``--factors 9 10``) are
merged into an existing JSON of the same set-up.
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


#: UE4's TAA reconstruction filter of the current frame (PostProcessTemporalAA.cpp, r.TemporalAAFilterSize 1):
#: weights exp(-2.29 |o|^2) (a normal distribution, sigma 0.47 px) of the 3x3 jittered samples at offsets o
UE4_FILTER_K = 2.29


def ue4_filter_weights(jitter: tuple[float, float]) -> np.ndarray:
    """(3, 3) weights (rows dy = -1, 0, 1; columns dx), summing to 1, of the current frame's 3x3 neighbourhood that
    UE4's TAA blends in place of the pixel itself (Karis 2014's reconstruction filter; UE4 PostProcessTemporalAA.cpp:
    exp(-2.29 |o|^2), o the offset from the unjittered pixel centre to a neighbour's jittered sample). Here a frame
    rendered with ``pixel_jitter`` j shows at pixel k what the unjittered camera sees at k + j (``textured``), so
    o = (dx + jx, dy + jy)."""
    d = np.arange(-1.0, 2.0)
    ox, oy = d[None, :] + jitter[0], d[:, None] + jitter[1]
    w = np.exp(-UE4_FILTER_K * (ox * ox + oy * oy))
    return w / w.sum()


class FilteredTAA:
    """ssskit's TAA (:func:`ssskit.screenspace.taa.taa_resolve`: the history clamped to the current frame's 3x3 box
    in YCoCg, then blended with weight alpha) with UE4's reconstruction filter: the blend takes the current frame's
    3x3 jittered samples weighted by :func:`ue4_filter_weights` instead of the pixel alone (the box is still the
    unfiltered samples', as UE4's). No motion (the camera does not move); ``valid`` False: the history dropped."""

    def __init__(self, settings: Any) -> None:
        self.settings = settings
        self.history: np.ndarray | None = None

    def resolve(self, current: np.ndarray, jitter: tuple[float, float], valid: np.ndarray | None = None) -> np.ndarray:
        from ssskit.screenspace.taa import neighbourhood_box, rgb_to_ycocg, ycocg_to_rgb

        cur = rgb_to_ycocg(np.asarray(current, np.float64))
        pad = np.pad(cur, ((1, 1), (1, 1), (0, 0)), mode="edge")
        hh, ww = cur.shape[:2]
        w = ue4_filter_weights(jitter)
        filt = sum(w[dy, dx] * pad[dy:dy + hh, dx:dx + ww] for dy in range(3) for dx in range(3))
        if self.history is None:
            out = filt
        else:
            prev = rgb_to_ycocg(self.history)
            if self.settings.neighbourhood != "none":
                low, high = neighbourhood_box(cur, self.settings.neighbourhood, self.settings.gamma)
                prev = np.clip(prev, low, high)
            a = np.full((hh, ww), self.settings.alpha) if valid is None else np.where(valid, self.settings.alpha, 1.0)
            out = (1.0 - a)[..., None] * prev + a[..., None] * filt
        self.history = np.maximum(ycocg_to_rgb(out), 0.0).astype(np.float32)
        return self.history


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


#: the runs :func:`view_study` can make (``runs``), by short name; "textured" ones need ``texture``
RUNS = ("jittered", "unclamped", "still", "textured", "textured-unclamped")


def view_study(view: str, seeds: list[int], size: tuple[int, int], frames: int, limit_spp: int, gbuffer_spp: int,
               say: Callable[[str], None], texture: float = 0.0, *, runs: list[str] | None = None,
               taa_alpha: float = 0.1, samplers: dict[str, str] | None = None, mips: bool = False,
               correction: str = "variance", metric: str = "rgb", decompose: bool = False,
               taa_filter: bool = False) -> dict[str, Any]:
    """The jittered and still runs of one view (module docstring).

    The factors of the remainder (``--factors``), each one change from the default run: ``runs`` (short names
    of :data:`RUNS`; None: jittered, unclamped, still and, with ``texture``, textured); ``taa_alpha`` the global
    TAA's current-frame weight (Karis 2014; UE4's r.TemporalAACurrentFrameWeight 0.04; Xie's alpha_0 = 0.2 is
    their guiding pass's); ``samplers`` the radius sampler per method ({"fixed64": ..., "adaptive": ...}: exact,
    xie (Eq. 21) or golubev; the truth stays the exact limit); ``mips`` the prefiltered pyramid (Eqs. 22-23) for
    both runs; ``correction`` the adaptive's Eq. 15 form ("sigma": as printed); ``metric`` "rgb" (the linear
    PSNR of the composite) or "gray" (Xie's gray-scale PSNR on the display, :func:`ssskit.metrics.display_psnr`);
    ``decompose``: per window and method the mean squared errors (over the SSS pixels' RGB, in units of the
    peak squared) of the floor F (floor - truth), of the noise N (run - floor) and their cross term
    X = 2 mean((floor - truth)(run - floor)), so that run - truth has F + N + X exactly: the additive model is
    X = 0. ``taa_filter``: the TAA with UE4's reconstruction filter of the current frame (:class:`FilteredTAA`),
    for the floor and both runs."""
    from ssskit.figures.head import head_spec
    from ssskit.figures.views import study_gbuffer
    from ssskit.pipeline.burley_frame import burley_reference
    from ssskit.screenspace import BurleySettings
    from ssskit.screenspace.adaptive import AdaptiveSettings
    from ssskit.screenspace.frames import run_frames
    from ssskit.screenspace.taa import TAASettings, TemporalAA, reprojection_valid

    from ssskit.metrics import display_psnr

    w, h = size
    base = head_spec(view)
    samplers = {"fixed64": "exact", "adaptive": "exact", **(samplers or {})}

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
        if metric == "gray":
            g = display_psnr(ref, image, mask)
            return math.inf if g is None else g
        err = (np.asarray(image, np.float64) - ref)[mask]
        mse = float(np.mean(err * err))
        return 20.0 * math.log10(peak / math.sqrt(mse)) if mse > 0 else math.inf  # inf: the still floor

    jittered = [jit[f % JITTER_FRAMES].gbuffer for f in range(frames)]
    clamped, unclamped = TAASettings(alpha=taa_alpha), TAASettings(alpha=taa_alpha, neighbourhood="none")
    seqs = {"jittered": (jittered, clamped, still.gbuffer),
            "jittered, TAA unclamped": (jittered, unclamped, still.gbuffer),
            "still": ([still.gbuffer] * frames, clamped, still.gbuffer)}
    limit_of = {id(s.gbuffer): lim for s, lim in zip(jit, lims)}
    limit_of[id(still.gbuffer)] = lim0
    if texture:  # the skin's albedo textured (pores), each frame's at the surface points its jittered pixels see
        tex = {f: textured(s.gbuffer, taa_jitter(f, JITTER_FRAMES), texture) for f, s in enumerate(jit)}
        tex_still = textured(still.gbuffer, (0.0, 0.0), texture)
        for f, g in tex.items():
            limit_of[id(g)] = lims[f]
        limit_of[id(tex_still)] = lim0
        tex_frames = [tex[f % JITTER_FRAMES] for f in range(frames)]
        seqs[f"jittered, textured skin ({texture:g})"] = (tex_frames, clamped, tex_still)
        seqs[f"jittered, textured skin ({texture:g}), TAA unclamped"] = (tex_frames, unclamped, tex_still)
    short = dict(zip(seqs, ("jittered", "unclamped", "still", "textured", "textured-unclamped")))
    wanted = runs if runs is not None else ["jittered", "unclamped", "still"] + (["textured"] if texture else [])
    seqs = {k: v for k, v in seqs.items() if short[k] in wanted}
    out: dict[str, Any] = {"view": view, "pixels": int(mask.sum()), "runs": {}}
    for name, (gbs, taa, truth_gb) in seqs.items():
        truth = truth_gb.composite(lim0).astype(np.float64)
        peak = float(truth[mask].max())
        # the TAA run on the noise-free frames (the limits), exactly as run_frames runs it: no motion (the camera
        # does not move), and where a frame's G-buffer is new its depth test against the previous one
        # (reprojection_valid) drops the history of the pixels it rejects: the jitter's own error, frame by frame
        resolver, kept = TemporalAA(taa), TemporalAA(taa)  # kept: the same without the depth test (all history kept)
        if taa_filter:
            resolver, kept = FilteredTAA(taa), FilteredTAA(taa)
        jitters = [(0.0, 0.0) if name == "still" else taa_jitter(f, JITTER_FRAMES) for f in range(len(gbs))]
        valids: list[np.ndarray | None] = []
        floor_out: list[np.ndarray] = []
        floor_kept: list[float] = []
        rejected: list[float] = []
        prev = None
        for gb, jitter in zip(gbs, jitters):
            valid = None
            if gb is not prev and prev is not None:
                valid = reprojection_valid(gb.depth, gb.camera, prev.depth, prev.camera)
                rejected.append(float(1.0 - valid[mask].mean()))
            frame = gb.composite(limit_of[id(gb)])
            if taa_filter:
                floor_out.append(resolver.resolve(frame, jitter, valid).astype(np.float64))
                floor_kept.append(psnr(kept.resolve(frame, jitter), truth))
            else:
                floor_out.append(resolver.resolve(frame, None, valid).astype(np.float64))
                floor_kept.append(psnr(kept.resolve(frame), truth))
            valids.append(valid)
            prev = gb
        floor = [psnr(x, truth) for x in floor_out]
        per: dict[str, list[list[float]]] = {"fixed64": [], "adaptive": []}
        per_floorless: dict[str, list[list[float]]] = {"fixed64": [], "adaptive": []}
        #: per method, seed and frame: (F, N, X) of ``decompose`` (docstring)
        parts: dict[str, list[list[tuple[float, float, float]]]] = {"fixed64": [], "adaptive": []}
        spp_used: list[float] = []
        for seed in seeds:
            for method in ("fixed64", "adaptive"):
                say(f"{view}: {name}, {method}, seed {seed}")
                a: list[float] = []
                b: list[float] = []
                n: list[float] = []
                fnx: list[tuple[float, float, float]] = []

                own = FilteredTAA(taa) if taa_filter else None  # the TAA run here, on the pass's frames

                def on_frame(fr: Any, a: list[float] = a, b: list[float] = b, n: list[float] = n,
                             fnx: list[tuple[float, float, float]] = fnx, own: Any = own) -> None:
                    if own is not None:
                        fr.image_taa = own.resolve(fr.image, jitters[fr.index], valids[fr.index])
                    a.append(psnr(fr.image_taa, truth))
                    b.append(psnr(fr.image_taa, floor_out[fr.index]))
                    n.append(float(fr.counts[fr.gbuffer.mask].mean()))
                    if decompose:
                        ef = (floor_out[fr.index] - truth)[mask] / peak
                        en = (np.asarray(fr.image_taa, np.float64) - floor_out[fr.index])[mask] / peak
                        fnx.append((float(np.mean(ef * ef)), float(np.mean(en * en)), 2.0 * float(np.mean(ef * en))))

                run_frames(gbs, params, BurleySettings(sampler=samplers[method], sequence="r2", mips=mips, seed=seed,
                                                        backend="numba"),
                           adaptive=AdaptiveSettings(**XIE, correction=correction) if method == "adaptive" else None,
                           spp=None if method == "adaptive" else 64, taa=None if taa_filter else taa,
                           on_frame=on_frame)
                parts[method].append(fnx)
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
            if decompose:  # window means over frames, then over seeds, of F, N, X per method
                d = {m: [statistics.fmean(float(np.mean([fr[i] for fr in s[lo - 1:hi]])) for s in parts[m])
                         for i in range(3)] for m in parts}
                fa, na, xa = d["adaptive"]
                ff, nf, xf = d["fixed64"]
                row[wname]["mse"] = {m: dict(zip(("floor", "noise", "cross"), d[m])) for m in d}
                row[wname]["gap_from_mse_db"] = 10.0 * math.log10((fa + na + xa) / (ff + nf + xf))
                row[wname]["gap_from_mse_additive_db"] = 10.0 * math.log10((fa + na) / (ff + nf))
                row[wname]["gap_from_mse_seeds_db"] = [
                    10.0 * math.log10(sum(float(np.mean([fr[i] for fr in sa[lo - 1:hi]])) for i in range(3))
                                      / sum(float(np.mean([fr[i] for fr in sf[lo - 1:hi]])) for i in range(3)))
                    for sa, sf in zip(parts["adaptive"], parts["fixed64"])]
        out["runs"][name] = {"windows": row, "adaptive_mean_spp_late": statistics.fmean(spp_used),
                             "taa_rejected": statistics.fmean(rejected) if rejected else 0.0}
    return out


def compute(views: list[str], seeds: list[int], size: tuple[int, int], frames: int, limit_spp: int,
            gbuffer_spp: int, say: Callable[[str], None] = print, texture: float = 0.0,
            **options: Any) -> dict[str, Any]:
    """The study of each view; ``options``: :func:`view_study`'s factors (recorded where given)."""
    t0 = time.time()
    load0 = os.getloadavg()
    rows = [view_study(v, seeds, size, frames, limit_spp, gbuffer_spp, say, texture, **options) for v in views]
    extra = {"options": options} if options else {}
    return {**extra, "experiment": "Xie 2020's adaptive vs fixed 64 spp with TAA on the head, jittered camera",
            "adaptive": XIE, "xie_close": XIE_CLOSE, "size": list(size), "frames": frames, "seeds": seeds,
            "limit_spp": limit_spp, "gbuffer_spp": gbuffer_spp, "texture": texture,
            "jitter": [taa_jitter(f, JITTER_FRAMES) for f in range(JITTER_FRAMES)],
            "pass": "exact sampler, r2, no mips, numba; TAA alpha 0.1, no motion", "views": rows,
            "seconds": time.time() - t0,
            "machine": _machine(load0)}


def _machine(load0: tuple[float, float, float]) -> dict[str, Any]:
    """The machine a run had: its cores, platform and load average before (``load0``) and now."""
    return {"cpus": os.cpu_count(), "platform": platform.platform(), "load_avg_before": load0,
            "load_avg_after": os.getloadavg()}


def _ran(n: dict[str, Any]) -> str:
    """The table's first line: the command, its wall time on the machine's cores and the load average around it."""
    return (f"`{n['command']}`: {n['seconds']:.0f} s on {n['machine']['cpus']} cores, load average "
            f"{n['machine']['load_avg_before'][0]:.1f}-{n['machine']['load_avg_after'][0]:.1f}; ")


def _floor(db: float) -> str:
    """The TAA floor as shown: none where the frames' limits are all one image (still: only float rounding)."""
    return "none" if db > 150 else f"{db:.2f}"


def table(n: dict[str, Any]) -> str:
    """The markdown table of docs/head.md from the numbers."""
    late = f"frames {n['frames'] - 23}-{n['frames']}"
    lines = [_ran(n) + f"{n['size'][0]} x {n['size'][1]}, {n['frames']} frames, seeds {', '.join(map(str, n['seeds']))}, "
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


#: the factors of the remainder (``--factors``): one change each from the textured, jittered run (view_study)
FACTORS: list[tuple[str, dict[str, Any]]] = [
    ("today's run (TAA alpha 0.1, min/max clamp, exact sampler, no mips, linear RGB PSNR)", {}),
    ("TAA alpha 0.04 (UE4's r.TemporalAACurrentFrameWeight)", {"taa_alpha": 0.04}),
    ("TAA alpha 0.2 (Xie's alpha_0)", {"taa_alpha": 0.2}),
    ("TAA unclamped", {"runs": ["textured-unclamped"]}),
    ("adaptive with Eq. 21 (Xie's sampler), fixed 64 exact", {"samplers": {"adaptive": "xie"}}),
    ("both runs Eq. 21", {"samplers": {"adaptive": "xie", "fixed64": "xie"}}),
    ("both runs with the prefiltered mips (Eqs. 22-23)", {"mips": True}),
    ("adaptive with Eq. 15 as printed (sigma form)", {"correction": "sigma"}),
    ("gray-scale display PSNR (Xie Sec. 6)", {"metric": "gray"}),
    ("UE4's TAA reconstruction filter (3x3 Gaussian, sigma 0.47 px)", {"taa_filter": True}),
    ("UE4's TAA: the filter and alpha 0.04", {"taa_filter": True, "taa_alpha": 0.04}),
    ("UE4's TAA (the filter, alpha 0.04) and the mips", {"taa_filter": True, "taa_alpha": 0.04, "mips": True}),
    ("TAA unclamped and the mips", {"runs": ["textured-unclamped"], "mips": True}),
    # the filter blurs the pores: at texture 0.113 (0.16 / sqrt 2, half the floor's error) its floor is Xie's again
    ("UE4's TAA filter, texture 0.113", {"taa_filter": True, "texture": 0.113}),
    ("UE4's TAA (the filter, alpha 0.04), texture 0.113", {"taa_filter": True, "taa_alpha": 0.04, "texture": 0.113}),
    ("UE4's TAA (the filter, alpha 0.04) and the mips, texture 0.113",
     {"taa_filter": True, "taa_alpha": 0.04, "mips": True, "texture": 0.113}),
    ("the same, gray-scale display PSNR", {"taa_filter": True, "taa_alpha": 0.04, "mips": True, "texture": 0.113,
                                           "metric": "gray"}),
]
FBEGIN, FEND = "<!-- adaptive factors: docs/head_adaptive.py --factors -->", "<!-- end of adaptive factors -->"


def factors(seeds: list[int], size: tuple[int, int], frames: int, limit_spp: int, texture: float,
            only: list[int] | None = None, say: Callable[[str], None] = print) -> dict[str, Any]:
    """Each of :data:`FACTORS` (or those numbered in ``only``) on the close view, textured and jittered, with the
    error decomposition (view_study's ``decompose``)."""
    t0 = time.time()
    load0 = os.getloadavg()
    rows = []
    for i, (name, opts) in enumerate(FACTORS):
        if only is not None and i not in only:
            continue
        opts = {"runs": ["textured"], **opts}
        say(f"factor {i}: {name}")
        t1 = time.time()
        tex = opts.pop("texture", texture)
        v = view_study("close", seeds, size, frames, limit_spp, 64, say, tex, decompose=True, **opts)
        opts["texture"] = tex
        (run,) = v["runs"].values()
        rows.append({"factor": i, "name": name, "options": opts, "run": run, "seconds": time.time() - t1,
                     "load_avg_after": os.getloadavg()})
    return {"experiment": "the adaptive-vs-fixed remainder on the close patch (textured, jittered): one factor "
            "changed at a time", "adaptive": XIE, "xie_close": XIE_CLOSE, "size": list(size), "frames": frames,
            "seeds": seeds, "limit_spp": limit_spp, "texture": texture, "rows": rows, "seconds": time.time() - t0,
            "machine": _machine(load0)}


def factor_table(n: dict[str, Any]) -> str:
    """The markdown table of the factors (docs/head.md, between :data:`FBEGIN` and :data:`FEND`)."""
    late = f"frames {n['frames'] - 23}-{n['frames']}"
    lines = [_ran(n) + f"close view, texture {n['texture']:g}, {n['size'][0]} x {n['size'][1]}, {n['frames']} frames, seeds "
             f"{', '.join(map(str, n['seeds']))}, window {late.replace('frames ', '')}.", "",
             "Per factor (one change from today's run): final PSNR (dB) of fixed 64 and adaptive, the TAA floor, the "
             "gap (mean +- SD over seeds), the additive model's gap, and the mean squared errors (units of 1e-5 of "
             "the peak squared) of the floor F, of each run's noise N (run - floor) and their cross term "
             "X = 2 <floor - truth, run - floor> (run - truth = F + N + X exactly; the model is X = 0); adaptive's "
             "mean spp.", "",
             "| factor | fixed 64 | adaptive | TAA floor | gap | model | F | N fixed | N adaptive | X fixed | "
             "X adaptive | adaptive spp |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in n["rows"]:
        x = r["run"]["windows"][late]
        m = x["mse"]
        sd = x["gap_db"]["sd"]
        lines.append(f"| {r['name']} | {x['fixed64_db']['mean']:.2f} | {x['adaptive_db']['mean']:.2f} | "
                     f"{_floor(x['floor_db'])} | {x['gap_db']['mean']:.2f}" + (f" +- {sd:.2f}" if sd is not None else "")
                     + f" | {x['gap_model_db']:.2f} | {1e5 * m['fixed64']['floor']:.3f} | "
                     f"{1e5 * m['fixed64']['noise']:.3f} | {1e5 * m['adaptive']['noise']:.3f} | "
                     f"{1e5 * m['fixed64']['cross']:+.3f} | {1e5 * m['adaptive']['cross']:+.3f} | "
                     f"{r['run']['adaptive_mean_spp_late']:.1f} |")
    return "\n".join(lines) + "\n"


def _replace_block(md: Path, begin: str, end: str, body: str) -> None:
    text = md.read_text()
    if begin not in text:
        raise SystemExit(f"{md} has no {begin} marker")
    new = f"{begin}\n{body}{end}"
    md.write_text(re.sub(re.escape(begin) + ".*?" + re.escape(end), lambda m: new, text, flags=re.S))


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--views", nargs="+", default=None, choices=["close", "ear", "front"])
    ap.add_argument("--seeds", nargs="+", type=int, default=None)
    ap.add_argument("--size", default=None)
    ap.add_argument("--frames", type=int, default=None)
    ap.add_argument("--texture", type=float, default=0.0, help="also a jittered run with the skin's albedo "
                    "textured (skin_texture) at this contrast (relative SD); 0: none")
    ap.add_argument("--taa-alpha", type=float, default=0.1, help="the global TAA's current-frame weight (0, 1]")
    ap.add_argument("--sampler-fixed", default="exact", choices=["exact", "xie", "golubev"])
    ap.add_argument("--sampler-adaptive", default="exact", choices=["exact", "xie", "golubev"])
    ap.add_argument("--mips", action="store_true", help="both runs fetch from the prefiltered mips (Eqs. 22-23)")
    ap.add_argument("--correction", default="variance", choices=["variance", "sigma"])
    ap.add_argument("--metric", default="rgb", choices=["rgb", "gray"])
    ap.add_argument("--runs", nargs="+", default=None, choices=list(RUNS))
    ap.add_argument("--taa-filter", action="store_true", help="the TAA with UE4's reconstruction filter (FilteredTAA)")
    ap.add_argument("--decompose", action="store_true", help="the floor / noise / cross-term split of each error")
    ap.add_argument("--factors", nargs="*", type=int, default=None, metavar="I",
                    help="the remainder's factors on the close view (all, or those numbered), with --texture")
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
    if not 0.0 < args.taa_alpha <= 1.0:
        ap.error(f"--taa-alpha must be in (0, 1] (the current frame's TAA weight), got {args.taa_alpha}")
    if any(r.startswith("textured") for r in args.runs or []) and not args.texture:
        ap.error("--runs textured... needs --texture C > 0")
    if args.factors is not None:
        if not args.texture:
            ap.error("--factors needs --texture C > 0 (the textured run)")
        if any(not 0 <= i < len(FACTORS) for i in args.factors):
            ap.error(f"--factors takes numbers 0..{len(FACTORS) - 1}")
        n = factors(seeds, (int(w), int(h)), frames, 256 if q else 2048, args.texture, args.factors or None)
        n["command"] = "python docs/head_adaptive.py " + " ".join(sys.argv[1:] if argv is None else argv)
        old = json.loads(Path(args.json).read_text()) if args.json and Path(args.json).is_file() else None
        same = ("size", "frames", "seeds", "limit_spp", "texture")
        if args.factors and old and all(old.get(k) == n[k] for k in same):  # some factors rerun: the others kept
            done = {r["factor"] for r in n["rows"]}
            n["rows"] = sorted([r for r in old["rows"] if r["factor"] not in done] + n["rows"],
                               key=lambda r: r["factor"])
            n["seconds"] = sum(r["seconds"] for r in n["rows"])
            n["command"] = "python docs/head_adaptive.py --texture " + f"{args.texture:g} --factors" + (
                f" --json {args.json}" if args.json else "") + (f" --md {args.md}" if args.md else "")
            n["machine"]["load_avg_before"] = old["machine"]["load_avg_before"]
        if args.json:
            Path(args.json).write_text(json.dumps(n, indent=1) + "\n")
        if args.md:
            _replace_block(Path(args.md), FBEGIN, FEND, factor_table(n))
        print(json.dumps({k: n[k] for k in ("seconds", "machine")}, indent=1))
        return n
    options: dict[str, Any] = {}
    for key, default in (("taa_alpha", 0.1), ("mips", False), ("correction", "variance"), ("metric", "rgb"),
                         ("runs", None), ("decompose", False), ("taa_filter", False)):
        if getattr(args, key) != default:
            options[key] = getattr(args, key)
    if (args.sampler_fixed, args.sampler_adaptive) != ("exact", "exact"):
        options["samplers"] = {"fixed64": args.sampler_fixed, "adaptive": args.sampler_adaptive}
    n = compute(views, seeds, (int(w), int(h)), frames, 256 if q else 2048, 64, say=print, texture=args.texture,
                **options)
    n["quick"] = q
    n["command"] = "python docs/head_adaptive.py " + " ".join(sys.argv[1:] if argv is None else argv)
    if args.json:
        Path(args.json).write_text(json.dumps(n, indent=1) + "\n")
    if args.md:
        _replace_block(Path(args.md), BEGIN, END, table(n))
    print(json.dumps({k: n[k] for k in ("seconds", "machine")}, indent=1))
    return n


if __name__ == "__main__":
    main()
