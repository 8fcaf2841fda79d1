"""Benchmark: the Burley Monte Carlo pass (Xie 2020, Sec. 4.2/5) on numba and on gl, vs the exact 2D
convolution by FFT, all in the same run.

The pass on the frame of ``bench_separable.py``: every pixel inside the SSS mask, a tilted plane (each
pixel its own footprint and depth difference), float32 RGB, Burley parameters of a skin-like material
(albedo 0.8/0.5/0.3, diffuse mean free path 2.0/1.0/0.5 mm, Eq. 5 configuration 3; about 2.5 pixels
per mm at 1080p, the focal length scaled with the width), the exact sampler and R2 sequence, no mips.

For every size and samples per pixel, timed in the same rounds (interleaved: every case sees the same
machine state; min, median and max over ``--repeats`` rounds):

* ``numba``: :func:`ssskit.screenspace.burley_sss` with ``backend="numba"`` (the public API: plan,
  checks, the kernel on ``numba.get_num_threads()`` threads);
* ``gl_api``: the same call with ``backend="gl"`` (upload, shader, readback);
* ``gl_device``: the gl shader alone on a frame already on the device (``BurleyFrame.run`` and glFinish:
  on Mesa's llvmpipe that is the shader's CPU time on all cores), the emulated GPU's best case;
* with ``--mips``, every case again with prefiltered mips (Xie Eqs. 22-23, a = 1/16; numba builds its pyramid
  in the call, gl_device runs the pyramid pass and the shader), ratio numba / gl_device per mips setting;
* ``fft``: the exact 2D convolution of the diffuse layer with R(r)'s cell integrals per channel (kernel
  radius: the largest channel's 0.999-energy radius) by ``scipy.signal.fftconvolve``: depth- and
  mask-unaware, the cheapest exact answer.

Ratios: numba / gl_device (the issue's target: <= 1) and numba / gl_api. Also at the first size >= 1080p
and 32 spp on numba: the xie and golubev samplers and the exact sampler with prefiltered mips (Xie Eqs.
22-23, the pyramid included), and the numpy oracle once per spp at ``--numpy-size`` (slow; scaled by
pixel count). ``--no-gl`` (or no EGL here) leaves the gl cases out, saying why. The load average is
printed before and after. Prints one JSON object.

    NUMBA_THREADING_LAYER is set to 'workqueue' unless given.
    python benchmarks/bench_burley.py [--sizes 480x270 1920x1080] [--spp 8 64] [--repeats 5] [--mips]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numba  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_separable import FOCAL_1080P, interleaved, scene  # noqa: E402

PARAMS = ((0.8, 0.5, 0.3), (2.0, 1.0, 0.5))  # albedo, dmfp (mm)


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


def gl_status() -> tuple[bool, str]:
    from ssskit.backends import backend_status

    st = backend_status()["gl"]
    return bool(st["available"]), str(st["details"])


def gl_device(gb, params, spp: int, mips: bool = False):
    """The gl shader on a frame kept on the device (with ``mips``: the pyramid pass too): returns (run-and-finish,
    release)."""
    from ssskit.backends.gl.burley import BurleyFrame
    from ssskit.backends.gl.context import context
    from ssskit.screenspace.burley import BurleySettings, burley_plan_for
    from ssskit.backends.plan import profile_ids

    cam = gb.camera
    plan = burley_plan_for(params, profile_ids(gb.profile_id), cam.fx, cam.fy, BurleySettings(spp=spp, mips=mips))
    frame = BurleyFrame(plan, gb.diffuse, gb.depth_mm, plan.slot_map(gb.profile_id), spp)
    ctx = context()

    def run():
        frame.run()
        ctx.finish()

    return run, frame.release


def stats(values_s: list[float]) -> dict:
    ms = [1e3 * v for v in values_s]
    return {"min_ms": round(min(ms), 3), "median_ms": round(statistics.median(ms), 3), "max_ms": round(max(ms), 3)}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["480x270", "1920x1080"])
    ap.add_argument("--spp", nargs="+", type=int, default=[8, 64])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--numpy-size", default="192x108", help="the numpy oracle's (small) frame")
    ap.add_argument("--no-gl", action="store_true", help="leave the gl backend out")
    ap.add_argument("--no-extras", action="store_true", help="leave out the samplers, mips and numpy rows")
    ap.add_argument("--mips", action="store_true",
                    help="every case also with prefiltered mips (Xie Eqs. 22-23, a = 1/16; the pyramid timed with it)")
    args = ap.parse_args(argv)
    import ssskit
    from ssskit.screenspace import BurleyParams, burley_sss

    params = BurleyParams.from_dmfp(*PARAMS)
    load_before = os.getloadavg()
    gl_ok, gl_why = (False, "left out (--no-gl)") if args.no_gl else gl_status()
    out: dict = {
        "benchmark": "Burley Monte Carlo screen-space SSS pass (Xie 2020 Eq. 24): numba vs gl, and exact 2D FFT",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "numba": numba.__version__,
                    "numpy": np.__version__, "threading_layer": os.environ["NUMBA_THREADING_LAYER"],
                    "threads": numba.get_num_threads(), "ssskit": str(Path(ssskit.__file__).parent)},
        "gl": gl_why, "params": {"albedo": list(params.albedo), "d_mm": list(params.d_mm)},
        "repeats": args.repeats, "sampler": "exact", "sequence": "r2", "cases": [],
    }
    for text in args.sizes:
        w, h = (int(v) for v in text.lower().split("x"))
        gb = gbuffer(w, h)
        fns = {"fft": fft_exact(gb, params)}
        releases = []
        mipses = (False, True) if args.mips else (False,)
        for n in args.spp:
            for mips in mipses:
                k = f"{n}_mips" if mips else f"{n}"
                fns[f"numba_{k}"] = lambda n=n, mips=mips: burley_sss(gb, params, spp=n, mips=mips, backend="numba")
                if gl_ok:
                    fns[f"gl_api_{k}"] = lambda n=n, mips=mips: burley_sss(gb, params, spp=n, mips=mips, backend="gl")
                    fns[f"gl_device_{k}"], rel = gl_device(gb, params, n, mips)
                    releases.append(rel)
        times = interleaved(fns, args.repeats)
        for rel in releases:
            rel()
        fft = stats(times["fft"])
        for n in args.spp:
            for mips in mipses:
                k = f"{n}_mips" if mips else f"{n}"
                case: dict = {"size": f"{w}x{h}", "spp": n, "mips": mips, "numba": stats(times[f"numba_{k}"]),
                              "fft": fft}
                med = case["numba"]["median_ms"]
                case["numba_gsamples_per_s"] = round(w * h * n / med / 1e6, 4)
                case["numba_over_fft"] = round(med / fft["median_ms"], 3)
                if gl_ok:
                    case["gl_api"] = stats(times[f"gl_api_{k}"])
                    case["gl_device"] = stats(times[f"gl_device_{k}"])
                    case["numba_over_gl_device"] = round(med / case["gl_device"]["median_ms"], 3)
                    case["numba_over_gl_api"] = round(med / case["gl_api"]["median_ms"], 3)
                out["cases"].append(case)
                print(json.dumps(case), file=sys.stderr, flush=True)
    if not args.no_extras:
        w, h = max((tuple(int(v) for v in t.lower().split("x")) for t in args.sizes), key=lambda s: s[0] * s[1])
        gb = gbuffer(w, h)
        fns = {f"numba_{s}": (lambda s=s: burley_sss(gb, params, spp=32, sampler=s, mips=False, backend="numba"))
               for s in ("exact", "xie", "golubev")}
        fns["numba_exact_mips"] = lambda: burley_sss(gb, params, spp=32, sampler="exact", mips=True, backend="numba")
        times = interleaved(fns, max(3, args.repeats // 2))
        out["numba_32spp"] = {"size": f"{w}x{h}", **{k: stats(v) for k, v in times.items()}}
        nw, nh = (int(v) for v in args.numpy_size.lower().split("x"))
        small = gbuffer(nw, nh)
        rows = []
        for n in args.spp:  # the oracle once per spp (slow), scaled by pixel count
            t0 = time.perf_counter()
            burley_sss(small, params, spp=n, sampler="exact", mips=False, backend="numpy")
            ms = 1e3 * (time.perf_counter() - t0)
            rows.append({"spp": n, "size": f"{nw}x{nh}", "ms_measured": round(ms, 1),
                         "ms_per_1080p_frame": round(ms * (1920 * 1080) / (nw * nh), 1)})
        out["numpy_oracle"] = rows
    out["load_average"] = {"before": load_before, "after": os.getloadavg()}
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
