"""Regenerate the Monte Carlo table of the artists'-terms inversion (src/ssskit/profiles/data/artist_table.json).

    PYTHONPATH=src python docs/artist_table.py                 # the shipped table (a few minutes on 2 cores)
    PYTHONPATH=src python docs/artist_table.py --out /tmp/t.json   # elsewhere (tests/profiles/test_artist.py
                                                                  # re-simulates a few entries instead)

For each relative index eta and reduced albedo alpha' (g = 0, sigma_t' = 1 mm^-1, a semi-infinite medium,
normal incidence, ssskit's MCML engine): the total diffuse reflectance Rd (overflow included), the radius
r50 holding half of it and the Burley d fitted to the profile (ssskit.export.fit_burley_channel, the fit of
every engine export), each the mean of ``--seeds`` independent runs with its standard error (the runs'
scatter / sqrt(seeds)). The grid extends to 12 diffusion lengths 1/sqrt(3 (1 - alpha')) plus 4 mean free
paths, in 500 bins. Progress on stderr.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "src" / "ssskit" / "profiles" / "data" / "artist_table.json"
ETAS = (1.0, 1.3, 1.4, 1.5)
KEYS = ("rd", "rd_se", "r50", "r50_se", "burley_d", "burley_d_se")
U = [round(0.02 + i * (0.999 - 0.02) / 27, 6) for i in range(28)]  # u = sqrt(1 - alpha')


def entry(alpha_reduced: float, eta: float, photons: int, seeds: int, first_seed: int = 1) -> dict:
    """Rd and r50 (units of 1/sigma_t') at one (alpha', eta): means and standard errors over the seeds."""
    import numpy as np

    import numpy as np

    from ssskit.export.engines import fit_burley_channel
    from ssskit.profiles.artist import mcml_run, r50_of_result

    rd, r50, d = [], [], []
    for s in range(seeds):
        res = mcml_run(1.0 - alpha_reduced, alpha_reduced, 0.0, eta, photons, first_seed + s)
        rd.append(res.total_rd)
        r50.append(r50_of_result(res.r_mm, res.rd, res.config.dr_mm, res.total_rd))
        d.append(fit_burley_channel(res.profile())[1])
    se = lambda v: float(np.std(v, ddof=1) / math.sqrt(len(v)))  # noqa: E731
    return {"rd": float(np.mean(rd)), "rd_se": se(rd), "r50": float(np.mean(r50)), "r50_se": se(r50),
            "burley_d": float(np.mean(d)), "burley_d_se": se(d)}


def table(photons: int, seeds: int, etas=ETAS) -> dict:
    out: dict = {"description": "MCML, semi-infinite, g = 0, sigma_t' = 1 mm^-1, normal incidence, eta_above 1: "
                                "total Rd (overflow included), r50 and the fitted Burley d (units of 1/sigma_t') per (eta, alpha'); "
                                "each the mean of `seeds` runs of `photons` photons, with its standard error",
                 "generator": "docs/artist_table.py", "photons": photons, "seeds": seeds,
                 "eta": list(etas), "alpha_reduced": [round(1.0 - u * u, 8) for u in U]}
    for key in KEYS:
        out[key] = []
    t0 = time.perf_counter()
    for i, eta in enumerate(etas):
        rows: dict = {k: [] for k in KEYS}
        for j, ap in enumerate(out["alpha_reduced"]):
            e = entry(ap, eta, photons, seeds, first_seed=1 + 100 * j)
            for k in rows:
                rows[k].append(float(f"{e[k]:.6g}"))
            print(f"artist table: eta {eta} alpha' {ap:.5f} Rd {e['rd']:.5f} r50 {e['r50']:.4f} "
                  f"({i * len(U) + j + 1}/{len(etas) * len(U)}, {time.perf_counter() - t0:.0f} s)", file=sys.stderr)
        for k in rows:
            out[k].append(rows[k])
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photons", type=int, default=50_000, help="photons per run [50000]")
    ap.add_argument("--seeds", type=int, default=4, help="independent runs per entry [4]")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    data = table(args.photons, args.seeds)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(data, separators=(",", ":")) + "\n")
    print(f"wrote {args.out} ({args.out.stat().st_size} bytes)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
