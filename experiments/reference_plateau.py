"""The path-traced reference against the Monte Carlo profile on the slab's uniformly lit plateau.

Far from every edge (the shadow edge at x = 0 and the slab's side at x = -60 mm) a uniformly lit
semi-infinite medium reflects Rd x E / pi if its light leaves like a Lambertian surface: the
converged reference's diffuse part (reference minus the G-buffer's specular layer, the same rough
dielectric reflection) over the G-buffer's E / pi must equal the Monte Carlo profile's total Rd.
The exit is not exactly Lambertian, so the script also reports MCML's own radiance factor near the
camera's direction (``MCResult.radiance_factor_at``) with the beam at the plateau's incidence
angle, which is what a camera looking along the normal sees.

Two boundaries: the scenes' rough dielectric (Beckmann alpha = 0.15, eta of the material) against
MCML with a smooth Fresnel boundary of the same eta and against MCML with the same rough surface
(``MCConfig.roughness``: Mitsuba's single-scattering ``roughdielectric``, which loses light at
grazing internal reflections and widens the exit lobe), and the index-matched one (Mitsuba ``null``)
against MCML at eta = 1. Every chunk of the reference is an independent batch; it renders until the
plateau's relative standard error is at most --rel-se or --max-spp is spent, only inside the
plateau's window. Prints one JSON object.

    PYTHONPATH=src python benchmarks/reference_plateau.py --material skin1 --rel-se 0.004
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time

import numpy as np

from ssskit.materials import get_material
from ssskit.profiles.montecarlo import config_for_material, montecarlo_rgb, simulate
from lab.oblique import pixel_angles, point_light
from ssskit.scenes import render_gbuffer
from ssskit.scenes.scenes import COAT_ROUGHNESS
from ssskit.scenes.reference import ReferenceRenderer, batch_mean_se



def plateau(gb, x_range=(-36.0, -15.0), y_half=25.0):
    """(H, W) bool: slab pixels with x in x_range mm and |y| < y_half mm (world coordinates on z = 0)."""
    world = gb.camera.unproject(np.where(gb.mask, gb.depth, 600.0))
    x, y = world[..., 0], world[..., 1]
    return gb.mask & (x >= x_range[0]) & (x <= x_range[1]) & (np.abs(y) < y_half)


def converge(renderer, region_crop, chunk_spp, rel_se, max_spp, label):
    acc, means, t0 = 0.0, [], time.perf_counter()
    for i in range(max(max_spp // chunk_spp, 2)):
        img = renderer.chunk(i, chunk_spp)
        acc = acc + img
        means.append(img[region_crop].mean(axis=0))
        if i >= 1:
            m, se = batch_mean_se(np.array(means))
            if i % 16 == 0:
                print(f"{label}: {(i + 1) * chunk_spp} spp, rel. SE {np.max(se / m):.3%}, "
                      f"{time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
            if np.all(se / m <= rel_se):
                break
    k = len(means)
    return acc / k, np.array(means), k * chunk_spp, time.perf_counter() - t0


def run(material, boundary, args):
    w, h = args.size
    mat = material if boundary == "rough-dielectric" else dataclasses.replace(material, eta=1.0)
    gb = render_gbuffer("slab", (1.0, 1.0, 1.0), eta=mat.eta, width=w, height=h, spp=args.gbuffer_spp)
    region = plateau(gb)
    ys, xs = np.nonzero(region)
    crop = (int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1), int(ys.max() - ys.min() + 1))
    sub = region[crop[1]:crop[1] + crop[3], crop[0]:crop[0] + crop[2]]
    renderer = ReferenceRenderer("slab", mat, w, h, max_depth=args.max_depth, seed=args.seed, boundary=boundary,
                                 crop=crop)
    image, means, spp, seconds = converge(renderer, sub, args.chunk_spp, args.rel_se, args.max_spp, boundary)
    win = (slice(crop[1], crop[1] + crop[3]), slice(crop[0], crop[0] + crop[2]))
    e_pi = gb.diffuse[win][sub].astype(float)
    spec = gb.specular[win][sub].astype(float)
    # the diffuse part: each chunk's plateau mean minus the specular layer's (the same rough reflection)
    diffuse_means = means - spec.mean(axis=0)
    ref_mean, ref_se = batch_mean_se(diffuse_means)
    epi = e_pi.mean(axis=0)
    # the plateau's mean incidence angle of the point light and the camera's exit cosine
    cos_i, mu_v = pixel_angles(gb, point_light("slab"))
    inc = float(np.degrees(np.mean(np.arccos(cos_i[region]))))
    mu_cam = float(np.mean(mu_v[region]))
    out = {"boundary": boundary, "eta": mat.eta, "size": [w, h], "plateau_pixels": int(region.sum()),
           "spp": spp, "seconds": round(seconds, 1), "ref_diffuse": ref_mean.tolist(),
           "ref_rel_se": (ref_se / ref_mean).tolist(), "E_over_pi": epi.tolist(),
           "specular_fraction": (spec.mean(axis=0) / (ref_mean + spec.mean(axis=0))).tolist(),
           "incidence_deg": inc, "camera_mu": mu_cam}
    # (a) the profile the pipeline uses: MCML at normal incidence (supplement F), its total Rd
    prof = montecarlo_rgb(mat, photons=args.profile_photons)
    rd_a = np.array([c.total_rd_with_overflow() for c in prof.channels])
    rd_a_se = np.array([c.result.total_rd_se for c in prof.channels])
    ratio = ref_mean / (epi * rd_a)
    out["profile_total_Rd"] = rd_a.tolist()
    out["ratio_to_profile_Rd"] = ratio.tolist()
    out["ratio_to_profile_Rd_se"] = (ratio * np.hypot(ref_se / ref_mean, rd_a_se / rd_a)).tolist()
    # (b) MCML with the beam at the plateau's incidence angle, and its radiance factor at the camera
    res = [simulate(dataclasses.replace(config_for_material(mat, c, photons=args.photons, seed=7), incidence_deg=inc))
           for c in range(3)]
    rd_b = np.array([r.total_rd for r in res])
    rf = [r.radiance_factor_at(mu_cam) for r in res]
    f, f_se = np.array([v[0] for v in rf]), np.array([v[1] for v in rf])
    ratio_b = ref_mean / (epi * rd_b)
    ratio_c = ratio_b / f
    out["oblique_total_Rd"] = rd_b.tolist()
    out["ratio_to_oblique_Rd"] = ratio_b.tolist()
    out["radiance_factor_at_camera"] = f.tolist()
    out["radiance_factor_se"] = f_se.tolist()
    out["ratio_to_oblique_Rd_times_radiance_factor"] = ratio_c.tolist()
    out["ratio_to_oblique_Rd_times_radiance_factor_se"] = (ratio_c * np.hypot(ref_se / ref_mean, f_se / f)).tolist()
    if boundary == "rough-dielectric":
        out["same_surface"] = same_surface(mat, ref_mean, ref_se, epi, inc, mu_cam, args)
    return out


def same_surface(mat, ref_mean, ref_se, epi, inc, mu_cam, args):
    """The reference against MCML with the scene's own rough surface (Beckmann alpha = COAT_ROUGHNESS):
    (a) the Monte Carlo profile of that surface, normal incidence, Lambertian exit, as the pipeline
    would use it; (b) the beam at the plateau's incidence and MCML's radiance factor at the camera."""
    normal = [simulate(dataclasses.replace(config_for_material(mat, c, photons=args.photons, seed=5),
                                           roughness=COAT_ROUGHNESS)) for c in range(3)]
    oblique = [simulate(dataclasses.replace(config_for_material(mat, c, photons=args.photons, seed=7),
                                            incidence_deg=inc, roughness=COAT_ROUGHNESS)) for c in range(3)]
    rd_a = np.array([r.total_rd for r in normal])
    rd_a_se = np.array([r.total_rd_se for r in normal])
    rd_b = np.array([r.total_rd for r in oblique])
    rd_b_se = np.array([r.total_rd_se for r in oblique])
    rf = [r.radiance_factor_at(mu_cam) for r in oblique]
    f, f_se = np.array([v[0] for v in rf]), np.array([v[1] for v in rf])
    ratio_a = ref_mean / (epi * rd_a)
    ratio_b = ref_mean / (epi * rd_b * f)
    return {"roughness": COAT_ROUGHNESS, "photons": args.photons,
            "profile_total_Rd": rd_a.tolist(), "rsp": [r.rsp for r in normal],
            "ratio_to_profile_Rd": ratio_a.tolist(),
            "ratio_to_profile_Rd_se": (ratio_a * np.hypot(ref_se / ref_mean, rd_a_se / rd_a)).tolist(),
            "oblique_total_Rd": rd_b.tolist(), "radiance_factor_at_camera": f.tolist(),
            "ratio_to_oblique_Rd_times_radiance_factor": ratio_b.tolist(),
            "ratio_to_oblique_Rd_times_radiance_factor_se":
                (ratio_b * np.sqrt((ref_se / ref_mean) ** 2 + (rd_b_se / rd_b) ** 2 + (f_se / f) ** 2)).tolist()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--material", default="skin1")
    ap.add_argument("--size", default="128x96")
    ap.add_argument("--rel-se", type=float, default=0.004)
    ap.add_argument("--max-spp", type=int, default=8192)
    ap.add_argument("--chunk-spp", type=int, default=16)
    ap.add_argument("--max-depth", type=int, default=1024)
    ap.add_argument("--gbuffer-spp", type=int, default=64)
    ap.add_argument("--photons", type=int, default=2_000_000, help="MCML photons per channel, oblique beam")
    ap.add_argument("--profile-photons", type=int, default=200_000, help="photons of the pipeline's profile")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--boundary", choices=("rough-dielectric", "index-matched", "both"), default="both")
    args = ap.parse_args(argv)
    args.size = tuple(int(v) for v in args.size.lower().split("x"))
    mat = get_material(args.material)
    bounds = ("rough-dielectric", "index-matched") if args.boundary == "both" else (args.boundary,)
    result = {"material": mat.name, "runs": [run(mat, b, args) for b in bounds]}
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
