"""Benchmark: the screen-space separable SSS pass (numba backend) vs scipy.ndimage.convolve1d, same run.

Both passes, 7 importance-sampled taps of the pre-integrated Skin1 kernel, depth-aware (the
follow-surface test on every sample), float32 RGB, every pixel inside the SSS mask, on a tilted
plane (depth varies across the image, so every pixel has its own footprint). The competitor is
two plain 7-tap ``convolve1d`` passes (axis 1 then axis 0, mode 'nearest') over the same (H, W, 3)
array with one weight vector: depth-unaware, mask-unaware, integer taps, the cheapest thing scipy
can be asked to do. Also timed: the paper's 10% jitter, and a G-buffer with three profile ids
(three materials, each with its own taps, in one pass) against the same G-buffer with one id (the
mean over the three materials, and with the same taps everywhere).
Also timed, the issue-27 figures: the public API (``separable_sss`` on a GBuffer, every per-frame step
included) with 10% jitter against OpenCV's plain 7-tap ``sepFilter2D`` on the same float32 image (if
OpenCV is installed: ``pip install opencv-python-headless``; it is a competitor here, never a
dependency), and a numpy copy of the image. Timings are medians of interleaved repeats, with min,
median and max of each; the load average before and after. Prints one JSON object.

``--before REV`` also times the same cases with the code of git revision REV (checked out into
the git-ignored ``benchmarks/.before-<rev>/`` and run in a subprocess, in the same run), so a
change is judged by its ratio to scipy before and after. ``--ab REV --rounds N`` instead alternates
the two versions round by round (this checkout, REV, this checkout, ...; each round a new process that
times every case ``--repeats`` times), so that both see the same machine load; it reports each round's
medians and, per version, the min / median / max over the rounds of the API's time, OpenCV's time and
their ratio (each round's ratio from one process).

    NUMBA_THREADING_LAYER is set to 'workqueue' unless given.
    python benchmarks/bench_separable.py [--sizes 960x540 1920x1080 3840x2160] [--repeats 9] [--before 11c9ea3]
    python benchmarks/bench_separable.py --sizes 960x540 1920x1080 --repeats 5 --ab c1d0039 --rounds 5
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numba  # noqa: E402
import numpy as np  # noqa: E402
from scipy.ndimage import convolve1d  # noqa: E402

FOCAL_1080P = 1000.0  # pixels at 1080p; scaled with the width so the footprint in pixels is the same


def scene(width: int, height: int):
    rng = np.random.default_rng(0)
    image = rng.random((height, width, 3), dtype=np.float32)
    xx = np.arange(width, dtype=np.float32)[None, :]
    yy = np.arange(height, dtype=np.float32)[:, None]
    depth_mm = (400.0 + 0.1 * xx * (1920 / width) + 0.05 * yy * (1080 / height)).astype(np.float32)
    return image, depth_mm


def median_ms(fns: dict, repeats: int) -> dict:
    """Interleaved repeats (every case sees the same machine state); medians in ms."""
    for fn in fns.values():
        fn()
    times = {k: [] for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
    return {k: 1e3 * statistics.median(v) for k, v in times.items()}


def taps_for(material: str, spec: str = "preintegrated", n: int = 7):
    from ssskit.kernels import build_kernel, default_grid
    from ssskit.profiles import profile_for_material
    from ssskit.sampling.taps import make_taps

    profile = profile_for_material(material, "dipole")
    cell, size = default_grid(profile)
    return make_taps(build_kernel(spec, profile, cell, size), n, "importance")


def spread_ms(times_s: list[float]) -> dict:
    ms = [1e3 * t for t in times_s]
    return {"min": round(min(ms), 3), "median": round(statistics.median(ms), 3), "max": round(max(ms), 3)}


def interleaved(fns: dict, repeats: int) -> dict:
    """Every function once (warm-up), then ``repeats`` rounds calling each in turn: {name: [seconds]}."""
    for fn in fns.values():
        fn()
    times: dict = {k: [] for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
    return times


def opencv():
    """cv2, or None with the reason (OpenCV is a benchmark competitor only, never a dependency of ssskit)."""
    try:
        import cv2
    except ImportError as exc:
        return None, f"not run: OpenCV is not installed ({exc}; pip install opencv-python-headless)"
    return cv2, f"OpenCV {cv2.__version__}, {cv2.getNumThreads()} threads"


def time_sizes(sizes, repeats: int, numpy_max_pixels: int) -> list[dict]:
    """The pass (this checkout's API or, via filter_arrays' keywords, an older one) vs scipy and OpenCV per size.

    Per size, interleaved: ``filter_arrays`` without and with 10% jitter; the public API
    (:func:`ssskit.screenspace.separable_sss` on a GBuffer) with 10% jitter; scipy's two plain 7-tap
    ``convolve1d`` passes; OpenCV's plain 7-tap ``sepFilter2D`` (border replicate) on the same float32
    image, if installed; and a numpy copy of the image (the bytes' floor)."""
    from ssskit.screenspace import Camera, GBuffer, separable_sss
    from ssskit.screenspace.separable import filter_arrays

    taps = taps_for("skin1")
    plain = np.ascontiguousarray(taps.weights[0][:, 0], dtype=np.float32)  # any 7 weights
    cv2, cv_status = opencv()
    rows = []
    for size in sizes:
        width, height = (int(v) for v in size.lower().split("x"))
        image, depth = scene(width, height)
        f = FOCAL_1080P * width / 1920
        gb = GBuffer(diffuse=image, albedo=np.ones_like(image), depth=depth,
                     profile_id=np.ones((height, width), np.uint32),
                     camera=Camera(width, height, f, f, width / 2, height / 2))
        fns = {
            "numba_ms": lambda: filter_arrays(image, depth, f, f, taps, jitter=0.0, depth_mode="follow"),
            "scipy_two_plain_passes_ms": lambda: convolve1d(convolve1d(image, plain, axis=1, mode="nearest"), plain,
                                                            axis=0, mode="nearest"),
            "numba_jitter10_ms": lambda: filter_arrays(image, depth, f, f, taps, jitter=0.1, depth_mode="follow"),
            "api_jitter10_ms": lambda: separable_sss(gb, taps, jitter=0.1, depth_mode="follow", backend="numba"),
            "numpy_copy_ms": lambda: image.copy(),
        }
        if cv2 is not None:
            fns["opencv_sepfilter2d_ms"] = lambda: cv2.sepFilter2D(image, -1, plain, plain,
                                                                   borderType=cv2.BORDER_REPLICATE)
        times = interleaved(fns, repeats)
        m = {k: 1e3 * statistics.median(v) for k, v in times.items()}
        row = {"size": f"{width}x{height}", **m, "spread_ms": {k: spread_ms(v) for k, v in times.items()}}
        row["ratio_numba_over_scipy"] = m["numba_ms"] / m["scipy_two_plain_passes_ms"]
        row["ratio_jitter10_over_plain"] = m["numba_jitter10_ms"] / m["numba_ms"]
        row["numba_fps"] = 1e3 / m["numba_ms"]
        if cv2 is not None:
            row["ratio_api_jitter10_over_opencv"] = m["api_jitter10_ms"] / m["opencv_sepfilter2d_ms"]
        row["opencv"] = cv_status
        if width * height <= numpy_max_pixels:
            t0 = time.perf_counter()
            filter_arrays(image, depth, f, f, taps, jitter=0.0, depth_mode="follow", backend="numpy")
            row["numpy_reference_ms"] = 1e3 * (time.perf_counter() - t0)
        rows.append(row)
    return rows


def time_profile_ids(repeats: int) -> dict:
    """1080p, one pass: three profile ids (vertical bands: Skin1, Marble, Ketchup taps) vs one id."""
    from ssskit.screenspace import Camera, GBuffer, separable_sss

    width, height = 1920, 1080
    image, depth = scene(width, height)
    pid3 = np.ones((height, width), np.uint32)
    pid3[:, width // 3:] = 2
    pid3[:, 2 * width // 3:] = 3
    cam = Camera(width, height, FOCAL_1080P, FOCAL_1080P, width / 2, height / 2)
    albedo = np.ones_like(image)
    gb1 = GBuffer(diffuse=image, albedo=albedo, depth=depth, profile_id=np.ones_like(pid3), camera=cam)
    gb3 = gb1.with_layers(profile_id=pid3)
    taps = {1: taps_for("skin1"), 2: taps_for("marble"), 3: taps_for("ketchup")}
    m = median_ms({
        "one_id_ms": lambda: separable_sss(gb1, taps[1], jitter=0.0, depth_mode="follow"),
        "one_id_marble_ms": lambda: separable_sss(gb1, taps[2], jitter=0.0, depth_mode="follow"),
        "one_id_ketchup_ms": lambda: separable_sss(gb1, taps[3], jitter=0.0, depth_mode="follow"),
        "three_ids_ms": lambda: separable_sss(gb3, taps, jitter=0.0, depth_mode="follow"),
        "three_ids_same_taps_ms": lambda: separable_sss(gb3, taps[1], jitter=0.0, depth_mode="follow"),
    }, repeats)
    # each material's kernel costs what it costs; the price of three ids in one pass is the ratio to the
    # mean of the three one-id frames (each material over the whole image)
    mean_one = (m["one_id_ms"] + m["one_id_marble_ms"] + m["one_id_ketchup_ms"]) / 3.0
    m["ratio_three_over_mean_of_ones"] = m["three_ids_ms"] / mean_one
    m["ratio_three_same_taps_over_one"] = m["three_ids_same_taps_ms"] / m["one_id_ms"]
    return m


def _checkout(rev: str) -> Path:
    """The git-ignored worktree ``benchmarks/.before-<rev>/`` of revision ``rev`` (made once)."""
    root = Path(__file__).resolve().parent.parent
    where = root / "benchmarks" / f".before-{rev}"
    if not where.exists():
        subprocess.run(["git", "-C", str(root), "worktree", "add", "--detach", str(where), rev], check=True,
                       capture_output=True)
    return where


def _sizes_run(src: Path, sizes, repeats: int) -> list:
    """This script's size table in a new process with the package at ``src`` (on PYTHONPATH)."""
    env = dict(os.environ, PYTHONPATH=str(src))
    out = subprocess.run([sys.executable, __file__, "--only-sizes", "--repeats", str(repeats), "--sizes", *sizes],
                         env=env, check=True, capture_output=True, text=True).stdout
    return json.loads(out)["results"]


def before(rev: str, sizes, repeats: int) -> dict:
    """Run this script's size table with the code of git revision ``rev`` in a subprocess."""
    return {"revision": rev, "results": _sizes_run(_checkout(rev) / "src", sizes, repeats)}


def ab(rev: str, sizes, repeats: int, rounds: int) -> dict:
    """This checkout and revision ``rev`` alternately, ``rounds`` rounds of one process each (module docstring)."""
    versions = {"after": Path(__file__).resolve().parent.parent / "src", "before": _checkout(rev) / "src"}
    runs: dict = {k: [] for k in versions}
    for _ in range(rounds):
        for k, src in versions.items():
            runs[k].append({"load_average": os.getloadavg()[0], "results": _sizes_run(src, sizes, repeats)})
    summary: dict = {}
    for k, rs in runs.items():
        for i, size in enumerate(sizes):
            rows = [r["results"][i] for r in rs]
            api = [row["api_jitter10_ms"] for row in rows]
            entry = {"api_jitter10_ms": _spread(api)}
            if "opencv_sepfilter2d_ms" in rows[0]:
                cv = [row["opencv_sepfilter2d_ms"] for row in rows]
                entry["opencv_sepfilter2d_ms"] = _spread(cv)
                entry["ratio_api_jitter10_over_opencv"] = _spread([a / c for a, c in zip(api, cv)])
            summary.setdefault(size, {})[k] = entry
    return {"revision": rev, "rounds": rounds, "summary": summary, "runs": runs}


def _spread(values: list) -> dict:
    return {"min": round(min(values), 3), "median": round(statistics.median(values), 3), "max": round(max(values), 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["1280x720", "1920x1080", "3840x2160"])
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--numpy-max-pixels", type=int, default=1_000_000,
                    help="time the numpy reference only up to this many pixels (it is slow)")
    ap.add_argument("--before", metavar="REV", help="also time git revision REV in the same run")
    ap.add_argument("--ab", metavar="REV", help="time this checkout and git revision REV alternately (no other tables)")
    ap.add_argument("--rounds", type=int, default=5, help="rounds of --ab (one process per version and round)")
    ap.add_argument("--only-sizes", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.only_sizes:  # the --before subprocess: this checkout's size table only
        print(json.dumps({"results": time_sizes(args.sizes, args.repeats, 0)}))
        return
    import ssskit

    if args.ab:
        out = {"benchmark": "separable pass, A/B: this checkout against --ab's revision, alternating rounds",
               "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "numba": numba.__version__,
                           "threading_layer": os.environ["NUMBA_THREADING_LAYER"], "threads": numba.get_num_threads()},
               "repeats": args.repeats, "load_average_before": os.getloadavg(),
               **ab(args.ab, args.sizes, args.repeats, args.rounds), "load_average_after": os.getloadavg()}
        print(json.dumps(out, indent=2))
        return
    out = {
        "benchmark": "separable screen-space SSS pass, 7 taps, both passes, depth-aware, float32 RGB",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "numba": numba.__version__,
                    "numpy": np.__version__, "threading_layer": os.environ["NUMBA_THREADING_LAYER"],
                    "threads": numba.get_num_threads(), "ssskit": str(Path(ssskit.__file__).parent)},
        "taps_mm": taps_for("skin1").offsets_mm[0].tolist(),
        "repeats": args.repeats,
        "load_average_before": os.getloadavg(),
        "results": time_sizes(args.sizes, args.repeats, args.numpy_max_pixels),
        "profile_ids_1080p": time_profile_ids(args.repeats),
    }
    if args.before:
        out["before"] = before(args.before, args.sizes, args.repeats)
    out["load_average_after"] = os.getloadavg()
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
