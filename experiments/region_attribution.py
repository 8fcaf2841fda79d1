"""What each difference in the region table is, measured: controlled path-traced experiments that each
switch ONE cause off and compare with the uncontrolled reference in the same run
(:mod:`lab.attribution`).

* transmission: the scene with a black backing just outside the surface the camera does not see
  (no light enters the medium there) vs the scene as rendered;
* fresnel: the index-matched boundary (material at eta = 1, MC profile at eta = 1 for the pass and
  the exact 2D convolution) vs the rough dielectric;
* curvature: the scene scaled by k (same image, k x the mm per pixel) for each k;
* thickness (not in the default runs; :mod:`lab.thickness`): the backed ear against the same
  ear with its unseen half --depths times deeper (backed too), and the local-slab prediction (chord
  along the normal, MCML Rd(t) / Rd(inf)); thin-slab: the slab cut to --thicknesses mm against the
  20 mm slab on the plateau, reference vs MCML (--boundary index-matched or rough-dielectric).

Per experiment, scene, setup and region: the levels (pass, exact 2D, reference ± SE), exact /
reference ± SE, that ratio relative to the plateau's ± SE, and against the first setup the reference
ratio and the share of the gap (reference - exact) removed ± SE. Every setup uses the same chunk
seeds and the first setup's pixels. Prints one JSON object; progress on stderr.

    PYTHONPATH=src python benchmarks/region_attribution.py          # every run, stored for the report
    PYTHONPATH=src python benchmarks/region_attribution.py --experiment curvature --scene sphere --factors 1,2,4,8
    PYTHONPATH=src python benchmarks/region_attribution.py --experiment thickness --scene ear
    PYTHONPATH=src python benchmarks/region_attribution.py --experiment thin-slab --spp 256
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time

from lab.figure import ATTRIBUTION_RUNS, ATTRIBUTION_SPP, CURVATURE_FACTORS, attribution_data
from lab.attribution import SETUPS, experiment_setups, run_experiment
from lab.thickness import DEEPEN_FACTORS, SLAB_THICKNESSES, slab_check, thickness_experiment

#: the thin-medium experiments (lab.thickness), run only when asked for
THICKNESS_EXPERIMENTS = ("thickness", "thin-slab")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--experiment", choices=sorted(SETUPS) + list(THICKNESS_EXPERIMENTS), action="append",
                    help="run only this experiment (repeatable; default: the default runs)")
    ap.add_argument("--scene", action="append", help="run only on this scene (repeatable)")
    ap.add_argument("--material", default="skin1")
    ap.add_argument("--size", default="160x120", help="the demo's image size")
    ap.add_argument("--spp", type=int, default=ATTRIBUTION_SPP, help="reference samples per pixel per setup")
    ap.add_argument("--chunk-spp", type=int, default=8)
    ap.add_argument("--photons", type=int, default=200_000, help="MCML photons per channel (the demo's)")
    ap.add_argument("--factors", default=",".join(f"{k:g}" for k in CURVATURE_FACTORS),
                    help="curvature: the scale factors, the first the baseline")
    ap.add_argument("--depths", default=",".join(f"{k:g}" for k in DEEPEN_FACTORS),
                    help="thickness: the factors by which the ear's unseen half is made deeper")
    ap.add_argument("--thicknesses", default=",".join(f"{t:g}" for t in SLAB_THICKNESSES),
                    help="thin-slab: the slab's thicknesses (mm)")
    ap.add_argument("--boundary", default="index-matched", choices=("index-matched", "rough-dielectric"),
                    help="thin-slab: the reference's boundary")
    ap.add_argument("--mcml-photons", type=int, default=1_000_000, help="thin-slab: MCML photons per channel")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--plot", default=None, metavar="FILE.png",
                    help="the default runs only: also draw their plot (lab.figure.plot_attribution) into FILE.png")
    args = ap.parse_args(argv)
    w, h = (int(v) for v in args.size.lower().split("x"))
    factors = tuple(float(v) for v in args.factors.split(","))
    runs = [(e, s) for e, s in ATTRIBUTION_RUNS if (not args.experiment or e in args.experiment)
            and (not args.scene or s in args.scene)]
    if args.experiment and args.scene:
        runs = [(e, s) for e in args.experiment for s in args.scene]
    elif args.experiment:  # the thin-medium experiments' own scenes
        runs += [(e, "ear" if e == "thickness" else "slab") for e in args.experiment if e in THICKNESS_EXPERIMENTS]
    say = lambda msg: print(msg, file=sys.stderr, flush=True)  # noqa: E731
    out = {"material": args.material, "spp": args.spp, "size": [w, h], "machine": platform.node(), "runs": []}
    t0 = time.perf_counter()
    if (not args.experiment and not args.scene and args.chunk_spp == 8 and args.seed == 0
            and factors == CURVATURE_FACTORS):
        # the figure's runs: stored (lab.figure.attribution_data) where a later run finds them
        data = attribution_data(args.material, photons=args.photons, spp=args.spp, width=w, height=h, progress=say)
        out["runs"] = data["runs"]
        out["stored"] = True
        if args.plot:
            from lab.figure import plot_attribution

            plot_attribution(data, args.plot)
            say(f"wrote {args.plot}")
        out["seconds"] = round(time.perf_counter() - t0, 1)
        print(json.dumps(out, indent=1))
        return
    for exp, scene in runs:
        say(f"== {exp} on {scene}")
        if exp in THICKNESS_EXPERIMENTS:
            t = time.perf_counter()
            if exp == "thickness":
                res = thickness_experiment(scene, args.material, tuple(float(v) for v in args.depths.split(",")),
                                           width=w, height=h, spp=args.spp, chunk_spp=args.chunk_spp,
                                           photons=args.photons, seed=args.seed, progress=say)
            else:
                res = slab_check(args.material, tuple(float(v) for v in args.thicknesses.split(",")), args.boundary,
                                 spp=args.spp, chunk_spp=args.chunk_spp, photons=args.photons,
                                 mcml_photons=args.mcml_photons, width=w, height=h, seed=args.seed, scene=scene,
                                 progress=say)
            out["runs"].append({"experiment": exp, "scene": scene, "seconds": round(time.perf_counter() - t, 1), **res})
            continue
        setups = experiment_setups(exp, scene, args.material, factors)
        t = time.perf_counter()
        res = run_experiment(setups, width=w, height=h, spp=args.spp, chunk_spp=args.chunk_spp,
                             photons=args.photons, seed=args.seed, progress=say)
        out["runs"].append({"experiment": exp, "scene": scene, "seconds": round(time.perf_counter() - t, 1), **res})
    out["seconds"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
