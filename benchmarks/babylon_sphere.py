"""Babylon.js (the client, headless Chromium) on a sphere against ssskit's own numpy Burley pass run on the
G-buffer read back from the same page: per material, the sphere of ssskit.view.babylon (``shape: "sphere"``,
the 45-degree sun, its terminator from N.L) rendered with ssskit's Babylon export (default variant), then
what Babylon's subsurface pass read (the pre-pass irradiance over sqrt(albedo), the profile index, view z in
mm) fed to :func:`ssskit.screenspace.burley_sss` (numpy backend, Golubev's sampler as Babylon's pass uses,
no mips) with the exported A and d. Reported per channel: the mean blurred irradiance (Babylon's output over
sqrt(albedo), the pass's own factor; ``--variant`` picks the export's variant) in regions chosen from the G-buffer alone: lit (N.L >= 0.5 of its
maximum), twilight (0 < N.L < 0.1) and the dark side in bands of distance past the terminator (0-1 and
1-3 times the material's widest d), both ways and as a ratio; the unblurred irradiance there; and ssskit's
pass with every depth step doubled (what the export's metersPerUnit x 2 does to Babylon's bilateral weight).

    PYTHONPATH=src python benchmarks/babylon_sphere.py            # markdown table (docs/exports.md)
    PYTHONPATH=src python benchmarks/babylon_sphere.py --json     # one JSON object
    PYTHONPATH=src python benchmarks/babylon_sphere.py --slab     # the shadow-edge slab, both ways

Needs Chromium, Playwright and @babylonjs/core (ssskit.view.babylon). Progress on stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
import time


def materials_of(names: list[str], model: str):
    """Per name (after checking the client is here): the material, its Burley fit A and d, and its Babylon
    export's parameters (one material per scene)."""
    from ssskit.export import fit_burley
    from ssskit.export.babylon import babylon_parameters
    from ssskit.materials import get_material
    from ssskit.profiles import profile_for_material
    from ssskit.view.babylon import babylon_available

    ok, why = babylon_available()
    if not ok:
        raise SystemExit(f"babylon_sphere: {why}")
    for name in names:
        material = get_material(name)
        a, d = fit_burley(profile_for_material(material, model))
        yield name, material, a, d, babylon_parameters([(name, a, d)])


def run(materials: list[str], model: str, size: int, variant: str = "widest") -> dict:
    import numpy as np

    from ssskit.export.babylon import babylon_module
    from ssskit.view.babylon import render_babylon, ssskit_pass, terminator_regions

    rows = []
    for name, material, a, d, params in materials_of(materials, model):
        dmax = float(np.max(d))
        radius = 8.0 * dmax
        ext = 1.25 * radius
        job = {"width": size, "height": size, "extent": ext, "intensity": 2.0, "shape": "sphere", "radius": radius,
               "material": name, "variant": variant, "gbuffer": True}
        t0 = time.perf_counter()
        res = render_babylon(babylon_module(params, name), [job])[0]
        t_render = time.perf_counter() - t0
        g = res["gbuffer"]
        sqrt_a = np.sqrt(np.asarray(a, dtype=np.float32))
        babylon = res["image"] / sqrt_a  # the pass's output is inputColor + sqrt(albedo) x blurred irradiance
        t0 = time.perf_counter()
        ours = ssskit_pass(g, a, d)
        t_numpy = time.perf_counter() - t0
        ours2 = ssskit_pass(g, a, d, depth_scale=2.0)  # the export's metersPerUnit x 2 on the bilateral weight
        pixel_mm = 2.0 * ext / size
        for region, mask in terminator_regions(g, pixel_mm, dmax).items():
            n = int(mask.sum())
            lv = {k: [float(img[..., c][mask].mean()) if n else None for c in range(3)]
                  for k, img in (("irradiance", g["irradiance"]), ("babylon_level", babylon), ("numpy", ours),
                                 ("numpy_dz2", ours2))}
            rows.append({"material": material.name, "region": region, "pixels": n, "pixel_mm": pixel_mm,
                         "radius_mm": radius, "d_mm": list(map(float, d)), "clipped": res["info"]["clipped"],
                         "babylon": res["info"]["version"], **lv})
        print(f"babylon_sphere: {name} render {t_render:.1f} s, numpy pass {t_numpy:.1f} s", file=sys.stderr)
    return {"model": model, "size": size, "variant": variant, "rows": rows}


def run_slab(materials: list[str], model: str, max_width: int) -> dict:
    """The shadow-edge slab of benchmarks/babylon_client.py (the same view and crop), the export's default
    variant, with its G-buffer read back: per channel the plateau and the 25 / 10 / 3 / 1 % edge distances
    (:func:`ssskit.export.blender.compare_slab`, the read-back irradiance as the white reference) of Babylon's
    output and of ssskit's numpy pass on the same G-buffer, and ssskit's Burley prediction."""
    import numpy as np

    from ssskit.export.babylon import babylon_module
    from ssskit.export.blender import compare_slab, edge_distances
    from ssskit.view.babylon import crop_view, render_babylon, ssskit_pass

    rows = []
    for name, material, a, d, params in materials_of(materials, model):
        reach = max(params["variants"]["widest"]["filter_radius_mm"].values())
        ext = 2.2 * reach + 1.6 * float(edge_distances(float(np.max(d)), (0.01,))[0])
        width = int(min(max_width, np.ceil(2 * ext / (float(np.min(d)) / 4)) // 8 * 8))
        job = {"width": width, "height": 8, "extent": ext, "intensity": 0.5, "shape": "slab", "material": name,
               "variant": "widest", "gbuffer": True}
        res = render_babylon(babylon_module(params, name), [job])[0]
        g = res["gbuffer"]
        babylon = res["image"] / np.sqrt(np.asarray(a, dtype=np.float32))
        # ssskit's pass drops samples that leave the screen, Babylon's read the other side (its wrap): on the
        # 8-row strip, whose rows are alike, ssskit's pass gets the strip tiled to past the filter radius
        # vertically (what the wrap reads), with the field of view to match, and its middle 8 rows are kept
        k = 2 * int(np.ceil(1.05 * reach / (2 * ext / width) / 8)) + 1
        tall = {"irradiance": np.tile(g["irradiance"], (k, 1, 1)), "profile": np.tile(g["profile"], (k, 1)),
                "sss": np.tile(g["sss"], (k, 1)), "depth": np.tile(g["depth"], (k, 1)),
                "fov": 2 * float(np.arctan(np.tan(0.5 * g["fov"]) * k))}
        ours = ssskit_pass(tall, a, d)[8 * (k // 2):8 * (k // 2) + 8]
        white, ext_c = crop_view(g["irradiance"], ext, 1.05 * reach)
        cmp = {}
        for who, img in (("babylon", babylon), ("numpy", ours)):
            render = {"images": [crop_view(img, ext, 1.05 * reach)[0]] * 3, "white": [white] * 3,
                      "extent_mm": [ext_c] * 3}
            cmp[who] = compare_slab(render, np.ones(3), np.asarray(d))["channels"]
        for c in range(3):
            rows.append({"material": material.name, "channel": "RGB"[c], "pixel_mm": 2 * ext / width,
                         "predicted_mm": [float(v) for v in edge_distances(float(d[c]))],
                         **{who: {"plateau": ch[c]["plateau_ratio"],
                                  "distances_mm": [x["measured_mm"] for x in ch[c]["distances"]]}
                            for who, ch in cmp.items()}})
        print(f"babylon_sphere: slab {name} done", file=sys.stderr)
    return {"model": model, "shape": "slab", "rows": rows}


def markdown_slab(data: dict) -> str:
    out = ["The slab's shadow edge (default export), Babylon's output over sqrt(albedo) and ssskit's numpy pass on "
           "the G-buffer read back from the page, each normalised by the read-back irradiance: plateau (1 = "
           "the irradiance) and the distances (mm) at 25 / 10 / 3 / 1 %, with ssskit's Burley prediction",
           "",
           "| material | channel | px (mm) | plateau Babylon / numpy | Babylon (mm) | numpy (mm) | predicted (mm) |",
           "|---|---|---|---|---|---|---|"]

    def mm(v):
        return " / ".join("-" if x is None else f"{x:.3f}" for x in v)

    for r in data["rows"]:
        out.append(f"| {r['material']} | {r['channel']} | {r['pixel_mm']:.3f} | {r['babylon']['plateau']:.4f} / "
                   f"{r['numpy']['plateau']:.4f} | {mm(r['babylon']['distances_mm'])} | "
                   f"{mm(r['numpy']['distances_mm'])} | {mm(r['predicted_mm'])} |")
    return "\n".join(out)


def markdown(data: dict) -> str:
    r0 = data["rows"][0]
    out = [f"Babylon.js {r0['babylon']} (headless Chromium, SwiftShader WebGL2) against ssskit's numpy Burley pass "
           f"(Golubev sampler, 64 spp cap, no mips) on the G-buffer read back from the page, {data['size']}^2 "
           f"pixels, sphere radius 8 d_max, source --model {data['model']}, export variant {data.get('variant', 'widest')}; mean blurred "
           "irradiance per region (R / G / B)",
           "",
           "| material | region | pixels | irradiance (unblurred) | Babylon | ssskit numpy | Babylon / numpy | "
           "numpy, depth steps x 2 | Babylon / that |",
           "|---|---|---|---|---|---|---|---|---|"]

    def trip(v):
        return " / ".join("-" if x is None else f"{x:.4f}" for x in v)

    def ratio(num, den):
        return " / ".join("-" if (b is None or n is None or n == 0) else f"{b / n:.3f}" for b, n in zip(num, den))

    for r in data["rows"]:
        out.append(f"| {r['material']} | {r['region']} | {r['pixels']} | {trip(r['irradiance'])} | "
                   f"{trip(r['babylon_level'])} | {trip(r['numpy'])} | {ratio(r['babylon_level'], r['numpy'])} | "
                   f"{trip(r['numpy_dz2'])} | {ratio(r['babylon_level'], r['numpy_dz2'])} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--materials", default="skin1,marble,ketchup")
    ap.add_argument("--model", default="dipole", help="source profile model [dipole]")
    ap.add_argument("--size", type=int, default=192, help="image width and height in pixels [192]")
    ap.add_argument("--variant", default="widest", help="the export's variant [widest]")
    ap.add_argument("--slab", action="store_true", help="the shadow-edge slab instead of the sphere")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.slab:
        data = run_slab(args.materials.split(","), args.model, 4096)
        print(json.dumps(data) if args.json else markdown_slab(data))
        return 0
    data = run(args.materials.split(","), args.model, args.size, args.variant)
    print(json.dumps(data) if args.json else markdown(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
