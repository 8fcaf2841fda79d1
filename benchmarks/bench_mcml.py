"""Benchmark: the numba MCML engine vs a plain vectorised-numpy implementation of the same
algorithm, measured in the same run; prints one JSON object.

    NUMBA_THREADING_LAYER is set to 'workqueue' (always available) unless given.
    python benchmarks/bench_mcml.py [--photons N] [--numpy-photons N] [--full]

--full also times the supplement's full simulation of Skin1: 10^7 photons per RGB channel.
The reference numbers for the original C MCML 1.2.2 (-O2, one core, this 2-core machine kind)
are the ones stated in the project's issue: 272,000 photons/s (Skin1 red), 27,900 (Marble red).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numba  # noqa: E402

from ssskit.materials import get_material  # noqa: E402
from ssskit.profiles.mcml_numpy import simulate_numpy  # noqa: E402
from ssskit.profiles.montecarlo import MCConfig, config_for_material, simulate  # noqa: E402

C_MCML_PHOTONS_PER_S = {"Skin1 R": 272_000, "Marble R": 27_900}


def rate_numba(cfg: MCConfig, threads: int) -> float:
    r = simulate(cfg, threads=threads, use_cache=False)
    return cfg.photons / r.seconds


def rate_numpy(cfg: MCConfig) -> float:
    t0 = time.perf_counter()
    simulate_numpy(cfg)
    return cfg.photons / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--photons", type=int, default=1_000_000)
    ap.add_argument("--numpy-photons", type=int, default=100_000)
    ap.add_argument("--full", action="store_true")
    args = ap.parse_args()
    # compile once, outside the timings
    simulate(config_for_material(get_material("skin1"), 0, photons=1_000), use_cache=False)
    cores = numba.config.NUMBA_NUM_THREADS
    out = {"machine": {"cpu_count": os.cpu_count(), "numba_threads": cores, "python": platform.python_version(),
                       "numba": numba.__version__, "threading_layer": os.environ["NUMBA_THREADING_LAYER"]},
           "cases": {}}
    for name, ch in (("Skin1", 0), ("Marble", 0)):
        label = f"{name} {'RGB'[ch]}"
        m = get_material(name)
        cfg = config_for_material(m, ch, photons=args.photons)
        one = rate_numba(cfg, 1)
        two = rate_numba(cfg, min(2, cores))
        npy = rate_numpy(config_for_material(m, ch, photons=args.numpy_photons))
        out["cases"][label] = {
            "photons": args.photons,
            "numba_1_thread_photons_per_s": round(one),
            "numba_2_threads_photons_per_s": round(two),
            "scaling_1_to_2_threads": round(two / one, 3),
            "numpy_vectorised_photons_per_s": round(npy),
            "numba_1_thread_over_numpy": round(one / npy, 2),
            "c_mcml_1_core_photons_per_s (issue)": C_MCML_PHOTONS_PER_S[label],
            "numba_1_thread_over_c_mcml": round(one / C_MCML_PHOTONS_PER_S[label], 2),
        }
    if args.full:
        m = get_material("skin1")
        t0 = time.perf_counter()
        for ch in range(3):
            simulate(config_for_material(m, ch, photons=10_000_000), use_cache=False)
        out["skin1_full_rgb_1e7_photons_per_channel_seconds"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
