"""Benchmark: Xie 2020 Fig. 1 / Sec. 6.4 in kind, the three-view study on the generated bust
(:mod:`ssskit.figures.views`): close, ear and front views; the adaptive Burley pass (sigma0^2 = 1e-3,
kappa = 0.2, 8-64 spp), Eq. 21 at a fixed 64 spp, Golubev's sampler at 64 spp and the separable pass
with the burley_fit kernel, each against the pass's converged limit (gray PSNR inside the SSS mask)
and timed per backend in the same run (the separable pass is every Burley method's competitor);
PSNR(Golubev) - PSNR(Eq. 21) per view beside Xie's 2.09 / 0.29 / 0.26 dB. ``--path-traced`` adds the
per-region levels against a path-traced reference of each view (minutes per view).

Prints one JSON object. NUMBA_THREADING_LAYER is set to 'workqueue' unless given.

    python benchmarks/xie_three_views.py [--size 256x192] [--frames 16] [--backends numba gl]
        [--reference-spp 4096] [--repeats 3] [--path-traced] [--path-traced-size 128x96] [--figure out.png]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numba  # noqa: E402


def _size(text: str) -> tuple[int, int]:
    w, _, h = text.lower().partition("x")
    return int(w), int(h)


def main(argv: list[str] | None = None) -> dict:
    from ssskit.backends import backend_status
    from ssskit.figures.views import plot_study, study_json, three_view_study

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=_size, default=(256, 192))
    ap.add_argument("--frames", type=int, default=16)
    ap.add_argument("--backends", nargs="+", default=["numba", "gl"])
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--path-traced", action="store_true")
    ap.add_argument("--path-traced-size", type=_size, default=None)
    ap.add_argument("--figure", default=None)
    args = ap.parse_args(argv)
    status = backend_status()
    backends = [b for b in args.backends if status.get(b, {}).get("available")]
    skipped = {b: status.get(b, {}).get("details", "unknown backend") for b in args.backends if b not in backends}
    t0 = time.perf_counter()
    study = three_view_study(width=args.size[0], height=args.size[1], frames=args.frames, backends=backends,
                             reference_spp=args.reference_spp, repeats=args.repeats, path_traced=args.path_traced,
                             path_traced_size=args.path_traced_size,
                             progress=lambda m: print(m, file=sys.stderr, flush=True))
    if args.figure:
        from pathlib import Path

        plot_study(study, Path(args.figure))
    out = study_json(study)
    out.update(machine={"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
                        "numba_threads": numba.config.NUMBA_NUM_THREADS,
                        "threading_layer": os.environ["NUMBA_THREADING_LAYER"]},
               skipped_backends=skipped, seconds=round(time.perf_counter() - t0, 1))
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
