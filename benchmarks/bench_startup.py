"""Benchmark: ssskit's start-up as whole processes: ``ssskit --help``, and a first and a second
``ssskit render`` on an empty numba cache and an empty ssskit cache; prints one JSON object.

Every figure is a fresh process of ``--python`` (default: this interpreter; give a fresh virtual
environment's to time a new installation) running the ``ssskit`` entry point, timed from outside: wall
seconds by a monotonic clock around the child, CPU seconds (user + system) from the operating system's
accounting of the finished child (getrusage). Competitor in the same rounds: ``python -c pass`` (the
interpreter's own start-up). ``--help`` runs ``--repeats`` times interleaved with it (min, median, max).
The first render runs with ``NUMBA_CACHE_DIR`` and ``SSSKIT_CACHE_DIR`` pointing at new empty folders
(numba compiles every kernel the render needs, the scene's G-buffer is rendered, nothing is cached), the
second in the same folders (numba's cache and ssskit's are warm): the compilation's cost is their
difference; a third run with numba's cache log counts the kernels loaded from the cache and those
compiled and saved (none, when the cache hits).

    python benchmarks/bench_startup.py [--python /path/to/venv/bin/python] [--repeats 7]
                                       [--render "--scene slab --size 320x240"]
    python benchmarks/bench_startup.py --src src --src /path/to/main/src --rounds 5   # first renders only

With ``--src`` (repeatable: a code tree's package folder, put first on ``PYTHONPATH``) only the first render is
timed, for each tree in turn, ``--rounds`` rounds interleaved (the machine is shared: the trees meet the same
load), each in new empty numba and ssskit caches and an empty home, with the load average before each run.

NUMBA_THREADING_LAYER is set to 'workqueue' for every child unless given (and recorded in the JSON).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ENTRY = "import sys; from ssskit.cli import main; sys.exit(main())"
os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")  # inherited by every child


def timed(cmd: list[str], env: dict | None = None) -> tuple[float, float, int]:
    """(wall seconds, CPU seconds of the child, exit status)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                       text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)[:120]} failed (rc {p.returncode}): {p.stderr.strip()[-300:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), p.returncode


def spread(values: list[float]) -> dict:
    return {"min": round(min(values), 4), "median": round(statistics.median(values), 4), "max": round(max(values), 4)}


def first_renders(py: str, trees: list[str], rounds: int, render_args: str) -> dict:
    """The first render of each tree (module docstring), ``rounds`` interleaved rounds: per tree its runs
    (wall s, CPU s, load average before) and the median wall and CPU seconds."""
    runs: dict[str, list[dict]] = {t: [] for t in trees}
    for _ in range(rounds):
        for tree in trees:
            with tempfile.TemporaryDirectory() as tmp:
                home = Path(tmp) / "home"
                home.mkdir()
                env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(tree).resolve()),
                                                                    os.environ.get("PYTHONPATH", "")]),
                           NUMBA_CACHE_DIR=str(Path(tmp) / "numba"), SSSKIT_CACHE_DIR=str(Path(tmp) / "ssskit"),
                           HOME=str(home), XDG_CACHE_HOME=str(home / ".cache"))
                load = os.getloadavg()[0]
                wall, cpu, _ = timed([py, "-c", ENTRY, "render", *shlex.split(render_args), "--out",
                                      str(Path(tmp) / "r.png")], env)
                runs[tree].append({"wall_s": round(wall, 2), "cpu_s": round(cpu, 2), "load_before": round(load, 2)})
                print(f"{tree}: {runs[tree][-1]}", file=sys.stderr, flush=True)
    return {t: {"runs": v, "median_wall_s": statistics.median(r["wall_s"] for r in v),
                "median_cpu_s": statistics.median(r["cpu_s"] for r in v)} for t, v in runs.items()}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--python", default=sys.executable, help="the interpreter whose ssskit is timed")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--render", default="--scene slab --size 320x240", help="the render command's arguments")
    ap.add_argument("--src", action="append", default=None,
                    help="a code tree's package folder (repeatable): time only first renders, trees interleaved")
    ap.add_argument("--rounds", type=int, default=5, help="with --src: rounds of first renders")
    args = ap.parse_args(argv)
    py = args.python
    if args.src:
        out = {"python": py, "render_args": args.render, "rounds": args.rounds,
               "threading_layer": os.environ["NUMBA_THREADING_LAYER"], "load_average_before": os.getloadavg(),
               "first_render": first_renders(py, args.src, args.rounds, args.render),
               "load_average_after": os.getloadavg()}
        print(json.dumps(out, indent=1))
        return out
    out: dict = {"python": py, "load_average_before": os.getloadavg(), "repeats": args.repeats,
                 "threading_layer": os.environ["NUMBA_THREADING_LAYER"]}
    helps, bare = [], []
    timed([py, "-c", ENTRY, "--help"])  # the files into the page cache
    for _ in range(args.repeats):
        helps.append(timed([py, "-c", ENTRY, "--help"])[:2])
        bare.append(timed([py, "-c", "pass"])[:2])
    out["help"] = {"wall_s": spread([w for w, _ in helps]), "cpu_s": spread([c for _, c in helps])}
    out["python_c_pass"] = {"wall_s": spread([w for w, _ in bare]), "cpu_s": spread([c for _, c in bare])}
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "numba"), SSSKIT_CACHE_DIR=str(Path(tmp) / "ssskit"))
        render = [py, "-c", ENTRY, "render", *shlex.split(args.render), "--out", str(Path(tmp) / "r.png")]
        first = timed(render, env)
        second = timed(render, env)
        out["render_args"] = args.render
        out["first_render"] = {"wall_s": round(first[0], 2), "cpu_s": round(first[1], 2)}
        out["second_render"] = {"wall_s": round(second[0], 2), "cpu_s": round(second[1], 2)}
        out["compile_and_first_run_cpu_s"] = round(first[1] - second[1], 2)
        # a third run with numba's cache log: every kernel loaded from the cache, none compiled and saved
        p = subprocess.run(render, env=dict(env, NUMBA_DEBUG_CACHE="1"), capture_output=True, text=True)
        log = p.stdout + p.stderr
        out["numba_cache_third_render"] = {"loaded": log.count("data loaded"), "saved": log.count("data saved")}
    out["load_average_after"] = os.getloadavg()
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
