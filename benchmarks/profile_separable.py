"""Where the numba separable pass spends its time: each kernel alone, on one thread, per tap row.

The scene of ``bench_separable.py`` (7 importance-sampled taps of Skin1, follow-surface depth test, float32,
the tilted plane; f = 1000 px at 1080p, scaled with the width). The backend packs the frame once; then the
packing (``pack_rows``) and each 1D pass (horizontal 'h', vertical 'v') are timed alone, called directly with
the plan's tables cut down to: no tap rows ('norows': lane data, block classification, output), the first
row as a plain row ('1plain'), all three rows plain ('3plain'), the first row jittered ('1jit'), and the real
table ('full': the jittered pair and two plain pairs). Differences between the variants give each part's cost:
'1jit' - 'norows' is the jittered pair, 'full' - '1jit' the two plain pairs. Times are thread CPU times
(``time.thread_time``, so a busy machine's time slices do not count), the minimum over ``--repeats``, in ms of
one core. Prints one JSON object.

The kernels' signatures are detected, so the script also profiles an older checkout of the package
(``PYTHONPATH=<old>/src``) for a before/after comparison in the same minutes.

    NUMBA_NUM_THREADS=1 PYTHONPATH=src python benchmarks/profile_separable.py [--size 1920x1080] [--repeats 9]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_separable as bs  # noqa: E402

#: variants of the tap table: (rows used, of which jittered)
VARIANTS = {"norows": (0, 0), "1plain": (1, 0), "3plain": (3, 0), "1jit": (1, 1), "full": (3, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--repeats", type=int, default=9)
    args = ap.parse_args()
    import ssskit
    from ssskit.backends import _numba_separable as ks
    from ssskit.backends import build_separable_plan, get_backend
    from ssskit.backends import numba_backend as nb
    from ssskit.sampling.hashes import frame_base

    w, h = (int(v) for v in args.size.lower().split("x"))
    image, depth = bs.scene(w, h)
    f = bs.FOCAL_1080P * w / 1920
    plan = build_separable_plan({1: bs.taps_for("skin1")}, f, f, jitter=0.1, depth_mode="follow")
    slots = np.ones((h, w), np.int32)
    be = get_backend("numba")
    be.separable(plan, image, depth, slots)  # compiles (or loads) the kernels and sets the pad
    pad = be._pads[(h, w)]
    buf, wps, plane = be._buffer(h, w, pad)
    run = ks.PASSES[plan.depth_mode]
    code = run.py_func.__code__
    lanes = (ks.LANES,) if "lanes" in code.co_varnames[:code.co_argcount] else ()
    pcode = ks.pack_rows.py_func.__code__
    slot_plane = (False,) if "slot_plane" in pcode.co_varnames[:pcode.co_argcount] else ()
    offs, wts, _, _, centre = nb._tables(plan.terms[0])
    base = np.uint64(frame_base(plan.frame, plan.seed))
    cap = np.float32(pad - 3)
    param = plan.depth_param.astype(np.float32)
    out = np.empty((h, w, 3), np.float32)
    flat = out.reshape(-1)
    tmp = ks.TMP_PLANE * plane
    bmap = np.zeros((h, 1), np.int32)
    stats = np.empty((h, 4))

    def one_pass(variant: str, axis: int) -> None:
        rows, jit = VARIANTS[variant]
        t = (offs, wts, np.array([0, jit]), np.array([0, rows]), centre)
        if axis == 0:
            run(buf, buf, 0, tmp + pad * wps + pad, plane, wps, 1, 0, h, w, pad, wps, plane, 0, plan.fx, *t, param,
                base, cap, bmap, *lanes)
        else:
            run(buf, flat, tmp, 0, 1, 3 * w, 3, 0, h, w, pad, wps, plane, 1, plan.fy, *t, param, base, cap, bmap,
                *lanes)

    def pack() -> None:
        ks.pack_rows(image, depth, slots, buf, pad, wps, plane, 0, h, True, *slot_plane, stats)

    def best_ms(fn) -> float:
        fn()
        ts = []
        for _ in range(args.repeats):
            t0 = time.thread_time()
            fn()
            ts.append(time.thread_time() - t0)
        return round(1e3 * min(ts), 3)

    times = {"pack": best_ms(pack)}
    for v in VARIANTS:
        for axis, name in ((0, "h"), (1, "v")):
            times[f"{name}_{v}"] = best_ms(lambda: one_pass(v, axis))
    derived = {f"{name}_{part}": round(times[f"{name}_{a}"] - times[f"{name}_{b}"], 3)
               for name in ("h", "v") for part, a, b in (("jittered_pair", "1jit", "norows"),
                                                         ("two_plain_pairs", "full", "1jit"))}
    print(json.dumps({"size": args.size, "ssskit": str(Path(ssskit.__file__).parent), "repeats": args.repeats,
                      "threads": 1, "load_average": os.getloadavg(), "ms_of_one_core": times, "derived_ms": derived,
                      "frame_ms": round(times["pack"] + times["h_full"] + times["v_full"], 3)}, indent=2))


if __name__ == "__main__":
    main()
