"""The transmittance pass against the path trace and MCML (docs/transmission.md, "Against the path trace"):
prints one JSON object per run.

    python benchmarks/transmission_truth.py slab [--thickness 0.5 1 2 4 8] [--view 45] [--size 48x36]
    python benchmarks/transmission_truth.py leaf [--view 45] [--size 96x72]
    python benchmarks/transmission_truth.py ear [--models ...] [--passes separable burley] [--size 160x120]

``slab``: Skin1 slabs (the built-in ``backlit`` scene cut to each thickness, :func:`ssskit.scenes.backlit
.backlit_slab`) lit from behind at normal incidence; per thickness and channel the *level* pi L / E (L the
radiance leaving the seen face, E the lit face's irradiance: the G-buffer's back irradiance, light x -N . L)
over the pixels within 15 mm of the slab's centre, of the pass (``ssskit render --transmission on
--transmission-spread mcml``: the MCML model, its lateral spread) and of the path-traced reference
(:func:`ssskit.scenes.render_reference`, rendered until its relative standard error there is 1 % or
``--max-spp`` is spent), with MCML's scattered transmittance
T_s(t) (independent runs: other seeds) and MCML's radiance at the camera's exit angle (Tt_a: what the
reference should see); each cell within 5 % or 3 standard errors or not. ``leaf``: the built-in ``leaf`` scene
(Apple), its pixels by the pass's thickness along the normal (rim < 0.4 mm, flank, middle >= 1 mm), the pass's
and the reference's level per region. ``ear``: the built-in ear lit from behind, the region table (silhouette
band, shadow edge: :func:`ssskit.pipeline.regions.compare_regions`) of the separable and the Burley pass with
the transmittance pass of each model against the converged reference (4096 spp), per channel with its SE:
the models are the registry's (:data:`ssskit.pipeline.settings.TRANSMISSION_MODELS`, so an engine model added
there is measured too) and HDRP's shape (:func:`ssskit.export.transmission.hdrp_model`, the tint fitted to the
material's MCML table, d that of the diffusion profile ``ssskit export`` writes for Unity), each with and without the lateral spread, and the MCML model
as it was before (MCML's whole Tt along the light's chord, no spread), and UE's model with the transmission fields
``ssskit export --format unreal`` writes (fitted to MCML's scattered T_s; its ScatteringDistribution and IOR).

Everything is cached (the MCML runs, the references): a second run takes seconds.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from typing import Any

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numpy as np  # noqa: E402

WITHIN = 0.05  # the bound: 5 % or 3 standard errors


def _size(text: str) -> tuple[int, int]:
    w, h = (int(v) for v in text.lower().split("x"))
    return w, h


def _within(a: float, b: float, se: float) -> bool:
    return bool(abs(a - b) <= max(WITHIN * abs(b), 3.0 * se))


def back_irradiance(gb: Any) -> np.ndarray:
    """(H, W, 3) the irradiance of the back face behind each pixel as the pass takes it: light x clamp(-N . L)."""
    _, _, ndl, light = gb.transmission_inputs()
    return light * np.clip(-ndl, 0.0, 1.0)[..., None]


def level(radiance: np.ndarray, e_back: np.ndarray, region: np.ndarray, se: np.ndarray | None = None
          ) -> tuple[np.ndarray, np.ndarray | None]:
    """pi mean(L) / mean(E) over ``region`` per channel, and its SE from the per-pixel SEs (in quadrature)."""
    n = int(region.sum())
    e = e_back[region].mean(axis=0)
    lev = math.pi * radiance[region].astype(np.float64).mean(axis=0) / e
    if se is None:
        return lev, None
    return lev, math.pi * np.sqrt(np.sum(se[region].astype(np.float64) ** 2, axis=0)) / n / e


def view_cosines(gb: Any, normal: np.ndarray) -> np.ndarray:
    """(H, W) cos of the angle between ``normal`` and the direction from each pixel's surface point to the camera."""
    cam = gb.camera
    origin = np.linalg.inv(np.asarray(cam.world_to_camera))[:3, 3]
    d = origin - gb.positions()
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return d @ np.asarray(normal, float)


def _reference(spec: Any, material: Any, gb: Any, region: np.ndarray, args: argparse.Namespace) -> Any:
    from ssskit.scenes import render_reference

    h, w = region.shape
    return render_reference(spec, material, w, h, spp=args.min_spp, max_spp=args.max_spp,
                            target_rel_se=args.rel_se, region=region, seed=args.seed, progress=args.progress)


def _pass(spec: Any, material: str, args: argparse.Namespace) -> Any:
    from ssskit.pipeline import RenderSettings, render

    w, h = _size(args.size)
    return render(spec, RenderSettings(material=material, width=w, height=h, spp=args.gbuffer_spp, transmission="on",
                                       transmission_spread="mcml", backend=args.backend, exact=False,
                                       perceptual=False))


def run_slab(args: argparse.Namespace) -> dict[str, Any]:
    from ssskit.materials import get_material
    from ssskit.profiles.montecarlo import simulate
    from ssskit.profiles.montecarlo.slab import slab_config
    from ssskit.profiles.montecarlo.transmission import absorber_transmittance
    from ssskit.scenes.backlit import backlit_slab

    mat = get_material("skin1")
    rows = []
    for i, t in enumerate(args.thickness):
        spec = backlit_slab(t, args.view)
        res = _pass(spec, "skin1", args)
        gb = res.gbuffer
        pos = gb.positions()
        region = gb.mask & (np.hypot(pos[..., 0], pos[..., 1]) <= 15.0)
        e_back = back_irradiance(gb)
        lev_pass, _ = level(res.transmitted, e_back, region)
        t0 = time.perf_counter()
        ref = _reference(spec, mat, gb, region, args)
        spec_layer = gb.specular if gb.specular is not None else np.zeros_like(ref.image)
        lev_ref, se_ref = level(np.asarray(ref.image) - spec_layer, e_back, region, ref.pixel_se)
        mu = view_cosines(gb, (0.0, 0.0, 1.0))[region]
        ts, ts_se, at, at_se = (np.zeros(3) for _ in range(4))
        for c in range(3):
            r = simulate(slab_config(mat, c, t, args.photons, 5000 + i))
            ts[c] = r.tt - float(absorber_transmittance(mat.sigma_t[c], t, mat.eta, mat.eta_ambient))
            ts_se[c] = r.tt_se
            vals = [r.tt_level_at(float(m)) for m in np.quantile(mu, (0.1, 0.3, 0.5, 0.7, 0.9))]
            at[c], at_se[c] = float(np.mean([v[0] for v in vals])), float(np.mean([v[1] for v in vals]))
        rows.append({
            "thickness_mm": t, "region_pixels": int(region.sum()), "view_deg_median": float(np.degrees(np.arccos(np.median(mu)))),
            "pass": lev_pass.tolist(), "path_traced": lev_ref.tolist(), "path_traced_se": se_ref.tolist(),
            "reference_spp": int(ref.spp), "reference_converged": bool(ref.converged),
            "reference_seconds": round(time.perf_counter() - t0, 1),
            "mcml_Ts": ts.tolist(), "mcml_Ts_se": ts_se.tolist(), "mcml_at_view": at.tolist(), "mcml_at_view_se": at_se.tolist(),
            "pass_vs_path_traced": [_within(lev_pass[c], lev_ref[c], se_ref[c]) for c in range(3)],
            "pass_vs_mcml_Ts": [_within(lev_pass[c], ts[c], ts_se[c]) for c in range(3)],
            "mcml_at_view_vs_path_traced": [_within(at[c], lev_ref[c], math.hypot(se_ref[c], at_se[c])) for c in range(3)],
        })
        print(json.dumps({"thickness_mm": t, "done": True}), file=sys.stderr, flush=True)
    return {"rows": rows}


def run_leaf(args: argparse.Namespace) -> dict[str, Any]:
    from ssskit.backends.numpy_backend import shadow_depth
    from ssskit.materials import get_material
    from ssskit.scenes.backlit import backlit_scene

    spec = backlit_scene("leaf", args.view)
    res = _pass(spec, "apple", args)
    gb = res.gbuffer
    uvz, shadow, ndl, _ = gb.transmission_inputs()
    with np.errstate(invalid="ignore"):
        t_n = (uvz[..., 2] - shadow_depth(shadow, uvz[..., 0], uvz[..., 1])) * np.clip(-ndl, 0.0, 1.0)
    t_n = np.where(np.isfinite(t_n) & gb.mask, t_n, 0.0)
    e_back = back_irradiance(gb)
    lit = gb.mask & (t_n > 1e-3) & (e_back[..., 0] > 0)
    regions = {"rim (t_n < 0.4 mm)": lit & (t_n < 0.4), "flank (0.4-1 mm)": lit & (t_n >= 0.4) & (t_n < 1.0),
               "middle (t_n >= 1 mm)": lit & (t_n >= 1.0)}
    ref = _reference(spec, get_material("apple"), gb, lit, args)
    spec_layer = gb.specular if gb.specular is not None else np.zeros_like(ref.image)
    out = {"reference_spp": int(ref.spp), "reference_converged": bool(ref.converged), "regions": {}}
    for name, m in regions.items():
        if not m.any():
            continue
        lp, _ = level(res.transmitted, e_back, m)
        lr, se = level(np.asarray(ref.image) - spec_layer, e_back, m, ref.pixel_se)
        out["regions"][name] = {"pixels": int(m.sum()), "mean_t_n_mm": float(t_n[m].mean()), "pass": lp.tolist(),
                                "path_traced": lr.tolist(), "path_traced_se": se.tolist(),
                                "ratio": (lp / lr).tolist(), "ratio_se": (lp / lr * se / lr).tolist(),
                                "within_5pct_or_3se": [_within(lp[c], lr[c], se[c]) for c in range(3)]}
    return out


def run_ear(args: argparse.Namespace) -> dict[str, Any]:
    from ssskit.errors import SsskitError
    from ssskit.export.engines import engine_parameters, fit_burley
    from ssskit.export.transmission import hdrp_model, hdrp_transmission
    from ssskit.materials import get_material
    from ssskit.pipeline import BurleyPass, RenderSettings, render
    from ssskit.pipeline.regions import compare_regions
    from ssskit.pipeline.settings import TRANSMISSION_MODELS
    from ssskit.pipeline.transmission import add_transmission
    from ssskit.profiles import profile_for_material
    from ssskit.screenspace.burley import burley_params_for_material
    from ssskit.screenspace.transmission import _mcml_table, mcml_model, unreal_model

    mat = get_material("skin1")
    w, h = _size(args.size)
    models = list(args.models or TRANSMISSION_MODELS) + (["hdrp-shape"] if "hdrp" not in TRANSMISSION_MODELS else [])
    d_hdrp = np.asarray(fit_burley(profile_for_material(mat, "montecarlo"))[1])  # ssskit export unity's profile
    hdrp = hdrp_transmission(_mcml_table(mat, 200_000, 101), d_hdrp)
    ue = engine_parameters(profile_for_material(mat, "montecarlo"), "unreal", mat, _mcml_table(mat, 200_000, 101))
    ue_t = ue["transmission"]  # ssskit export --format unreal's transmission fields
    ue_model = unreal_model(ue_t["scattering_distance_mm"], ue_t["TransmissionTintColor"], ue_t["ExtinctionScale"],
                            ue_t["NormalScale"], ue_t["WorldUnitScale"], ue_t["DistanceScale"])
    ue_phase = (float(ue_t["ScatteringDistribution"]), float(ue["IOR"]))
    out: dict[str, Any] = {"models": models, "hdrp": {k: hdrp[k] for k in ("transmissionTint", "thicknessRemap",
                                                                          "scattering_distance_mm")},
                           "unreal_export": {k: ue_t[k] for k in ("ExtinctionScale", "DistanceScale",
                                                                 "TransmissionTintColor", "ScatteringDistribution",
                                                                 "NormalScale")} | {"IOR": ue["IOR"]}, "tables": []}
    for pass_name in args.passes:
        base = dict(width=w, height=h, spp=args.gbuffer_spp, transmission="on", reference=True,
                    reference_spp=args.ear_spp, reference_max_spp=args.ear_spp, perceptual=False, backend=args.backend)
        if pass_name == "burley":
            base["pass_"] = BurleyPass(spp=args.burley_spp)
            profile = burley_params_for_material(mat).profile()
        else:
            profile = profile_for_material(mat, "montecarlo")
        res = render("ear", RenderSettings(**base))
        gb, ref = res.gbuffer, res.reference_info
        albedo = gb.albedo.astype(np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            refl = np.asarray(res.sss, np.float64) - np.where(albedo > 0, res.transmitted / albedo, 0.0)
        variants: list[tuple[str, str, Any]] = [(m, spread, None) for m in models for spread in ("mcml", "off")]
        variants.append(("mcml (before: whole Tt, light's chord)", "off",
                         {1: mcml_model(mat, part="total", along_normal=False)}))
        variants += [("unreal (exported fields)", spread, {1: ue_model}) for spread in ("mcml", "off")]
        variants.append(("none (reflectance alone)", "off", "none"))
        for label, spread, given in variants:
            if given == "none":
                sss = refl
            else:
                if label.startswith("hdrp"):
                    given = {1: hdrp_model(hdrp["transmissionTint"], d_hdrp)}
                settings = RenderSettings(**{**base, "transmission_model": label if given is None else "mcml",
                                             "transmission_spread": spread})
                try:
                    sss, _, _ = add_transmission(gb, refl, settings, {1: mat}, lambda s: None, given,
                                                 ue_phase if label.startswith("unreal (exported") else None)
                except SsskitError as e:
                    out["tables"].append({"pass": pass_name, "model": label, "spread": spread, "error": str(e)})
                    continue
            table = compare_regions(gb, profile, sss, None, ref)
            row: dict[str, Any] = {"pass": pass_name, "model": label, "spread": spread}
            for region in ("silhouette", "shadow_edge"):
                r = table["regions"][region]
                row[region] = {"pixels": r["pixels"], "ratio": r["screen_space_vs_path_traced"]["ratio"],
                               "se": r["screen_space_vs_path_traced"]["se"], "path_traced": r["path_traced"]["level"],
                               "path_traced_se": r["path_traced"]["se"]}
            out["tables"].append(row)
            print(json.dumps({"pass": pass_name, "model": label, "spread": spread, "done": True}), file=sys.stderr,
                  flush=True)
        out.setdefault("reference", ref.summary())
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", choices=("slab", "leaf", "ear"))
    ap.add_argument("--thickness", type=float, nargs="+", default=[0.5, 1.0, 2.0, 4.0, 8.0])
    ap.add_argument("--view", type=float, default=None, help="camera angle off the normal (degrees; default the scene's)")
    ap.add_argument("--size", default=None, help="image size WxH (default: slab 48x36, leaf 96x72, ear 160x120)")
    ap.add_argument("--gbuffer-spp", type=int, default=16)
    ap.add_argument("--backend", default="numba")
    ap.add_argument("--photons", type=int, default=400_000, help="MCML photons per (thickness, channel)")
    ap.add_argument("--rel-se", type=float, default=0.01, help="the reference's target relative SE over its region")
    ap.add_argument("--min-spp", type=int, default=256)
    ap.add_argument("--max-spp", type=int, default=32768)
    ap.add_argument("--ear-spp", type=int, default=4096, help="the ear reference's spp (fixed)")
    ap.add_argument("--burley-spp", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--models", nargs="+", default=None, help="transmission models (default: the registry's)")
    ap.add_argument("--passes", nargs="+", default=["separable", "burley"], choices=("separable", "burley"))
    ap.add_argument("--progress", action="store_true", help="the path tracer's progress bar on stderr")
    args = ap.parse_args()
    if args.size is None:
        args.size = {"slab": "48x36", "leaf": "96x72", "ear": "160x120"}[args.what]
    t0 = time.perf_counter()
    result = {"slab": run_slab, "leaf": run_leaf, "ear": run_ear}[args.what](args)
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    print(json.dumps({"what": args.what, "args": {k: v for k, v in vars(args).items()}, **result,
                      "seconds": round(time.perf_counter() - t0, 1), "load_after": load, "machine": platform.machine(),
                      "cpus": os.cpu_count()}, indent=1))


if __name__ == "__main__":
    main()
