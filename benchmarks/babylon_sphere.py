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

Needs Chromium, Playwright and @babylonjs/core (ssskit.view.babylon). Progress on stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
import time


def run(materials: list[str], model: str, size: int, variant: str = "widest") -> dict:
    import numpy as np

    from ssskit.export import fit_burley
    from ssskit.export.babylon import babylon_module, babylon_parameters
    from ssskit.materials import get_material
    from ssskit.profiles import profile_for_material
    from ssskit.view.babylon import babylon_available, render_babylon, ssskit_pass, terminator_regions

    ok, why = babylon_available()
    if not ok:
        raise SystemExit(f"babylon_sphere: {why}")
    rows = []
    for name in materials:
        material = get_material(name)
        a, d = fit_burley(profile_for_material(material, model))
        params = babylon_parameters([(name, a, d)])
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
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    data = run(args.materials.split(","), args.model, args.size, args.variant)
    print(json.dumps(data) if args.json else markdown(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
