"""Benchmark: ``ssskit demo`` on a fresh machine, as whole processes, one code tree against another in the
same run; prints one JSON object.

Every run starts from nothing: new empty folders for numba's cache (``NUMBA_CACHE_DIR``), ssskit's
(``SSSKIT_CACHE_DIR``) and the home folder (``HOME``, ``XDG_CACHE_HOME``, ``MPLCONFIGDIR``), so numba compiles
every kernel, matplotlib builds its font cache and no section comes from the demo's cache; the install is
not timed. The trees (``--src``: a folder put first on ``PYTHONPATH``, e.g. ``src`` of this checkout and of
main, the competitor) run interleaved, ``--repeats`` rounds, with the load average before and after each
run (the machine is shared). Per run: the wall and CPU seconds of the command (CPU: user + system of it and
its worker processes), the report's own time (``built in ... s`` on its page), each section's wall and CPU
time as its progress line states it (and the workers' compilation, if any), and the longest stderr silence
(``benchmarks/silence.py``).

    NUMBA_THREADING_LAYER=workqueue python benchmarks/bench_demo.py --src /path/to/main/src --src src --repeats 2
    python benchmarks/bench_demo.py --src src --demo-args "--jobs 1"   # the sections one after another
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from silence import stamped_run  # noqa: E402

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")  # inherited by every run


def fresh_demo(src: str, python: str, demo_args: list[str]) -> dict:
    """One ``ssskit demo`` of the tree ``src`` in new empty caches and home; its numbers (module docstring)."""
    with tempfile.TemporaryDirectory(prefix="bench-demo-") as tmp:
        home = Path(tmp) / "home"
        home.mkdir()
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(src).resolve()), os.environ.get("PYTHONPATH", "")]),
                   NUMBA_CACHE_DIR=str(Path(tmp) / "numba"), SSSKIT_CACHE_DIR=str(Path(tmp) / "ssskit"),
                   HOME=str(home), XDG_CACHE_HOME=str(home / ".cache"), MPLCONFIGDIR=str(home / ".matplotlib"))
        out = Path(tmp) / "demo"
        run = stamped_run([python, "-m", "ssskit", "demo", "--out", str(out), *demo_args], env)
        lines = run.pop("lines")
        if run["exit"] != 0:
            raise RuntimeError(f"ssskit demo of {src} failed (exit {run['exit']}): "
                               + " | ".join(text for _, text in lines[-5:]))
        page = (out / "index.html").read_text(encoding="utf-8")
    built = re.search(r"built in ([0-9.]+) s", page)
    sections = {m.group(1): float(m.group(2)) for _, text in lines
                if (m := re.search(r"section (\w+): done in ([0-9.]+) s", text))}
    cpu = {m.group(1): float(m.group(2)) for _, text in lines
           if (m := re.search(r"section (\w+): done in [0-9.]+ s \(CPU ([0-9.]+) s\)", text))}
    compiled = [float(m.group(1)) for _, text in lines
                if (m := re.search(r"compiled the \w+ kernels in ([0-9.]+) s", text))]
    run.pop("command")
    return {**run, "report_own_s": float(built.group(1)) if built else None, "sections_s": sections,
            "sections_cpu_s": cpu, "warm_up_s": compiled[0] if compiled else None}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", action="append", default=None,
                    help="a code tree's package folder (repeatable; default: this checkout's src)")
    ap.add_argument("--python", default=sys.executable, help="the interpreter (with ssskit's dependencies)")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--demo-args", default="", help="more arguments of ssskit demo, e.g. \"--jobs 1\"")
    args = ap.parse_args(argv)
    trees = args.src or [str(Path(__file__).resolve().parents[1] / "src")]
    runs: dict[str, list[dict]] = {t: [] for t in trees}
    for r in range(args.repeats):
        for tree in trees:
            result = fresh_demo(tree, args.python, shlex.split(args.demo_args))
            runs[tree].append(result)
            print(f"round {r + 1}, {tree}: wall {result['wall_s']} s, report {result['report_own_s']} s, load "
                  f"{result['load_before'][0]} -> {result['load_after'][0]}", file=sys.stderr, flush=True)
    out = {"python": args.python, "demo_args": args.demo_args, "repeats": args.repeats,
           "threading_layer": os.environ["NUMBA_THREADING_LAYER"], "cpus": os.cpu_count(), "runs": runs,
           "median_wall_s": {t: statistics.median(x["wall_s"] for x in v) for t, v in runs.items()},
           "median_report_own_s": {t: statistics.median(x["report_own_s"] for x in v) for t, v in runs.items()}}
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
