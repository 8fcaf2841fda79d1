"""The error table of docs/exports.md: every engine parameter export re-imported into ssskit's Burley
or separable (Gaussian-sum) model, against the source profile, per material and engine.

    PYTHONPATH=src python docs/export_errors.py                      # dipole sources, markdown
    PYTHONPATH=src python docs/export_errors.py --model montecarlo   # MCML sources (the shipped 10^7 photons)
    PYTHONPATH=src python docs/export_errors.py --full               # one row per engine and model
    PYTHONPATH=src python docs/export_errors.py --json               # one JSON object

For each (material, engine model): the share of the reflected energy the engine puts at a wrong
radius, int |p_src - p_eng| dr / int p_src dr with p = 2 pi r R(r) (R, G, B), the ratio of the
radii holding half the energy (r50, R G B) and of the totals (``ssskit.export.profile_error``).
The last column separates the engine's encoding from the model's shape: the largest misplaced
energy of the re-imported profile against ssskit's own fit before encoding (Burley (A, d), or the
demo profile with the fitted falloffs): float32 storage, clamps and unit conversions only.
"""

from __future__ import annotations

import argparse
import json
import sys


def table(model: str, materials: list[str] | None = None) -> list[dict]:
    import numpy as np

    from ssskit.export import ENGINE_MODELS, engine_parameters, fit_burley, profile_error, reimport
    from ssskit.export.engines import fit_separable_channel
    from ssskit.kernels.burley_fit import _mixture
    from ssskit.profiles import BurleyProfile, GaussianSumProfile, RGBProfile
    from ssskit.materials import MATERIALS, get_material
    from ssskit.profiles import profile_for_material

    rows = []
    for name in materials or MATERIALS.names():
        material = get_material(name)
        source = profile_for_material(material, model)
        a, d = fit_burley(source)
        fits = {"burley": RGBProfile(tuple(BurleyProfile(a[c], d[c]) for c in range(3)), "burley", name)}
        sep = []
        for c, ch in enumerate(source.channels):
            w, sig = _mixture("jimenez2012", np.array([fit_separable_channel(ch)["params"]["falloff"]]))
            sep.append(GaussianSumProfile(float(ch.total_rd()) * w, sig**2))
        fits["separable"] = RGBProfile(tuple(sep), "gaussians", name)
        exports = {}
        for engine, engine_model in ENGINE_MODELS:
            if engine not in exports:
                exports[engine] = engine_parameters(source, engine, material)
            back = reimport(exports[engine], engine_model)
            err = profile_error(source, back)
            encoding = max(profile_error(fits[engine_model], back)["relative_l1"])
            clamps = exports[engine].get("clamps", []) if engine == "unreal" else []
            rows.append({"material": material.name, "source": model, "engine": engine, "model": engine_model,
                         "albedo": [round(float(v), 4) for v in source.total_rd()], **err, "encoding_loss": encoding,
                         "clamps": clamps})
    return rows


def markdown(rows: list[dict]) -> str:
    fmt = lambda vals, p=3: " ".join(f"{v:.{p}f}" for v in vals)  # noqa: E731
    out = ["| material | engine | model | misplaced energy R G B | r50 ratio R G B | total ratio R G B | encoding loss |",
           "|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['material']} | {r['engine']} | {r['model']} | {fmt(r['relative_l1'])} | "
                   f"{fmt(r['r50_ratio'], 2)} | {fmt(r['total_ratio'], 4)} | {r['encoding_loss']:.1e} |")
    return "\n".join(out)


def clamped(rows: list[dict]) -> str:
    """The Unreal clamps that fired (UE clamps SurfaceAlbedo and MeanFreePathColor to >= 0.009)."""
    fired = sorted({c.split(" ")[0] for r in rows for c in r["clamps"]})
    return ", ".join(f"{f} -> 0.009" for f in fired) if fired else "none"


def summary(rows: list[dict]) -> str:
    """One row per material: the three Burley engines share one fit (they differ by their encoding only,
    the encoding-loss column, taken where no engine clamp fires), Unreal's separable profile is the other model;
    the last column lists the Unreal clamps that fired (their effect is in the --full table)."""
    fmt = lambda vals, p=3: " ".join(f"{v:.{p}f}" for v in vals)  # noqa: E731
    out = ["| material | albedo A (R G B) | Burley engines: misplaced energy R G B (r50 ratio) | "
           "Unreal separable: misplaced energy R G B (r50 ratio) | largest encoding loss | Unreal clamps |",
           "|---|---|---|---|---|---|"]
    for name in dict.fromkeys(r["material"] for r in rows):
        mine = [r for r in rows if r["material"] == name]
        burley = [r for r in mine if r["model"] == "burley" and not r["clamps"]]
        sep = next(r for r in mine if r["model"] == "separable")
        spread = max(abs(a - b) for r in burley for a, b in zip(r["relative_l1"], burley[0]["relative_l1"]))
        assert spread < 1e-5, f"{name}: the Burley engines disagree by {spread}"
        b = burley[0]
        out.append(f"| {name} | {fmt(b['albedo'])} | {fmt(b['relative_l1'])} ({fmt(b['r50_ratio'], 2)}) | "
                   f"{fmt(sep['relative_l1'])} ({fmt(sep['r50_ratio'], 2)}) | "
                   f"{max(r['encoding_loss'] for r in mine if not r['clamps']):.0e} | "
                   f"{clamped(mine)} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="dipole", help="source profile model (dipole, burley, montecarlo, ...)")
    ap.add_argument("--materials", default=None, help="comma-separated presets [default: all]")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of a markdown table")
    ap.add_argument("--full", action="store_true", help="one markdown row per (material, engine, model)")
    args = ap.parse_args(argv)
    rows = table(args.model, args.materials.split(",") if args.materials else None)
    if args.json:
        print(json.dumps({"model": args.model, "rows": rows}))
    else:
        print(markdown(rows) if args.full else summary(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
