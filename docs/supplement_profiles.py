"""Regenerate the Monte Carlo profiles ssskit ships (src/ssskit/profiles/montecarlo/data/supplement_profiles.npz).

    python docs/supplement_profiles.py            # the supplement's 10^7 photons per channel (about an hour on 2 cores)
    python docs/supplement_profiles.py --photons 100000 --out /tmp/quick.npz   # a quick trial

Every simulation of :func:`ssskit.profiles.montecarlo.shipped.shipped_configs` (the 11 materials of
supplement G and Skin1 at eta = 1, three channels each, seed 1) runs on the numba engine, one after the
other, with a progress line on stderr at least every few seconds. Finished simulations land in the
ssskit cache (``$SSSKIT_CACHE_DIR``), and an interrupted one is continued, so running the script again
after Ctrl-C loses nothing. The file is written once all are done; prints one JSON line (sizes, times).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

from ssskit.cache import cache_dir
from ssskit.profiles.montecarlo import DEFAULT_PHOTONS, simulate
from ssskit.profiles.montecarlo.shipped import SHIPPED_FILE, shipped_configs, write_shipped


#: simulated first: the materials the demo's kernel ranking and screen-space sections use
_PRIORITY = ["Skin1", "Skin1 (eta = 1)", "Ketchup", "Marble"]
#: then in rising cost (the slowest have the highest albedo: their photons scatter longest)
_COST = {"Chicken1": 0, "Chicken2": 0, "Skin2": 1, "Potato": 2, "Apple": 3, "Skimmilk": 4, "Wholemilk": 5, "Cream": 6}


def main(argv: list[str] | None = None) -> int:
    import signal

    def interrupt(signum, frame):  # kill (SIGTERM) like Ctrl-C: the running simulation keeps its batches
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, interrupt)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photons", type=int, default=DEFAULT_PHOTONS, help="photons per channel (default 10^7)")
    ap.add_argument("--out", type=Path, default=SHIPPED_FILE, help="the file to write (default: the package's)")
    ap.add_argument("--finished-only", action="store_true",
                    help="write only the simulations already finished in the cache, simulate nothing (a trial file: "
                         "the tests want every one)")
    args = ap.parse_args(argv)
    configs = shipped_configs(args.photons)
    # the demo's own materials first, the slowest (nearly absorption-free) last; the file keeps the order of
    # shipped_configs
    order = sorted(range(len(configs)), key=lambda i: (_PRIORITY.index(configs[i][0]) if configs[i][0] in _PRIORITY
                                                       else len(_PRIORITY), _COST.get(configs[i][0], 0)))
    results: dict[int, object] = {}
    t0 = time.perf_counter()
    for k, i in enumerate(order, 1):
        label, ch, cfg = configs[i]
        if args.finished_only and not (cache_dir("mcml") / f"{cfg.key()}.npz").is_file():
            continue
        print(f"[{k}/{len(configs)}] {label} {ch}: {cfg.photons:,} photons, {cfg.nr} bins of {cfg.dr_mm:.4g} mm "
              f"({time.perf_counter() - t0:.0f} s so far)", file=sys.stderr, flush=True)
        results[i] = simulate(cfg, progress=True, resume=True, shipped=False, label=f"{label} {ch}")
    entries = [(label, ch, results[i]) for i, (label, ch, _) in enumerate(configs) if i in results]
    made = {"date": time.strftime("%Y-%m-%d"), "machine": platform.processor() or platform.machine(),
            "python": platform.python_version(), "cpus": os.cpu_count(), "photons": args.photons}
    path = write_shipped(entries, args.out, made)
    print(json.dumps({"file": str(path), "kb": round(path.stat().st_size / 1024, 1), "entries": len(entries),
                      "seconds_simulated": round(sum(r.seconds for _, _, r in entries), 1),
                      "seconds_wall": round(time.perf_counter() - t0, 1)}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
