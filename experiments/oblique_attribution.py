"""The bumpy tile's G/B residual, measured: the flat-limit prediction from MCML for the tile's own
light and view angles, and the controlled path-traced experiment on a flat medium at those angles
(:mod:`lab.oblique`, issue 11).

Scaled 8x (:func:`lab.variants.scaled_scene`), the tile is flat within the profile's reach
and the red gap closes; what is left is how a flat medium lit at grazing incidence and seen at ~45
degrees differs from the model's Rd(0) E / pi. The script

1. tabulates MCML over the incidence angle (:func:`lab.oblique_table.oblique_table`,
   eta of the material with a smooth surface and with the references' rough one, and eta = 1);
2. predicts every region's level from the tile's per-pixel incidence and view angles (the G-buffer
   of the unscaled tile: the scaled one's image, normals and E / pi are the same; angles and E / pi
   taken at ``--subpixels`` x that many sub-pixels per pixel) and compares with
   the measured exact / reference ratios: k = 8 of the curvature experiment (rough dielectric) and
   k = 1 of the Fresnel experiment (index-matched), taken from ``--measured`` (the JSON that
   ``region_attribution.py`` prints) or, without it, measured here (``run_experiment``, k = 1 and 8,
   and the index-matched setup);
3. measures the rough dielectric's factor on a flat slab (:func:`lab.flat.flat_scene`) at
   the tile's E / pi-weighted view angle and azimuth for a range of incidence angles, with the
   index-matched boundary at the tile's mean angles as the control (it must give 1), and applies the
   measured factor per pixel (interpolated in cos theta_i) to the prediction; splits the factor into
   the boundary's entry (the rough dielectric's transmittance over Fresnel's, sampled from Mitsuba's
   BSDF: :func:`lab.flat.rough_dielectric_transmittance`) and the rest.

4. estimates the light that leaves the surface (the boundary's reflection, the diffuse light) and
   re-enters it elsewhere (:func:`lab.oblique.surface_reentry`), which the G-buffer's
   direct E / pi lacks, and applies it to the rough-surface MCML prediction.

Keys: ``prediction.rough`` / ``table.rough``: MCML with a smooth surface at the material's eta (for the
reference's rough dielectric); ``rough_mcml``: MCML with the references' rough surface; ``index_matched``:
MCML at eta = 1; ``comparison.<region>.<column>.reference_over_flat``: the predicted exact / reference over
the measured one (1: the prediction explains the difference).

Prints one JSON object; progress on stderr.

    PYTHONPATH=src python benchmarks/oblique_attribution.py --measured regions-attribution.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import platform
import sys
import time

import numpy as np

from ssskit.materials import get_material
from lab.attribution import Setup, curvature_setups, fresnel_setups, prepare, regions_of, run_experiment
from lab.oblique import (compare_flat_limit, flat_experiment, flat_prediction, point_light,
                                     surface_reentry)
from lab.oblique_table import fresnel_transmittance, oblique_table
from ssskit.scenes import COAT_ROUGHNESS, render_gbuffer
from lab.flat import rough_dielectric_transmittance

REGIONS = ("silhouette", "shadow_edge", "grazing_view", "object")


def measured_runs(path, scene):
    """{experiment: last setup's regions} of ``scene`` from a region_attribution.py JSON."""
    data = json.loads(open(path).read())
    out = {}
    for run in data["runs"]:
        if run["scene"] == scene and run["experiment"] in ("curvature", "fresnel"):
            out[run["experiment"]] = {"label": run["setups"][-1]["label"], "regions": run["setups"][-1]["regions"],
                                      "spp": run["setups"][-1]["spp"]}
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="bumpy")
    ap.add_argument("--material", default="skin1")
    ap.add_argument("--size", default="160x120", help="the demo's image size")
    ap.add_argument("--measured",
                    help="region_attribution.py JSON with the scene's curvature (last factor) and fresnel runs")
    ap.add_argument("--measure-spp", type=int, default=1024, help="without --measured: reference spp per setup")
    ap.add_argument("--table-photons", type=int, default=1_000_000, help="MCML photons per channel and angle")
    ap.add_argument("--angles", default="0,30,50,60,65,70,75,80,85", help="flat experiment: incidence angles")
    ap.add_argument("--flat-spp", type=int, default=2048, help="flat experiment, rough dielectric: spp per angle")
    ap.add_argument("--flat-size", default="64x48")
    ap.add_argument("--control-spp", type=int, default=512, help="flat experiment, index-matched control: spp")
    ap.add_argument("--bsdf-samples", type=int, default=50_000,
                    help="samples of the boundary's transmittance per angle")
    ap.add_argument("--subpixels", type=int, default=4, help="angles and E / pi at s x s sub-pixels per pixel")
    ap.add_argument("--subpixel-spp", type=int, default=4, help="spp of the sub-pixel G-buffer")
    ap.add_argument("--reentry-samples", type=int, default=40_000, help="surface points for the re-entry estimate")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    say = lambda msg: print(msg, file=sys.stderr, flush=True)  # noqa: E731
    w, h = (int(v) for v in args.size.lower().split("x"))
    fw, fh = (int(v) for v in args.flat_size.lower().split("x"))
    mat = get_material(args.material)
    mat1 = dataclasses.replace(mat, eta=1.0)
    t0 = time.perf_counter()
    out = {"scene": args.scene, "material": mat.name, "machine": platform.node(), "size": [w, h]}

    say("MCML tables")
    t = time.perf_counter()
    tab, tab1 = oblique_table(mat, photons=args.table_photons), oblique_table(mat1, photons=args.table_photons)
    # MCML with the references' own rough surface (Beckmann alpha = COAT_ROUGHNESS)
    tab_r = oblique_table(mat, photons=args.table_photons, roughness=COAT_ROUGHNESS)
    out["table"] = {"rough": tab.to_dict(), "index_matched": tab1.to_dict(), "rough_mcml": tab_r.to_dict(),
                    "seconds": round(time.perf_counter() - t, 1)}

    say("G-buffers, regions, per-pixel prediction")
    prep = prepare(Setup("x1", args.scene, mat), w, h, 200_000, surface=False)
    prep1 = prepare(Setup("index-matched", args.scene, mat1, "index-matched"), w, h, 200_000, surface=False)
    masks = regions_of(prep)
    light = point_light(args.scene)
    # the angles and E / pi at s x s sub-pixels per pixel (the tile's pits are a pixel wide)
    sub = args.subpixels
    fine = render_gbuffer(args.scene, prep.profile.total_rd(), eta=mat.eta, width=w * sub, height=h * sub,
                          spp=args.subpixel_spp, material=mat.name) if sub > 1 else None
    fine1 = render_gbuffer(args.scene, prep1.profile.total_rd(), eta=1.0, width=w * sub, height=h * sub,
                           spp=args.subpixel_spp, material=mat.name) if sub > 1 else None
    pred = flat_prediction(prep.gbuffer, light, tab, masks, fine=fine)
    pred1 = flat_prediction(prep1.gbuffer, light, tab1, masks, fine=fine1)
    pred_r = flat_prediction(prep.gbuffer, light, tab_r, masks, fine=fine)
    # the same at one normal per pixel (what the region table's G-buffer holds)
    out["prediction_one_normal_per_pixel"] = {"rough_mcml": flat_prediction(prep.gbuffer, light, tab_r, masks)}
    out["prediction"] = {"rough": pred, "index_matched": pred1, "rough_mcml": pred_r}

    if args.measured:
        meas = measured_runs(args.measured, args.scene)
        out["measured_from"] = args.measured
    else:
        meas = {}
        for exp, setups in (("curvature", curvature_setups(args.scene, mat, (1.0, 8.0))),
                            ("fresnel", fresnel_setups(args.scene, mat))):
            say(f"== measuring {exp}")
            res = run_experiment(setups, width=w, height=h, spp=args.measure_spp, seed=args.seed, surface=False,
                                 progress=say)
            last = res["setups"][-1]
            meas[exp] = {"label": last["label"], "regions": last["regions"], "spp": last["spp"]}

    say("flat experiment: index-matched control at the tile's mean angles")
    tile = pred["object"]
    view, az, inc = round(tile["view_deg"]), round(tile["azimuth_deg"]), round(tile["incidence_deg"])
    control = flat_experiment(mat, inc, view, az, "index-matched", fw, fh, args.control_spp, seed=args.seed,
                              table=tab1, progress=say)
    angles = [float(v) for v in args.angles.split(",")]
    flats = []
    for a in angles:
        say(f"flat experiment: rough dielectric at {a:g} deg")
        flats.append(flat_experiment(mat, a, view, az, "rough-dielectric", fw, fh, args.flat_spp, seed=args.seed,
                                     table=tab, compare={"rough_mcml": tab_r}, progress=say))
    factor = np.array([f["reference_over_prediction"] for f in flats]).T
    factor_se = np.array([f["reference_over_prediction_se"] for f in flats]).T
    # the boundary's entry: the rough dielectric's transmittance over the smooth one's at each angle
    cos_a = np.cos(np.radians(angles))
    t_rough, t_se = rough_dielectric_transmittance(cos_a, mat.eta, samples=args.bsdf_samples, seed=args.seed)
    entry = t_rough / fresnel_transmittance(cos_a, mat.eta)
    entry_se = t_se / fresnel_transmittance(cos_a, mat.eta)
    rest = factor / entry
    rest_se = rest * np.hypot(factor_se / factor, entry_se / entry)
    out["flat"] = {"view_deg": view, "azimuth_deg": az, "control": control, "rough": flats,
                   "entry_transmittance_ratio": entry.tolist(), "entry_transmittance_ratio_se": entry_se.tolist(),
                   "factor_over_entry": rest.tolist(), "factor_over_entry_se": rest_se.tolist()}
    pred_b = flat_prediction(prep.gbuffer, light, tab, masks, boundary=(angles, factor, factor_se), fine=fine)
    out["prediction"]["rough_with_measured_boundary"] = pred_b
    pred_e = flat_prediction(prep.gbuffer, light, tab, masks,
                             boundary=(angles, np.tile(entry, (3, 1)), np.tile(entry_se, (3, 1))), fine=fine)
    out["prediction"]["rough_with_rough_entry"] = pred_e

    say("light leaving the surface and re-entering it")
    reentry = surface_reentry(args.scene, tab_r, samples=args.reentry_samples, seed=args.seed)
    out["reentry"] = reentry
    gain = 1.0 + np.asarray(reentry["specular_reentry"]) + np.asarray(reentry["diffuse_reentry"])
    gain_se = np.hypot(reentry["specular_reentry_se"], reentry["diffuse_reentry_se"])
    pred_rr = {name: {**p, "level": (np.asarray(p["level"]) * gain).tolist(),
                      "rel_se": np.hypot(p["rel_se"], gain_se / gain).tolist()} for name, p in pred_r.items()}
    out["prediction"]["rough_mcml_with_reentry"] = pred_rr

    comp = {}
    for name in REGIONS:
        row = {}
        if "curvature" in meas and name in meas["curvature"]["regions"] and name in pred:
            c = meas["curvature"]["regions"][name]
            eo = c["exact_over_reference"]
            for key, p, what in (("", pred, "MCML, smooth boundary"),
                                 ("_rough_mcml", pred_r, "MCML with the same rough surface"),
                                 ("_rough_mcml_reentry", pred_rr, "MCML with the rough surface x (1 + light re-entering)"),
                                 ("_rough_entry", pred_e, "MCML x the rough entry transmittance"),
                                 ("_measured_boundary", pred_b, "MCML x flat rough factor")):
                row["rough_flat_limit" + key] = compare_flat_limit(p[name], c["exact_2d"], eo["value"], eo["se"],
                                                                   f"{meas['curvature']['label']} vs {what}")
        if "fresnel" in meas and name in meas["fresnel"]["regions"] and name in pred1:
            c = meas["fresnel"]["regions"][name]
            eo = c["exact_over_reference"]
            row["index_matched_k1"] = compare_flat_limit(pred1[name], c["exact_2d"], eo["value"], eo["se"],
                                                         "index-matched, unscaled, vs MCML at eta 1")
        comp[name] = row
    out["comparison"] = comp
    out["seconds"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
