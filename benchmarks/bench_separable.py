"""Benchmark: the screen-space separable SSS pass (numba) vs scipy.ndimage.convolve1d, same run.

Both passes, 7 importance-sampled taps of the pre-integrated Skin1 kernel, depth-aware (the
follow-surface test on every sample), float32 RGB, every pixel inside the SSS mask, on a tilted
plane (depth varies across the image, so every pixel has its own footprint). The competitor is
two plain 7-tap ``convolve1d`` passes (axis 1 then axis 0, mode 'nearest') over the same (H, W, 3)
array with one weight vector: depth-unaware, mask-unaware, integer taps, the cheapest thing scipy
can be asked to do. Timings are medians of interleaved repeats. Prints one JSON object.

    NUMBA_THREADING_LAYER is set to 'workqueue' unless given.
    python benchmarks/bench_separable.py [--sizes 1280x720 1920x1080 3840x2160] [--repeats 9]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numba  # noqa: E402
import numpy as np  # noqa: E402
from scipy.ndimage import convolve1d  # noqa: E402

from ssskit.kernels import build_kernel, default_grid  # noqa: E402
from ssskit.profiles import profile_for_material  # noqa: E402
from ssskit.sampling.taps import make_taps  # noqa: E402
from ssskit.screenspace.separable import filter_arrays  # noqa: E402


def scene(width: int, height: int):
    rng = np.random.default_rng(0)
    image = rng.random((height, width, 3), dtype=np.float32)
    xx = np.arange(width, dtype=np.float32)[None, :]
    yy = np.arange(height, dtype=np.float32)[:, None]
    depth_mm = (400.0 + 0.1 * xx * (1920 / width) + 0.05 * yy * (1080 / height)).astype(np.float32)
    return image, depth_mm


def timed(fn, repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["1280x720", "1920x1080", "3840x2160"])
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--numpy-max-pixels", type=int, default=2_100_000,
                    help="time the numpy reference only up to this many pixels (it is slow)")
    args = ap.parse_args()

    profile = profile_for_material("skin1", "dipole")
    cell, n = default_grid(profile)
    taps = make_taps(build_kernel("preintegrated", profile, cell, n), 7, "importance")
    plain = np.ascontiguousarray(taps.weights[0][:, 0], dtype=np.float32)  # any 7 weights
    focal = 1000.0  # pixels at 1080p; scaled with the width so the footprint in pixels is the same

    results = []
    for size in args.sizes:
        width, height = (int(v) for v in size.lower().split("x"))
        image, depth = scene(width, height)
        f = focal * width / 1920
        scratch: dict = {}
        run_numba = lambda jit=0.0: filter_arrays(image, depth, f, f, taps, jitter=jit, depth_mode="follow",  # noqa: E731
                                                  scratch=scratch)

        def run_scipy():
            tmp = convolve1d(image, plain, axis=1, mode="nearest")
            return convolve1d(tmp, plain, axis=0, mode="nearest")

        run_numba()
        run_numba(0.1)
        run_scipy()
        t_numba, t_scipy, t_jit = [], [], []
        for _ in range(args.repeats):  # interleaved: both see the same machine state
            t_numba += timed(run_numba, 1)
            t_scipy += timed(run_scipy, 1)
            t_jit += timed(lambda: run_numba(0.1), 1)
        row = {
            "size": f"{width}x{height}",
            "numba_ms": 1e3 * statistics.median(t_numba),
            "numba_jitter10_ms": 1e3 * statistics.median(t_jit),
            "scipy_two_plain_passes_ms": 1e3 * statistics.median(t_scipy),
        }
        row["ratio_numba_over_scipy"] = row["numba_ms"] / row["scipy_two_plain_passes_ms"]
        row["numba_fps"] = 1e3 / row["numba_ms"]
        if width * height <= args.numpy_max_pixels:
            t_np = timed(lambda: filter_arrays(image, depth, f, f, taps, jitter=0.0, depth_mode="follow",
                                               backend="numpy"), 1)
            row["numpy_reference_ms"] = 1e3 * t_np[0]
        results.append(row)

    print(json.dumps({
        "benchmark": "separable screen-space SSS pass, 7 taps, both passes, depth-aware, float32 RGB",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "numba": numba.__version__,
                    "numpy": np.__version__, "threading_layer": os.environ["NUMBA_THREADING_LAYER"],
                    "threads": numba.get_num_threads()},
        "taps_mm": taps.offsets_mm[0].tolist(),
        "repeats": args.repeats,
        "results": results,
    }, indent=2))


if __name__ == "__main__":
    main()
