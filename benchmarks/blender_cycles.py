"""Blender Cycles (the client) against ssskit's prediction: the slab of ssskit.export.cycles_slab rendered
with ssskit's Blender export, for Christensen-Burley (the exported method) and for Random Walk given the
same numbers, per material and channel: the plateau over the exported albedo and the distances at which
the normalised shadow edge falls to 25 / 10 / 3 / 1 %, with the render's noise.

    PYTHONPATH=src python benchmarks/blender_cycles.py                 # markdown table (docs/exports.md)
    PYTHONPATH=src python benchmarks/blender_cycles.py --json          # one JSON object
    PYTHONPATH=src python benchmarks/blender_cycles.py --model dipole --spp 256   # quicker

Needs a Python with bpy (pip install bpy==4.2.0 on Python 3.11, or SSSKIT_BLENDER_PYTHON). Progress on stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time


def run(materials: list[str], model: str, width: int, height: int, spp: int, methods: list[str],
        rw_spp: int) -> dict:
    from ssskit.export.blender import compare_slab, find_blender_python, render_slab
    from ssskit.export.engines import slab_material
    from ssskit.materials import get_material

    python, why = find_blender_python()
    if python is None:
        raise SystemExit(f"blender_cycles: {why}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in materials:
            material = get_material(name)
            _, script, a, d = slab_material(name, model, tmp)
            for method in methods:
                t0 = time.perf_counter()
                n = rw_spp if method.startswith("RANDOM_WALK") else spp
                render = render_slab(script, list(d), width, height, n, seed=11, method=method, python=python,
                                     timeout=3600.0)
                cmp = compare_slab(render, a, d)
                print(f"blender_cycles: {name} {method} {time.perf_counter() - t0:.1f} s", file=sys.stderr)
                rows.append({"material": material.name, "method": method, "blender": render["blender"], "spp": n,
                             "seconds": render["seconds"], **cmp})
                print(json.dumps(rows[-1]), file=sys.stderr)
    return {"model": model, "width": width, "height": height, "spp": spp, "rows": rows}


def markdown(data: dict) -> str:
    from ssskit.export.blender import distance_cells

    out = [f"Cycles {data['rows'][0]['blender']} (CPU), {data['width']}x{data['height']} px per channel view, "
           f"source --model {data['model']}; the distances at 25 / 10 / 3 / 1 % of the plateau as rendered / "
           "predicted - 1, +- the render's noise (one standard error)",
           "",
           "| material | method (spp) | channel | plateau / albedo | 25 % | 10 % | 3 % | 1 % | mean abs edge error |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        for c, ch in enumerate(r["channels"]):
            cells = distance_cells(ch, "error")
            se = f"{ch['plateau_se']:.4f}" if ch["plateau_se"] >= 5e-5 else "< 0.0001"
            out.append(f"| {r['material']} | {r['method']} ({r['spp']}) | {'RGB'[c]} | {ch['plateau_ratio']:.4f} ± "
                       f"{se} | " + " | ".join(cells) + f" | {ch['mean_abs_edge_error']:.4f} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--materials", default="skin1,marble,ketchup")
    ap.add_argument("--model", default="montecarlo", help="source profile model [montecarlo]")
    ap.add_argument("--width", type=int, default=300)
    ap.add_argument("--height", type=int, default=48)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--methods", default="BURLEY,RANDOM_WALK")
    ap.add_argument("--rw-spp", type=int, default=64, help="samples for Random Walk (long walks at high albedo) [64]")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    data = run(args.materials.split(","), args.model, args.width, args.height, args.spp, args.methods.split(","), args.rw_spp)
    print(json.dumps(data) if args.json else markdown(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
