"""EEVEE Next (the viewport's engine) against Cycles (the offline truth of the same file) on the scanned head: ssskit's
Blender export of each material on the head's close view (the left cheek beside the nose), lit by the head's key
light with no cast shadow, so the light ends at the terminator (N . L = 0), the same line in both engines
(ssskit.export.blender_head). Per material, channel and export variant (``cycles``; ``eevee``, the radius x s(A')
that undoes EEVEE's burley_setup narrowing): EEVEE's terminator spill (the light that leaves the skin where the
light does not reach, over the albedo) over Cycles', and the lit plateau over the albedo, for each of ``--repeats``
EEVEE renders (EEVEE on llvmpipe differs run to run: the spread is the noise), with s(A') beside it.

    PYTHONPATH=src nice -n 10 python benchmarks/blender_eevee_head.py            # JSON on stdout
    PYTHONPATH=src nice -n 10 python benchmarks/blender_eevee_head.py --markdown # the docs/exports.md table

Progress on stderr.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time


def run(materials: list[str], model: str, width: int, height: int, taa: int, spp: int, repeats: int,
        view: str) -> dict:
    from ssskit.export.blender import eevee_radius_scale, find_blender_python
    from ssskit.export.blender_head import compare_head
    from ssskit.export.engines import slab_material
    from ssskit.materials import get_material

    python, why = find_blender_python()
    if python is None:
        raise SystemExit(f"blender_eevee_head: {why}")
    rows = []
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        for name in materials:
            _, script, a, d = slab_material(name, model, tmp)
            cmp = compare_head(script, a, width, height, view, taa, spp, repeats, python=python)
            rows.append({"material": get_material(name).name, "albedo": a.tolist(), "d_mm": d.tolist(),
                         "s": eevee_radius_scale(a).tolist(), **cmp})
            print(json.dumps({"material": name, "seconds": round(time.time() - t0, 1)}), file=sys.stderr)
    return {"model": model, "view": view, "width": width, "height": height, "taa": taa, "spp": spp,
            "repeats": repeats, "seconds": time.time() - t0, "load_average": os.getloadavg(), "rows": rows}


def _span(values: list[float], digits: int = 2) -> str:
    lo, hi = min(values), max(values)
    return f"{lo:.{digits}f}" if f"{lo:.{digits}f}" == f"{hi:.{digits}f}" else f"{lo:.{digits}f}-{hi:.{digits}f}"


def markdown(data: dict) -> str:
    out = [f"EEVEE Next {data['rows'][0]['blender']} (Mesa llvmpipe, EGL) and Cycles (CPU, {data['spp']} spp), "
           f"the head's {data['view']} view at {data['width']}x{data['height']} px, key light without cast shadow, "
           f"EEVEE {data['taa']} TAA samples (its gather: 16 samples per pixel per TAA sample), {data['repeats']} "
           f"EEVEE renders per row (min-max over them), source --model {data['model']}",
           "",
           "| material | channel | A | s(A') | Cycles plateau / A | EEVEE spill / Cycles' (cycles export) | "
           "EEVEE spill / Cycles' (eevee variant) | gain of the variant | EEVEE plateau / A (cycles) |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        for c in range(3):
            cyc = [run["spill_ratio"][c] for run in r["eevee"]["cycles"]]
            eev = [run["spill_ratio"][c] for run in r["eevee"]["eevee"]]
            gain = [e / x for e, x in zip(eev, cyc)]
            pl = [run["plateau"][c] for run in r["eevee"]["cycles"]]
            out.append(f"| {r['material']} | {'RGB'[c]} | {r['albedo'][c]:.4f} | {r['s'][c]:.2f} | "
                       f"{r['cycles_plateau'][c]:.3f} | {_span(cyc)} | {_span(eev)} | {_span(gain)} | {_span(pl, 3)} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--materials", default="skin1,marble,ketchup")
    ap.add_argument("--model", default="dipole", help="source profile model [dipole]")
    ap.add_argument("--view", default="close", help="the head's view [close]")
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--taa", type=int, default=64, help="EEVEE's TAA render samples [64]")
    ap.add_argument("--spp", type=int, default=256, help="Cycles' samples per pixel [256]")
    ap.add_argument("--repeats", type=int, default=3, help="EEVEE renders per material and variant [3]")
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    data = run(args.materials.split(","), args.model, args.width, args.height, args.taa, args.spp, args.repeats,
               args.view)
    print(markdown(data) if args.markdown else json.dumps(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
