"""Benchmark: the first run of what needs a material's transmission table, on empty caches, with the shipped tables
(this checkout) against a competitor source tree in the same rounds (``--before``: e.g. the commit before them);
prints one JSON object.

    git archive 9a6a6bb src | tar -x -C /tmp/before
    NUMBA_THREADING_LAYER=workqueue PYTHONPATH=src python benchmarks/first_run_transmission.py --before /tmp/before/src

Each figure is a fresh process of this interpreter with ``PYTHONPATH`` at one source tree and ``NUMBA_CACHE_DIR`` and
``SSSKIT_CACHE_DIR`` at new empty folders (numba compiles every kernel it needs, nothing comes from ssskit's cache;
Mitsuba's own kernel cache is not emptied), timed from outside: wall seconds by a monotonic clock around the child,
CPU seconds from the operating system's accounting of the finished child. Two commands:

* ``export``: ``ssskit export --material skin1 --format unreal --out x.json`` (its transmission fields need Skin1's
  table);
* ``demo_transmission``: the demo report's transmission section alone (``ssskit.report._transmission_section``: the
  back-lit ear's G-buffer ray-cast by Mitsuba, three renders with the transmittance pass), as ``ssskit demo`` runs
  it.

Per run also: the MCML simulations that landed in the cache (``mcml_runs``: one per slab and channel simulated) and
whether numba compiled the MCML engine (``mcml_compiled``: its index file in the numba cache). ``--repeats`` rounds
(default 5), the variants interleaved in each; min / median / max per command and variant, and the load average
before and after (the machine is shared).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_startup import ENTRY, spread, timed  # noqa: E402  (timed: wall and CPU seconds of a child, raises if it fails)

SECTION = ("import sys; from pathlib import Path; from ssskit import report; "
           "report._transmission_section(Path(sys.argv[1]), lambda m: print(m, file=sys.stderr), "
           "{'backend': 'numba', 'photons': report.DEMO_PHOTONS})")
os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")  # inherited by every child


def first_run(src: Path, what: str) -> dict:
    """One first run of ``what`` with ``src`` on new empty caches."""
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(t / "numba"), SSSKIT_CACHE_DIR=str(t / "ssskit"))
        if what == "export":
            cmd = [sys.executable, "-c", ENTRY, "export", "--material", "skin1", "--format", "unreal", "--out",
                   str(t / "x.json")]
        else:
            cmd = [sys.executable, "-c", SECTION, str(t / "demo")]
        wall, cpu, _ = timed(cmd, env)
        mcml = t / "ssskit" / "mcml"
        return {"wall_s": round(wall, 2), "cpu_s": round(cpu, 2),
                "mcml_runs": len(list(mcml.glob("*.npz"))) if mcml.is_dir() else 0,
                "mcml_compiled": any((t / "numba").rglob("engine_numba*.nbi"))}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True, help="the competitor's source tree (its src folder)")
    ap.add_argument("--after", type=Path, default=Path(__file__).resolve().parents[1] / "src",
                    help="the source tree with the shipped tables (default: this checkout's src)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--only", choices=("export", "demo_transmission"), help="time one command only")
    args = ap.parse_args(argv)
    variants = {"after": args.after.resolve(), "before": args.before.resolve()}
    whats = [args.only] if args.only else ["export", "demo_transmission"]
    out: dict = {"load_average_before": os.getloadavg(), "repeats": args.repeats, "cpus": os.cpu_count(),
                 "threading_layer": os.environ["NUMBA_THREADING_LAYER"], "sources": {k: str(v) for k, v in variants.items()}}
    runs: dict = {w: {v: [] for v in variants} for w in whats}
    for r in range(args.repeats):
        for w in whats:
            for v, src in variants.items():
                res = first_run(src, w)
                runs[w][v].append(res)
                print(f"round {r + 1}: {w} {v}: {res} (load {os.getloadavg()[0]:.2f})", file=sys.stderr, flush=True)
    for w in whats:
        out[w] = {v: {"wall_s": spread([x["wall_s"] for x in rs]), "cpu_s": spread([x["cpu_s"] for x in rs]),
                      "mcml_runs": sorted({x["mcml_runs"] for x in rs}),
                      "mcml_compiled": sorted({x["mcml_compiled"] for x in rs})} for v, rs in runs[w].items()}
        out[w]["median_wall_before_over_after"] = round(out[w]["before"]["wall_s"]["median"]
                                                        / out[w]["after"]["wall_s"]["median"], 2)
    out["load_average_after"] = os.getloadavg()
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
