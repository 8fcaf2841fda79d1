"""Blender EEVEE Next (the viewport's engine, headless on EGL) against Cycles' and ssskit's prediction: the slab
of ssskit.export.cycles_slab with its edge made by a spot cone's rim (EEVEE casts no shadow of the blocker
there), rendered with ssskit's Blender export (``cycles`` radius, and the ``eevee`` variant that undoes
EEVEE's s(A') narrowing), per material and channel: the plateau over the exported albedo and the distances at
which the edge falls to 25 / 10 / 3 / 1 %, as EEVEE / predicted (the prediction Cycles renders to 1-5 %).

    PYTHONPATH=src python benchmarks/blender_eevee.py            # markdown table (docs/exports.md)
    PYTHONPATH=src python benchmarks/blender_eevee.py --json

EEVEE's noise: each render's rows are split in 8 groups; the scatter of a distance over them, over sqrt(8), is
reported (its sparse bright rows are left out by a 25 % trimmed mean per column). Progress on stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile

TRIM = 0.25


def run(materials: list[str], model: str, width: int, height: int, samples: int, variants: list[str]) -> dict:
    from ssskit.export.blender import compare_slab, find_blender_python, render_slab
    from ssskit.export.engines import slab_material
    from ssskit.materials import get_material

    python, why = find_blender_python()
    if python is None:
        raise SystemExit(f"blender_eevee: {why}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in materials:
            material = get_material(name)
            _, script, a, d = slab_material(name, model, tmp)
            for variant in variants:
                render = render_slab(script, list(d), width, height, samples, seed=11, python=python, timeout=3600.0,
                                     engine="BLENDER_EEVEE_NEXT", variant=variant)
                cmp = compare_slab(render, a, d, trim=TRIM)
                rows.append({"material": material.name, "variant": variant, "blender": render["blender"],
                             "samples": samples, "seconds": render["seconds"], **cmp})
                print(json.dumps({k: rows[-1][k] for k in ("material", "variant")}), file=sys.stderr)
    return {"model": model, "width": width, "height": height, "samples": samples, "rows": rows}


def markdown(data: dict) -> str:
    from ssskit.export.blender import distance_cells

    out = [f"EEVEE Next {data['rows'][0]['blender']} (Mesa llvmpipe, EGL), {data['width']}x{data['height']} px per "
           f"channel view, {data['samples']} TAA samples (its subsurface gather: 16 samples per pixel per TAA sample), "
           f"source --model {data['model']}; the distances at 25 / 10 / 3 / 1 % of the plateau as EEVEE / predicted "
           "(the prediction Cycles renders), +- one standard error over 8 row groups",
           "",
           "| material | export | channel | plateau / albedo | 25 % | 10 % | 3 % | 1 % |",
           "|---|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        for c, ch in enumerate(r["channels"]):
            cells = distance_cells(ch, "ratio")
            out.append(f"| {r['material']} | {r['variant']} | {'RGB'[c]} | {ch['plateau_ratio']:.4f} ± "
                       f"{ch['plateau_se']:.4f} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--materials", default="skin1,marble,ketchup")
    ap.add_argument("--model", default="dipole", help="source profile model [dipole]")
    ap.add_argument("--width", type=int, default=200)
    ap.add_argument("--height", type=int, default=32)
    ap.add_argument("--samples", type=int, default=32, help="EEVEE's TAA render samples [32]")
    ap.add_argument("--variants", default="cycles,eevee")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    data = run(args.materials.split(","), args.model, args.width, args.height, args.samples, args.variants.split(","))
    print(json.dumps(data) if args.json else markdown(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
