"""Why the head's path-traced references show colour speckle (issue 35, Build 6): the per-pixel noise of the
Mitsuba reference at a fixed spp, per boundary and integrator.

The hypothesis tested: the medium's boundary is a dielectric (``roughdielectric``, Beckmann alpha = 0.15,
:mod:`ssskit.scenes.reference`), so a shadow ray from a vertex *inside* the medium is blocked by it and the point
lights are reached only by next-event estimation at the boundary vertices, through the refraction lobe of the
rough interface. A point light cannot be hit by a sampled direction, so NEE is the only estimator; a peaky lobe
(small alpha) makes that estimate a rare, large contribution. Variants (everything else equal: the head's view,
Skin1, the lights, black surroundings, ``max_depth`` 1024, the same chunk seeds):

* ``rough-dielectric a=0.15`` -- the shipped reference;
* ``rough-dielectric a=0.05 / 0.3 / 0.6`` -- the same interface with a peakier / broader lobe;
* ``smooth dielectric`` -- Mitsuba ``dielectric`` (a delta lobe: NEE through it is impossible, only paths that
  leave the medium and hit nothing but black can carry light, so the image is black: the limit of the trend);
* ``index-matched`` -- Mitsuba ``null`` (:data:`ssskit.scenes.reference.BOUNDARIES`): no interface, shadow
  rays from every medium vertex reach the light (NEE inside the medium);
* ``a=0.15, volpath`` -- the shipped boundary with Mitsuba ``volpath`` instead of ``volpathmis``.

Measured per variant, on the G-buffer's SSS pixels (``all``) and on the lit pixels (E/pi above half its
maximum over the mask: flat, directly lit skin, no edge): the median and the 90th percentile of the per-pixel
relative standard error (green; batch method over ``--chunks`` independent chunks of ``--chunk-spp``), the
region's level (the path trace's diffuse part over E/pi, :func:`ssskit.figures.head.reference_levels`' measure)
with its standard error, and the share of the region's sum carried by its brightest 1 % of chunk-pixels (a
firefly measure). Prints one JSON object.

    nice -n 10 env PYTHONPATH=src python experiments/head_speckle.py [--view front] [--size 96x72]
        [--chunks 16 --chunk-spp 16] [--variants ...]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import Any

import numpy as np

VARIANTS = {
    "rough-dielectric a=0.15 (shipped)": ("roughdielectric", 0.15, "volpathmis"),
    "rough-dielectric a=0.05": ("roughdielectric", 0.05, "volpathmis"),
    "rough-dielectric a=0.3": ("roughdielectric", 0.3, "volpathmis"),
    "rough-dielectric a=0.6": ("roughdielectric", 0.6, "volpathmis"),
    "smooth dielectric": ("dielectric", None, "volpathmis"),
    "index-matched (null)": ("null", None, "volpathmis"),
    "rough-dielectric a=0.15, volpath": ("roughdielectric", 0.15, "volpath"),
}


def render_variant(sc: Any, material: Any, shell: str, alpha: float | None, integrator: str, chunks: int,
                   chunk_spp: int) -> np.ndarray:
    """(chunks, H, W, 3): independent chunk images of the head (``sc``) with the boundary ``shell``."""
    from ssskit.scenes.mitsuba_variant import interruptible_render
    from ssskit.scenes.reference import _interior, chunk_seed
    from ssskit.scenes.scenes import mitsuba, scene_dict

    gb = sc.gbuffer
    h, w = gb.mask.shape
    interior = _interior(material, "rough-dielectric" if shell != "null" else "index-matched")
    if shell == "dielectric":
        interior = {"type": "dielectric", "int_ior": interior["int_ior"], "ext_ior": interior["ext_ior"],
                    "__medium": interior["__medium"]}
    elif shell == "roughdielectric":
        interior = {**interior, "alpha": float(alpha)}  # type: ignore[arg-type]
    black = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.0}}
    spec = sc.spec
    d = scene_dict(spec, w, h, 1, 0, 0, {"type": integrator, "max_depth": 1024},
                   lambda sid: interior if sid in spec.sss_shapes else black)
    scene = mitsuba().load_dict(d)
    return np.stack([np.array(interruptible_render(scene, seed=chunk_seed(0, i), spp=chunk_spp), np.float64)[..., :3]
                     for i in range(chunks)])


def measure(sc: Any, imgs: np.ndarray) -> dict[str, Any]:
    """The per-pixel and region statistics of one variant's chunk images (module docstring)."""
    from ssskit.figures.head import _masks
    from ssskit.scenes.reference import batch_mean_se

    gb = sc.gbuffer
    spec_layer = gb.specular.astype(np.float64)
    e = gb.diffuse.astype(np.float64)
    mean, se = batch_mean_se(imgs)
    g_light = e[..., 1]
    lit = gb.mask & (g_light > 0.5 * g_light[gb.mask].max())
    masks, _ = _masks(sc)
    out: dict[str, Any] = {}
    for name, m in {"all": gb.mask, "lit": lit, **masks}.items():
        if int(m.sum()) < 4:
            continue
        ok = m & (mean[..., 1] > 0)
        rel = se[..., 1][ok] / mean[..., 1][ok]
        # the region's level (ssskit.metrics.region_level): mean(diffuse part) / mean(E/pi), green; its SE from
        # the spread of the chunks' levels
        per_chunk = (imgs - spec_layer)[..., 1][:, m].mean(axis=1) / e[..., 1][m].mean()
        vals = np.sort((imgs[..., 1][:, m]).ravel())
        top = vals[int(0.99 * vals.size):].sum() / max(vals.sum(), 1e-300)
        out[name] = {"pixels": int(m.sum()), "pixel_rel_se_median": float(np.median(rel)) if rel.size else None,
                     "pixel_rel_se_p90": float(np.percentile(rel, 90)) if rel.size else None,
                     "level_g": float(per_chunk.mean()), "level_g_se": float(per_chunk.std(ddof=1) / np.sqrt(len(per_chunk))),
                     "top1pct_share": float(top)}
    return out


def main(argv: list[str] | None = None) -> dict[str, Any]:
    from ssskit.figures.head import _homogeneous, head_view
    from ssskit.materials import get_material

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--view", default="front")
    ap.add_argument("--size", default="96x72")
    ap.add_argument("--chunks", type=int, default=16)
    ap.add_argument("--chunk-spp", type=int, default=16)
    ap.add_argument("--variants", nargs="+", default=None, help="names containing one of these words (default: all)")
    ap.add_argument("--save", default=None, help="write the chunk means (npz) here, for the figure")
    args = ap.parse_args(argv)
    w, h = (int(v) for v in args.size.lower().split("x"))
    t0 = time.perf_counter()
    load0 = os.getloadavg()
    sc = head_view(args.view, "skin1", w, h)
    mat = _homogeneous(get_material("skin1"))
    res: dict[str, Any] = {}
    saved = {}
    for name, (shell, alpha, integ) in VARIANTS.items():
        if args.variants and not any(v in name for v in args.variants):
            continue
        t1 = time.perf_counter()
        imgs = render_variant(sc, mat, shell, alpha, integ, args.chunks, args.chunk_spp)
        res[name] = {"seconds": round(time.perf_counter() - t1, 1), **measure(sc, imgs)}
        saved[name] = imgs.mean(axis=0)
        print(json.dumps({name: res[name]}), file=sys.stderr, flush=True)
    out = {"experiment": "per-pixel noise of the head's path trace per boundary and integrator", "view": args.view,
           "size": [w, h], "spp": args.chunks * args.chunk_spp, "chunks": args.chunks, "variants": res,
           "seconds": round(time.perf_counter() - t0, 1), "load_average": {"before": load0, "after": os.getloadavg()}}
    if args.save:
        np.savez_compressed(args.save, **{k.replace(" ", "_"): v for k, v in saved.items()})
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
