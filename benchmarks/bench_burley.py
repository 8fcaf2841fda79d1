"""Benchmark: the Burley Monte Carlo pass (Xie 2020, Sec. 4.2/5) vs the exact 2D convolution by FFT, same run.

The pass (:func:`ssskit.screenspace.burley_sss`) on a 1080p frame: every pixel inside the SSS mask,
a tilted plane (each pixel its own footprint and depth difference), float32 RGB, Burley parameters
of a skin-like material (albedo 0.8/0.5/0.3, diffuse mean free path 2.0/1.0/0.5 mm, Eq. 5
configuration 3; about 2.5 pixels per mm). For each backend and samples per pixel (8, 16, 32, 64):
ms per frame and samples per second (pixels x spp / time), without mips (nearest-texel fetches);
also, at 32 spp, the xie and golubev samplers and the exact sampler with prefiltered mips (Xie
Eqs. 22-23; the pyramid's construction included). The numba backend runs at 1920x1080; the
numpy oracle at a small size (it is slow), scaled to a 1080p frame by its pixel count.

Competitor, same image: the exact 2D convolution of the diffuse layer with R(r)'s cell integrals per
channel (the ground truth of the pass on a fronto-parallel surface: kernel radius = the largest
channel's 0.999-energy radius, :func:`ssskit.truth.exact_screen_space`'s choice) by
``scipy.signal.fftconvolve``: depth-unaware and mask-unaware, so the cheapest exact answer.

Timings are medians of interleaved repeats. Prints one JSON object.

    NUMBA_THREADING_LAYER is set to 'workqueue' unless given.
    python benchmarks/bench_burley.py [--spp 8 16 32 64] [--repeats 3] [--numpy-size 192x108]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numba  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_separable import FOCAL_1080P, median_ms, scene  # noqa: E402


def gbuffer(width: int, height: int):
    from ssskit.screenspace import Camera, GBuffer

    image, depth = scene(width, height)  # the frame of bench_separable.py
    f = FOCAL_1080P * width / 1920
    return GBuffer(diffuse=image, albedo=np.ones_like(image), depth=depth,
                   profile_id=np.ones((height, width), np.uint32), camera=Camera(width, height, f, f, width / 2,
                                                                                height / 2))


def fft_exact(gb, params):
    """The exact 2D convolution of the diffuse layer with R's cell integrals (0.999 radius), per channel."""
    from scipy.signal import fftconvolve

    prof = params.profile()
    pixel_mm = float(np.median(gb.depth_mm)) / gb.camera.fx
    half = int(np.ceil(float(np.max(prof.radius_at_fraction(0.999))) / pixel_mm))
    cells = prof.discretize_2d(pixel_mm, 2 * half + 1)
    cells = (cells / cells.sum(axis=(0, 1))).astype(np.float32)
    return lambda: np.stack([fftconvolve(gb.diffuse[..., c], cells[..., c], mode="same") for c in range(3)], axis=-1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", nargs="+", type=int, default=[8, 16, 32, 64])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--size", default="1920x1080", help="the numba backend's frame")
    ap.add_argument("--numpy-size", default="192x108", help="the numpy oracle's (small) frame")
    ap.add_argument("--samplers", nargs="+", default=["exact", "xie", "golubev"],
                    help="samplers timed at every spp (exact) or at 32 spp (the others)")
    args = ap.parse_args()
    import ssskit
    from ssskit.screenspace import BurleyParams, burley_sss

    params = BurleyParams.from_dmfp((0.8, 0.5, 0.3), (2.0, 1.0, 0.5))
    w, h = (int(v) for v in args.size.lower().split("x"))
    gb = gbuffer(w, h)
    fns = {"fft_exact_ms": fft_exact(gb, params)}
    for n in args.spp:
        fns[f"numba_exact_{n}spp_ms"] = lambda n=n: burley_sss(gb, params, spp=n, sampler="exact", mips=False,
                                                               backend="numba")
    for s in args.samplers:
        if s != "exact":
            fns[f"numba_{s}_32spp_ms"] = lambda s=s: burley_sss(gb, params, spp=32, sampler=s, mips=False,
                                                                backend="numba")
    fns["numba_exact_mips_32spp_ms"] = lambda: burley_sss(gb, params, spp=32, sampler="exact", mips=True,
                                                          backend="numba")
    m = median_ms(fns, args.repeats)
    rows = []
    for n in args.spp:
        ms = m[f"numba_exact_{n}spp_ms"]
        rows.append({"backend": "numba", "sampler": "exact", "spp": n, "size": f"{w}x{h}", "ms_per_frame": ms,
                     "samples_per_s": w * h * n / (ms / 1e3), "ratio_over_fft": ms / m["fft_exact_ms"]})
    for s in args.samplers:
        if s != "exact":
            ms = m[f"numba_{s}_32spp_ms"]
            rows.append({"backend": "numba", "sampler": s, "spp": 32, "size": f"{w}x{h}", "ms_per_frame": ms,
                         "samples_per_s": w * h * 32 / (ms / 1e3), "ratio_over_fft": ms / m["fft_exact_ms"]})
    ms = m["numba_exact_mips_32spp_ms"]
    rows.append({"backend": "numba", "sampler": "exact", "mips": True, "spp": 32, "size": f"{w}x{h}",
                 "ms_per_frame": ms, "samples_per_s": w * h * 32 / (ms / 1e3), "ratio_over_fft": ms / m["fft_exact_ms"]})
    nw, nh = (int(v) for v in args.numpy_size.lower().split("x"))
    small = gbuffer(nw, nh)
    for n in args.spp:  # the oracle once per spp (slow), scaled to the numba frame by pixel count
        t0 = time.perf_counter()
        burley_sss(small, params, spp=n, sampler="exact", mips=False, backend="numpy")
        ms = 1e3 * (time.perf_counter() - t0)
        rows.append({"backend": "numpy", "sampler": "exact", "spp": n, "size": f"{nw}x{nh}", "ms_measured": ms,
                     "ms_per_frame": ms * (w * h) / (nw * nh), "samples_per_s": nw * nh * n / (ms / 1e3),
                     "ratio_over_fft": ms * (w * h) / (nw * nh) / m["fft_exact_ms"]})
    out = {
        "benchmark": "Burley Monte Carlo screen-space SSS pass (Xie 2020 Eq. 24) vs exact 2D FFT convolution",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "numba": numba.__version__,
                    "numpy": np.__version__, "threading_layer": os.environ["NUMBA_THREADING_LAYER"],
                    "threads": numba.get_num_threads(), "load_average": os.getloadavg(),
                    "ssskit": str(Path(ssskit.__file__).parent)},
        "params": {"albedo": list(params.albedo), "d_mm": list(params.d_mm)},
        "repeats": args.repeats,
        "fft_exact_ms": m["fft_exact_ms"],
        "results": rows,
    }
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
