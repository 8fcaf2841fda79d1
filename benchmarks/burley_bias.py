"""Bias of the Burley pass's approximations (issue 13): Xie's approximate inverse CDF (Eq. 21, c = 2.5715
and Unreal's 2.6) and the prefiltered mips (Eqs. 22-23, a = 1/256, 1/16, 1, 16), as RMSE and PSNR against
the converged reference, on a fronto-parallel G-buffer whose reference is exact, and on the four
built-in scenes against their converged references (:func:`scene_table`). The mips' a is read in
Xie's units (backends/burley_plan.py, step 5b).

The G-buffer: 128 x 96 pixels at 400 mm, 3 pixels per mm, one profile id on a disk of radius 40 px,
a textured diffuse layer (a sine grating, a hard vertical shadow edge and noise); Burley parameters
from albedo 0.6 and dmfp 8/4/2 mm (d = 2.0/1.0/0.5 mm, Eq. 5 configuration 3). The reference is
:func:`ssskit.pipeline.burley_frame.burley_exact` (the pass's exact limit: the exact sampler without mips
converges to it, tests/screenspace/test_burley_consistency.py).

For each configuration and n = 8, 16, 64 samples per pixel, K frames with independent seeds:

* ``frame_rmse`` / ``frame_psnr``: one frame against the reference (the mean over the K frames of
  the per-frame RMSE, and the PSNR of that RMSE): what a single frame looks like (noise + bias);
* ``bias_rmse`` / ``bias_psnr``: the mean of the K frames against the reference: the bias, plus a
  noise floor of about frame_rmse / sqrt(K) (the unbiased exact sampler without mips shows the floor).

Also Xie's comparison (Sec. 4.2: 1.87% RMS between Eq. 21 and MIS in PBRT at 2k spp): the relative
RMS difference between the xie sampler (c = 2.5715, 2.6) and the exact one, both converged (4096
spp, no mips, the same seed), on the head-on slab scene (Mitsuba G-buffer 128 x 96, the material's
Burley profile and dmfp 12/6/3 mm) and on the disk above: ``xie_vs_exact``.

PSNR = 20 log10(peak / RMSE) with peak = the reference's maximum inside the mask
(:func:`ssskit.metrics.region_metrics`), over all three channels inside the mask. Prints one JSON object.

    python benchmarks/burley_bias.py [--frames 32] [--spp 8 16 64] [--backend numba] [--scene-frames 8] [--size 160x120]
"""

from __future__ import annotations

import argparse
import json
import math
import os

import numpy as np

#: Eq. 22's a, in Xie's units (backends/burley_plan.py step 5b): Xie's 1/16 and powers of 16 around it
MIP_SCALES = (1 / 256, 1 / 16, 1.0, 16.0)
_A = {1 / 256: "1/256", 1 / 16: "1/16", 1.0: "1", 16.0: "16"}

CONFIGS = {
    "exact, no mips (unbiased)": dict(sampler="exact", mips=False),
    "xie c=2.5715, no mips": dict(sampler="xie", c=2.5715, mips=False),
    "xie c=2.6, no mips": dict(sampler="xie", c=2.6, mips=False),
    **{f"exact, mips a={_A[a]}": dict(sampler="exact", mips=True, mip_scale=a) for a in MIP_SCALES},
    "xie c=2.5715, mips a=1/16 (Xie 2020)": dict(sampler="xie", c=2.5715, mips=True, mip_scale=1 / 16),
}

#: the built-in scenes' table: Xie's pass (xie sampler) without and with mips at each a
SCENE_CONFIGS = {
    "xie c=2.5715, no mips": dict(sampler="xie", c=2.5715, mips=False),
    **{f"xie c=2.5715, mips a={_A[a]}": dict(sampler="xie", c=2.5715, mips=True, mip_scale=a) for a in MIP_SCALES},
}


def gbuffer():
    from ssskit.screenspace import Camera, GBuffer

    h, w = 96, 128
    rng = np.random.default_rng(5)
    yy, xx = np.mgrid[0:h, 0:w]
    e = 0.4 + 0.3 * np.sin(xx / 4.0)[..., None] * np.array([1.0, 0.6, 0.3]) + 0.2 * rng.random((h, w, 3))
    e[:, w // 2:] *= 0.15  # a hard shadow edge through the disk
    pid = ((xx - 64) ** 2 + (yy - 48) ** 2 < 40**2).astype(np.uint32)
    depth = np.where(pid > 0, 400.0, np.inf)
    return GBuffer(diffuse=e.astype(np.float32), albedo=np.ones((h, w, 3), np.float32), depth=depth.astype(np.float32),
                   profile_id=pid, camera=Camera(w, h, 1200.0, 1200.0, w / 2, h / 2))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=32)
    ap.add_argument("--spp", nargs="+", type=int, default=[8, 16, 64])
    ap.add_argument("--backend", default="numba")
    ap.add_argument("--converged-spp", type=int, default=4096)
    ap.add_argument("--scene-frames", type=int, default=8, help="frames per row of the scenes' table (0: skip it)")
    ap.add_argument("--size", default="160x120", help="the scenes' G-buffer size, WxH")
    args = ap.parse_args()
    from ssskit.pipeline.burley_frame import burley_exact
    from ssskit.screenspace import BurleyParams, burley_sss

    params = BurleyParams.from_dmfp(0.6, (8.0, 4.0, 2.0))
    gb = gbuffer()
    mask = gb.mask
    ref = burley_exact(gb, params).astype(np.float64)
    peak = float(ref[mask].max())

    def rmse(img):
        return float(np.sqrt(np.mean((img[mask] - ref[mask]) ** 2)))

    def psnr(e):
        return 20 * math.log10(peak / e) if e > 0 else None

    rows = []
    for name, cfg in CONFIGS.items():
        for n in args.spp:
            frames = [burley_sss(gb, params, spp=n, seed=1000 + k, backend=args.backend, **cfg).astype(np.float64)
                      for k in range(args.frames)]
            frame = float(np.mean([rmse(f) for f in frames]))
            bias = rmse(np.mean(frames, axis=0))
            rows.append({"config": name, "spp": n, "frame_rmse": frame, "frame_psnr": psnr(frame), "bias_rmse": bias,
                         "bias_psnr": psnr(bias), "mean_ratio": (np.mean(frames, axis=0)[mask].mean(axis=0)
                                                                / ref[mask].mean(axis=0)).tolist()})
    from ssskit.scenes import render_gbuffer
    from ssskit.screenspace.burley import burley_params_for_material

    head_on = []
    slab_params = {"skin1 (Burley profile)": burley_params_for_material("skin1"),
                   "dmfp 12/6/3 mm": BurleyParams.from_dmfp(0.6, (12.0, 6.0, 3.0))}
    cases = [("disk", gb, params)] + [(f"slab, {k}", render_gbuffer("slab", p.albedo, width=128, height=96, spp=8), p)
                                      for k, p in slab_params.items()]
    for label, g, p in cases:
        exact = burley_sss(g, p, spp=args.converged_spp, sampler="exact", mips=False, seed=7,
                           backend=args.backend).astype(np.float64)
        for c in (2.5715, 2.6):
            xie = burley_sss(g, p, spp=args.converged_spp, sampler="xie", c=c, mips=False, seed=7,
                             backend=args.backend).astype(np.float64)
            m = g.mask
            rel = float(np.sqrt(np.mean((xie[m] - exact[m]) ** 2)) / np.sqrt(np.mean(exact[m] ** 2)))
            head_on.append({"case": label, "c": c, "spp": args.converged_spp, "relative_rms": rel,
                            "d_mm": list(p.d_mm)})
    scenes = scene_table(args) if args.scene_frames > 0 else []
    print(json.dumps({"benchmark": "bias of the Burley pass's xie sampler and mips vs the exact limit",
                      "frames": args.frames, "backend": args.backend, "peak": peak, "cpus": os.cpu_count(),
                      "params": {"albedo": list(params.albedo), "d_mm": list(params.d_mm)}, "results": rows,
                      "xie_vs_exact": head_on, "scenes": scenes}, indent=2))


def scene_table(args) -> list[dict]:
    """The four built-in scenes (Mitsuba G-buffers, ``--size``, Skin1's Burley profile): for each
    configuration of :data:`SCENE_CONFIGS` and n of ``--spp``, ``--scene-frames`` frames against the
    converged reference (:func:`ssskit.pipeline.burley_frame.burley_reference`: exact sampler,
    ``--converged-spp``, no mips, seed 0). Per row: frame RMSE (mean over frames), its gray-scale PSNR
    (Xie 2020 Sec. 6; peak = the reference's gray maximum in the mask), bias RMSE (the frames' mean
    against the reference). The reference's own error: ``ref_se`` = RMS difference of two
    references with seeds 0 and 1 over sqrt(2)."""
    from ssskit.pipeline.burley_frame import burley_reference
    from ssskit.scenes import front_lit_scenes, render_gbuffer
    from ssskit.screenspace import burley_sss
    from ssskit.screenspace.burley import burley_params_for_material

    w, h = (int(v) for v in args.size.split("x"))
    params = burley_params_for_material("skin1")
    out = []
    for scene in front_lit_scenes():  # a scene lit only from behind is black here (no transmittance pass)
        gb = render_gbuffer(scene, params.albedo, width=w, height=h, spp=16)
        m = gb.mask
        ref = burley_reference(gb, params, spp=args.converged_spp, backend=args.backend).astype(np.float64)
        ref2 = burley_reference(gb, params, spp=args.converged_spp, seed=1, backend=args.backend).astype(np.float64)
        gray = ref[m].mean(axis=-1)
        peak = float(gray.max())

        def rmse(img):
            return float(np.sqrt(np.mean((img[m] - ref[m]) ** 2)))

        def gray_rmse(img):
            return float(np.sqrt(np.mean((img[m].mean(axis=-1) - gray) ** 2)))

        ref_se = rmse(ref2) / math.sqrt(2)
        for name, cfg in SCENE_CONFIGS.items():
            for n in args.spp:
                frames = [burley_sss(gb, params, spp=n, seed=2000 + k, backend=args.backend, **cfg).astype(np.float64)
                          for k in range(args.scene_frames)]
                frame = float(np.mean([rmse(f) for f in frames]))
                g = float(np.mean([gray_rmse(f) for f in frames]))
                bias = rmse(np.mean(frames, axis=0))
                out.append({"scene": scene, "config": name, "spp": n, "frame_rmse": frame,
                            "frame_psnr_gray": 20 * math.log10(peak / g), "bias_rmse": bias,
                            "ref_se": ref_se, "size": args.size})
    return out


if __name__ == "__main__":
    main()
