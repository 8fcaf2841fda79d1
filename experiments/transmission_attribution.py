"""What is left of the back-lit ear's difference with the transmittance pass (issue 25; lab.transmitted):

    python experiments/transmission_attribution.py [--size 160x120] [--spp 4096] [--skip-oblique]

Prints one JSON object: ``transmitted``, the transmitted part alone per region (the pass's T E / pi against the
reference as rendered less the reference with a black backing behind the unseen surface, both 4096 spp, the
demo's regions) for the MCML model as it was (whole Tt along the light's chord), with the unscattered beam
taken out, along the surface normal, and with the lateral spread; ``map_resolution``, the same with the
light-space depth ray-cast at 1, 2 and 4 times the frame's size; ``oblique``, MCML's scattered transmittance
of Skin1 slabs lit at 0-60 degrees against the pass's two thicknesses (lab.transmitted.oblique_table);
``slab_faces``, the back-lit 0.5 and 1 mm slabs path-traced with MCML's smooth faces and with the references'
rough ones, against MCML at the camera's 45 degrees (lab.transmitted.slab_face_levels). The
references are cached (the as-rendered one is ``ssskit render --scene ear --size 160x120 --spp 16
--transmission on --reference --reference-spp 4096 --reference-max-spp 4096``'s).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numpy as np  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", default="160x120")
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--skip-oblique", action="store_true")
    ap.add_argument("--skip-faces", action="store_true")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))

    from lab.transmitted import map_resolution_pass, oblique_table, slab_face_levels, transmitted_table
    from lab.variants import backed_scene
    from ssskit.backends.spread_plan import build_spread_plan
    from ssskit.backends import get_backend
    from ssskit.materials import get_material
    from ssskit.metrics import region_masks
    from ssskit.pipeline import RenderSettings, render
    from ssskit.pipeline.regions import pixel_mm
    from ssskit.profiles import profile_for_material
    from ssskit.scenes import render_reference
    from ssskit.screenspace.transmission import mcml_model, mcml_spread, transmission_plan

    t0 = time.perf_counter()
    mat = get_material("skin1")
    res = render("ear", RenderSettings(width=w, height=h, spp=16, transmission="on", reference=True,
                                       reference_spp=args.spp, reference_max_spp=args.spp, perceptual=False,
                                       exact=False, backend="numpy"))
    gb, ref = res.gbuffer, res.reference_info
    backed = render_reference(backed_scene("ear"), mat, w, h, spp=args.spp, max_spp=args.spp, region=gb.mask, seed=0,
                              progress=False)
    prof = profile_for_material(mat, "montecarlo")
    radius_px = float(np.max(prof.radius_at_fraction(0.99))) / pixel_mm(gb)
    masks = {k: v for k, v in region_masks(gb.diffuse, gb.mask, radius_px).items() if k in ("silhouette", "shadow_edge")}
    masks["object"] = gb.mask
    e = gb.diffuse.astype(np.float64)
    spec = gb.specular.astype(np.float64)
    slots = (gb.profile_id > 0).astype(np.int32)
    uvz, shadow, ndl, light = gb.transmission_inputs()
    numpy = get_backend("numpy")
    splan = build_spread_plan({1: mcml_spread(mat)}, gb.camera.fx, gb.camera.fy)
    variants = {"whole Tt, light's chord (before)": (dict(part="total", along_normal=False), False),
                "scattered part, light's chord": (dict(part="diffuse", along_normal=False), False),
                "scattered part, along the normal": (dict(part="diffuse", along_normal=True), False),
                "scattered part, along the normal, spread (--transmission-spread mcml)": (dict(part="diffuse", along_normal=True), True)}
    out: dict = {"size": [w, h], "spp": args.spp, "transmitted": {}, "map_resolution": {}}
    for label, (kw, spread) in variants.items():
        ex = np.maximum(np.asarray(numpy.transmission(transmission_plan({1: mcml_model(mat, **kw)}), slots, uvz, shadow,
                                                      ndl, light)), 0.0)
        if spread:
            ex = numpy.transmission_spread(splan, ex, gb.depth_mm, slots, uvz, shadow)
        out["transmitted"][label] = transmitted_table(ex / math.pi, np.asarray(ref.image) - spec,
                                                      np.asarray(backed.image) - spec, ref.pixel_se, backed.pixel_se,
                                                      e, masks)
    plan = transmission_plan({1: mcml_model(mat)})
    for k in (1, 2, 4):
        ex = map_resolution_pass("ear", gb, plan, k)
        out["map_resolution"][f"x{k}"] = transmitted_table(ex / math.pi, np.asarray(ref.image) - spec,
                                                           np.asarray(backed.image) - spec, ref.pixel_se,
                                                           backed.pixel_se, e, masks)
    if not args.skip_oblique:
        out["oblique"] = oblique_table(mat, (1.0, 2.0, 3.0), (0.0, 30.0, 45.0, 60.0))
    if not args.skip_faces:
        out["slab_faces"] = []
        from ssskit.profiles.montecarlo import simulate
        from ssskit.profiles.montecarlo.slab import slab_config

        for i, t in enumerate((0.5, 1.0)):
            mc = [simulate(slab_config(mat, c, t, 400_000, 5000 + i)).tt_level_at(math.sqrt(0.5)) for c in range(3)]
            for faces in ("smooth", "rough"):
                row = slab_face_levels(t, faces, mat)
                row["mcml_at_45"] = [v[0] for v in mc]
                out["slab_faces"].append(row)
    out["seconds"] = round(time.perf_counter() - t0, 1)
    out["load_after"] = os.getloadavg()
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
