"""The transmitted light of a finite slab by the original C MCML 1.2.2 (Wang, Jacques, Zheng 1995): its total
transmittance Tt and radial profile Tt(r) (MCML's Tt_r), written as the reference data of the test of
ssskit's own Tt(r) tally (``tests/profiles/data/c_mcml_slab_tt.json``, checked by
``tests/profiles/test_transmitted_tallies.py``); with ``--compare``, ssskit's numba engine on the same slab in
the same run, ring by ring. Prints one JSON object.

    python benchmarks/mcml_transmitted.py [--photons 1000000] [--mcml-src DIR] [--fetch] [--write] [--compare]

The C source is not part of this repository: ``--fetch`` or ``--mcml-src`` as for ``bench_mcml.py`` (whose
build and input-file helpers this script uses; the binary lands in ``benchmarks/.mcml-build/``). Cases
(:data:`CASES`): Skin1's red and blue channel (``ssskit.materials``) as one layer of 2 mm and 0.5 mm between
two ambient half-spaces, normal incidence, the supplement's radial grid (``supplement_grid``) as ssskit's
``slab_config`` makes it. MCML writes Tt_r in cm^-2 (4 significant digits); the file holds it in mm^-2 with
the run's photons, RAT values and the grid. MCML 1.2.2 seeds its generator from the clock, so a new run
writes statistically equivalent data, not the same digits.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_mcml import DEFAULT_SRC, build_mcml, fetch_sources, find_sources, write_mci  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "profiles" / "data" / "c_mcml_slab_tt.json"
#: (name, material, channel, thickness mm, seed of ssskit's comparison run)
CASES = (("skin1-R-2mm", "skin1", 0, 2.0, 11), ("skin1-B-0.5mm", "skin1", 2, 0.5, 12))
#: a ring is compared where ssskit's relative standard error is below this (the far tail holds a few photons,
#: whose batch spread is no standard error)
WELL_SAMPLED = 0.1
#: the rings the comparison sums the annuli into (mm): fine near the axis, wider outside
RING_EDGES_MM = (0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 14.0, 20.0, 30.0)


def parse_mco(text: str) -> dict:
    """RAT values and Tt_r (cm^-2, MCML's nr bins, the last collecting every radius beyond) of an .mco file."""
    rat = {}
    for key, label in (("Rsp", "Specular reflectance"), ("Rd", "Diffuse reflectance"),
                       ("A", "Absorbed fraction"), ("Tt", "Transmittance")):
        m = re.search(r"^\s*(\S+)\s+#" + label, text, re.MULTILINE)
        rat[key] = float(m.group(1)) if m else None
    m = re.search(r"^Tt_r #.*\n((?:\s*\S+\n)+)", text, re.MULTILINE)
    tt_r = [float(v) for v in m.group(1).split()] if m else []
    return {"rat": rat, "tt_r_cm2": tt_r}


def run_case(exe: Path, name: str, material: str, channel: int, thickness: float, photons: int) -> dict:
    import subprocess

    from ssskit.materials import get_material
    from ssskit.profiles.montecarlo.slab import slab_config

    cfg = slab_config(get_material(material), channel, thickness, photons)
    mci = write_mci(cfg, name)
    out = mci.with_suffix(".mco")
    out.unlink(missing_ok=True)
    p = subprocess.run([str(exe), mci.name], cwd=mci.parent, stdin=subprocess.DEVNULL, capture_output=True,
                       text=True, timeout=7200)
    if p.returncode != 0 or not out.exists():
        raise RuntimeError(f"mcml failed (rc {p.returncode}): {(p.stdout + p.stderr).strip()[-300:]}")
    got = parse_mco(out.read_text())
    if len(got["tt_r_cm2"]) != cfg.nr:
        raise RuntimeError(f"MCML wrote {len(got['tt_r_cm2'])} Tt_r bins, the grid has {cfg.nr}")
    return {"name": name, "material": material, "channel": channel, "thickness_mm": thickness, "photons": photons,
            "dr_mm": cfg.dr_mm, "nr": cfg.nr, "eta": cfg.layers[0].eta, "eta_ambient": cfg.eta_above,
            "rat": got["rat"], "tt_r_mm2": [v / 100.0 for v in got["tt_r_cm2"]]}


def compare(case: dict, photons: int) -> dict:
    """ssskit's numba engine on the case against the C program's Tt and Tt(r) rings (module docstring): each
    ring's difference in standard errors, the C run's taken as ssskit's scaled by the photon counts."""
    from ssskit.materials import get_material
    from ssskit.profiles.montecarlo import simulate
    from ssskit.profiles.montecarlo.result import ring_sums
    from ssskit.profiles.montecarlo.slab import slab_config

    seed = {c[0]: c[4] for c in CASES}[case["name"]]
    res = simulate(slab_config(get_material(case["material"]), case["channel"], case["thickness_mm"], photons, seed))
    dr = case["dr_mm"]
    s, s_se = ring_sums(res.tt_r, dr, RING_EDGES_MM, res.tt_r_se)
    c, _ = ring_sums(np.asarray(case["tt_r_mm2"])[:-1], dr, RING_EDGES_MM)
    assert s_se is not None
    sampled = s_se < WELL_SAMPLED * s
    se = s_se * np.sqrt(1.0 + photons / case["photons"])
    z = np.where(sampled, (s - c) / np.where(sampled, se, 1.0), np.nan)
    return {"name": case["name"], "ssskit_photons": photons, "tt": [res.tt, res.tt_se], "c_tt": case["rat"]["Tt"],
            "rings_mm": list(RING_EDGES_MM), "ssskit_rings": s.tolist(), "c_rings": c.tolist(),
            "z": [None if not np.isfinite(v) else round(float(v), 2) for v in z],
            "max_abs_z": float(np.nanmax(np.abs(z))), "reduced_chi2": float(np.nanmean(z ** 2))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--photons", type=int, default=1_000_000, help="photons of each C MCML run")
    ap.add_argument("--mcml-src", type=Path, default=DEFAULT_SRC, help="folder holding MCML 1.2.2's C files")
    ap.add_argument("--fetch", action="store_true", help="clone the C source first (bench_mcml.py's --fetch)")
    ap.add_argument("--write", action="store_true", help=f"write the reference data ({DATA.relative_to(ROOT)})")
    ap.add_argument("--compare", type=int, default=0, metavar="PHOTONS",
                    help="also run ssskit's numba engine with PHOTONS photons per case and compare ring by ring")
    args = ap.parse_args()
    if args.fetch:
        fetch_sources(args.mcml_src)
    code = find_sources(args.mcml_src)
    if code is None:
        print(json.dumps({"error": f"C MCML source not found in {args.mcml_src} (--fetch)"}))
        sys.exit(1)
    exe, build = build_mcml(code)
    cases = [run_case(exe, name, mat, ch, t, args.photons) for name, mat, ch, t, _ in CASES]
    out = {"c_mcml": build, "cases": [{k: v for k, v in c.items() if k != "tt_r_mm2"} for c in cases]}
    if args.write:
        DATA.parent.mkdir(parents=True, exist_ok=True)
        DATA.write_text(json.dumps({"command": "python benchmarks/mcml_transmitted.py --write",
                                    "source": "C MCML 1.2.2 (lhvwang/MCML, V1/mcR5unix/mcmlcode), gcc -O2",
                                    "cases": cases}, indent=None, separators=(",", ":")) + "\n")
        out["written"] = str(DATA.relative_to(ROOT))
    if args.compare:
        out["compare"] = [compare(c, args.compare) for c in cases]
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
