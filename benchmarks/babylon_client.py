"""Babylon.js (the client, headless Chromium) against ssskit's prediction: the shadow-edge slab of
ssskit.view.babylon rendered with ssskit's Babylon export, per material and channel: the plateau over the
exported albedo and the distances at which the normalised edge falls to 25 / 10 / 3 / 1 %, for the export's
variants and for the renders that settle how Babylon reads the profile colour.

    PYTHONPATH=src python benchmarks/babylon_client.py            # markdown table (docs/exports.md)
    PYTHONPATH=src python benchmarks/babylon_client.py --json     # one JSON object

Each render is deterministic (Babylon's pass has no per-frame rotation): its noise is the pass's fixed
sample pattern, reported as the scatter of the distance over 8 groups of rows (0 where rows agree).
Needs Chromium, Playwright and @babylonjs/core (ssskit.view.babylon). Progress on stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
import time


def cases(name: str, a, d, params) -> list[tuple[str, dict, list[float]]]:
    """(label, job overrides, the d (mm) per channel that reading predicts): the export's three variants, and
    the renders that settle the colour's reading (the other reading: colour = d; the other order: r, b, g)."""
    import numpy as np

    d = np.asarray(d, dtype=float)
    plain = params["variants"]["plain"]
    return [
        ("documented", {"variant": "documented"}, list(d)),
        ("plain", {"variant": "plain"}, list(d)),
        ("widest (default)", {"variant": "widest"}, list(d)),
        ("colour = d (the other reading), plain", {"variant": "plain", "override": {"color": list(d)}},
         list(1.0 / d)),
        ("colour in r, b, g order, plain", {"variant": "plain", "override": {
            "color": [1 / d[0], 1 / d[2], 1 / d[1]], "metersPerUnit": plain["metersPerUnit"]}}, [d[0], d[2], d[1]]),
    ]


def run(materials: list[str], model: str, height: int, max_width: int, labels: list[str] | None = None) -> dict:
    import numpy as np

    from ssskit.export import fit_burley
    from ssskit.export.babylon import babylon_module, babylon_parameters
    from ssskit.export.blender import compare_slab, edge_distances
    from ssskit.materials import get_material
    from ssskit.profiles import profile_for_material
    from ssskit.view.babylon import babylon_available, crop_view, render_babylon

    ok, why = babylon_available()
    if not ok:
        raise SystemExit(f"babylon_client: {why}")
    rows = []
    for name in materials:
        material = get_material(name)
        a, d = fit_burley(profile_for_material(material, model))
        params = babylon_parameters([(name, a, d)])
        text = babylon_module(params, name)
        todo = [c for c in cases(name, a, d, params) if labels is None or c[0] in labels]
        # one view per material: wide enough that no sample of any case leaves it (Babylon's samples past the
        # screen's edge read the other side), pixels a quarter of the narrowest d
        reach = max(max(params["variants"][v]["filter_radius_mm"].values()) for v in ("plain", "widest"))
        ext = 2.2 * reach + 1.6 * float(edge_distances(float(np.max(d)), (0.01,))[0])
        width = int(min(max_width, np.ceil(2 * ext / (float(np.min(d)) / 4)) // 8 * 8))
        job = {"width": width, "height": height, "extent": ext, "intensity": 0.5, "shape": "slab", "material": name}
        t0 = time.perf_counter()
        res = render_babylon(text, [dict(job, white=True)] + [dict(job, **c[1]) for c in todo])
        margin = 1.05 * 2.0 * reach  # the documented variant's samples reach twice its filter radius
        white, ext_c = crop_view(res[0]["image"], ext, margin)
        for (label, _, dpred), r in zip(todo, res[1:]):
            img = crop_view(r["image"], ext, margin)[0]
            render = {"images": [img] * 3, "white": [white] * 3, "extent_mm": [ext_c] * 3}
            cmp = compare_slab(render, np.asarray(a), np.asarray(dpred))
            rows.append({"material": material.name, "case": label, "width": width, "height": height,
                         "extent_mm": ext, "pixel_mm": 2 * ext / width, "d_predicted_mm": list(map(float, dpred)),
                         "babylon": r["info"]["version"], **cmp})
            print(json.dumps({k: rows[-1][k] for k in ("material", "case", "width")}), file=sys.stderr)
        print(f"babylon_client: {name} {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return {"model": model, "rows": rows}


def markdown(data: dict) -> str:
    from ssskit.export.blender import distance_cells

    out = [f"Babylon.js {data['rows'][0]['babylon']} (headless Chromium, SwiftShader WebGL2), source --model "
           f"{data['model']}; the distances at 25 / 10 / 3 / 1 % of the plateau as rendered / predicted - 1 "
           "(+- the scatter over row groups; the pass is deterministic)",
           "",
           "| material | case | px (mm) | channel | plateau / albedo | 25 % | 10 % | 3 % | 1 % |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        for c, ch in enumerate(r["channels"]):
            cells = distance_cells(ch, "error")
            out.append(f"| {r['material']} | {r['case']} | {r['pixel_mm']:.3f} | {'RGB'[c]} | "
                       f"{ch['plateau_ratio']:.4f} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--materials", default="skin1,marble,ketchup")
    ap.add_argument("--model", default="dipole", help="source profile model [dipole]")
    ap.add_argument("--height", type=int, default=8)
    ap.add_argument("--max-width", type=int, default=4096)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    data = run(args.materials.split(","), args.model, args.height, args.max_width)
    print(json.dumps(data) if args.json else markdown(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
