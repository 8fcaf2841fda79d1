"""Benchmark: every GPU measurement of the gl backend and of the GLSL MCML engine in one run, one JSON.

Made for a lent GPU (one command, well under 5 minutes on an H100/H200; benchmarks/RESULTS.md says how to
run it through the device tool and what to carry), and runs anywhere an OpenGL 4.3 context exists (Mesa's
llvmpipe: ``--quick`` for a smoke run of every case at small sizes). The cases:

* the separable pass (``bench_gl.time_gl``): 7 taps of Skin1, follow-surface test, 1080p and 4K, without
  and with the paper's 10% jitter, against the copy floor (a shader moving the same bytes);
* the Burley pass (``bench_gl.time_burley``): 1080p, exact sampler, 8/16/32/64 spp, without and with the
  prefiltered mips (Xie Eqs. 22-23, the pyramid built on the device inside each frame);
* the adaptive guiding phase (``bench_adaptive_phases.bench_guide``): 1080p, the history update (static
  and moving camera) and the count estimate, device time;
* the transmittance pass (``transmission.cost``): 1080p, Skin1's MCML model, a 1024^2 translucency shadow
  map, against the separable pass on the same backend in the same rounds (wall time of the backend call,
  upload and readback included), on gl and on numba (the lent machine's CPU);
* MCML on gl (:mod:`ssskit.profiles.montecarlo.engine_gl`): Skin1 and Marble red on the supplement's grid,
  photons per second of ``simulate(backend="gl")`` (wall time: dispatches, the tallies' readback and
  their reduction included), and its total Rd with standard error.

GPU time by GL_TIME_ELAPSED queries around batches of frames already on the device (wall time around
glFinish on llvmpipe); each case reports its median and minimum. Every case's failure is recorded in the
JSON (``"error"``) and the run goes on. Prints one JSON object on stdout (progress on stderr).

    python benchmarks/bench_gpu.py [--quick] [--mcml-photons 200000000] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
import traceback
from pathlib import Path
from typing import Any, Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _case(out: list[Any], name: str, fn: Callable[[], dict], t_start: float) -> None:
    t0 = time.perf_counter()
    try:
        row = {"case": name, **fn()}
    except Exception as exc:  # a broken case must not lose the others' figures
        row = {"case": name, "error": f"{type(exc).__name__}: {exc}",
               "traceback": traceback.format_exc(limit=3)}
    row["seconds"] = round(time.perf_counter() - t0, 2)
    out.append(row)
    print(json.dumps({"case": name, "seconds": row["seconds"], "at": round(time.perf_counter() - t_start, 1),
                      **({"error": row["error"]} if "error" in row else {})}), file=sys.stderr, flush=True)


def separable(width: int, height: int, jitter: float, batches: int, floor: dict) -> dict:
    from bench_gl import parse_layout, time_gl

    gl = time_gl(width, height, jitter, batches, 10, parse_layout("default"))
    return {"size": f"{width}x{height}", "jitter": jitter, "gl": gl, "copy_floor_ms": floor["frame_ms"],
            "ratio_to_floor": gl["frame_ms"] / floor["frame_ms"]}


def burley(width: int, height: int, spp: int, mips: bool, batches: int) -> dict:
    from bench_gl import time_burley

    return {"size": f"{width}x{height}", **time_burley(width, height, spp, mips, "exact", batches, 10, False, 0)}


def guiding(width: int, height: int, repeats: int) -> dict:
    from bench_adaptive_phases import bench_guide

    from ssskit.backends.adaptive_plan import as_plan
    from ssskit.screenspace.adaptive import AdaptiveSettings

    settings = AdaptiveSettings(sigma0_sq=1e-3, kappa=0.2)
    return {"size": f"{width}x{height}", "settings": settings.to_dict(),
            **bench_guide("gl", width, height, as_plan(settings), repeats)}


def transmittance(repeats: int) -> dict:
    from transmission import cost

    return {"size": "1920x1080", "timing": "wall time of the backend call (upload, dispatch, readback)", **cost(repeats)}


def mcml(material: str, photons: int) -> dict:
    from ssskit.materials import get_material
    from ssskit.profiles.montecarlo import config_for_material, simulate

    m = get_material(material)
    simulate(config_for_material(m, 0, photons=20_000, seed=2), backend="gl", use_cache=False)  # compile, warm up
    cfg = config_for_material(m, 0, photons=photons, seed=1)
    t0 = time.perf_counter()
    r = simulate(cfg, backend="gl", use_cache=False)
    wall = time.perf_counter() - t0
    return {"material": material, "channel": "R", "photons": photons, "grid": {"dr_mm": cfg.dr_mm, "nr": cfg.nr},
            "seconds": round(wall, 3), "photons_per_s": photons / wall, "total_rd": r.total_rd,
            "total_rd_se": r.total_rd_se, "energy_balance": r.total_rd + r.tt + r.absorbed + r.rsp}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes and photon counts (a CPU / llvmpipe smoke run)")
    ap.add_argument("--mcml-photons", type=int, default=None,
                    help="photons per MCML case (default 2e8 Skin1 / 5e7 Marble; --quick: 2e4)")
    ap.add_argument("--batches", type=int, default=None, help="timed batches per GL case (default 20; --quick 3)")
    ap.add_argument("--out", type=Path, default=None, help="also write the JSON to this file")
    args = ap.parse_args(argv)
    from ssskit.backends import backend_status

    t_start = time.perf_counter()
    status = backend_status()["gl"]
    result: dict = {"benchmark": "every GPU measurement of the gl backend and the GLSL MCML engine",
                    "python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count(),
                    "load_average_before": os.getloadavg(), "gl": status["details"], "quick": args.quick}
    if not status["available"]:
        result["error"] = f"the gl backend is not available here: {status['details']}"
        print(json.dumps(result, indent=1))
        return result
    from ssskit.backends.gl.context import is_software

    result["timing"] = "wall time around glFinish (llvmpipe)" if is_software() else "GL_TIME_ELAPSED"
    batches = args.batches or (3 if args.quick else 20)
    sizes = [(320, 180), (640, 360)] if args.quick else [(1920, 1080), (3840, 2160)]
    burley_size = (320, 180) if args.quick else (1920, 1080)
    spps = [8] if args.quick else [8, 16, 32, 64]
    cases: list[Any] = []
    result["cases"] = cases
    from bench_gl import time_copy_floor

    for w, h in sizes:
        floor: dict = {}
        _case(cases, f"copy_floor {w}x{h}", lambda w=w, h=h: floor.update(time_copy_floor(w, h, batches, 10)) or dict(floor),
              t_start)
        if "frame_ms" not in floor:
            continue
        for jitter in (0.0, 0.1):
            _case(cases, f"separable {w}x{h} jitter {jitter}", lambda w=w, h=h, j=jitter, f=floor: separable(
                w, h, j, batches, f), t_start)
    bw, bh = burley_size
    for mips in (False, True):
        for spp in spps:
            _case(cases, f"burley {bw}x{bh} {spp} spp mips {mips}",
                  lambda s=spp, m=mips: burley(bw, bh, s, m, batches), t_start)
    _case(cases, f"adaptive guiding {bw}x{bh}", lambda: guiding(bw, bh, max(3, batches // 2)), t_start)
    _case(cases, "transmittance 1920x1080", lambda: transmittance(2 if args.quick else 7), t_start)
    for material, default in (("skin1", 200_000_000), ("marble", 50_000_000)):
        photons = args.mcml_photons or (20_000 if args.quick else default)
        _case(cases, f"mcml gl {material}", lambda m=material, n=photons: mcml(m, n), t_start)
    result["seconds"] = round(time.perf_counter() - t_start, 1)
    result["load_average_after"] = os.getloadavg()
    text = json.dumps(result, indent=1, default=float)
    if args.out:
        args.out.write_text(text)
    print(text)
    return result


if __name__ == "__main__":
    main()
