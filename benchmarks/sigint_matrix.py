"""SIGINT at every stage of ``ssskit render`` and ``ssskit demo``, as Ctrl-C and as an ignored signal (issue 34).

Two ways a process meets SIGINT:

* ``foreground``: a terminal's Ctrl-C, SIGINT to the command's whole process group (its worker processes too),
  once, when a stage's progress line appears on stderr. Expected: exit status 130, ``ssskit: interrupted``, no
  traceback, nothing in the output folder (no file, no staging folder), no process of the group left, and every
  file it added to the cache also one that an uninterrupted run adds (a finished step's result, never a partial
  one: a reference, a G-buffer or a report section of an interrupted render is not cached).
* ``background``: a script's background job (``ssskit ... &`` in a non-interactive shell starts it with SIGINT
  ignored; here: ``SIG_IGN`` set before ``exec``), SIGINT sent to its group every 0.1 s from each of the three
  stages' lines on until it ends. Expected: exit status 0 and the same outputs as an uninterrupted run: every
  output file byte for byte, index.html part for part (each table one part) and the JSON on stdout, except what two uninterrupted runs
  (made first) differ in themselves: the demo measures times (the adaptive section's phase table, its
  equal-time comparison and the sample counts chosen by time), which no two runs share.

Stages are found by the command's own progress lines, not by time, so the matrix means the same on a loaded
machine; the only time limit is a hang guard. Each run has a cache of its own, copied from a warm one without
the entries the stages make (references for ``render``, the report's sections for ``demo``), so the
interrupted steps really run. Prints one JSON object; exit status 1 if any case failed.

    python benchmarks/sigint_matrix.py [--repeat 3] [--only render|demo]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HANG_S = 3600.0  # a guard against a hang, never a measure: a loaded machine may take what it takes

# the command, the stage lines (regular expressions on stderr) in the order they come, and the cache folders the
# stages fill (removed from the warm cache each run starts with)
COMMANDS = {
    "render": (["render", "--scene", "slab", "--size", "256x192", "--spp", "64", "--reference", "--reference-spp",
                "16", "--reference-max-spp", "48", "--json", "--out", "out/slab.exr", "--save-gbuffer",
                "out/gbuffer.exr"],
               {"gbuffer": r"rendering the slab G-buffer", "separable": r"separable pass:",
                "reference": r"path tracing slab: \d+/"},
               ("reference",)),
    "demo": (["demo", "--material", "skin1", "--jobs", "2", "--out", "out/demo"],
             {"parent": r"writing the report to", "first section": r"\[1/\d+\] section ",
              "second section": r"\[\d+/\d+\] section screenspace"},
             ("demo", "figures")),
}


SRC = [ROOT / "src"]  # the ssskit that runs (--src: another checkout's, e.g. to show a failure without a fix)


def _env(cache: Path) -> dict[str, str]:
    return dict(os.environ, SSSKIT_CACHE_DIR=str(cache), PYTHONPATH=str(SRC[0]), SSSKIT_PROGRESS="lines")


def _files(folder: Path) -> dict[str, str]:
    """{relative path: sha1 of the bytes} of every file under ``folder``."""
    if not folder.exists():
        return {}
    return {str(p.relative_to(folder)): hashlib.sha1(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _untimed(text: str) -> str:
    """A page or JSON text with its timings masked (the demo's "built in 12.3 s", "done in", seconds)."""
    return re.sub(r"\d+(\.\d+)? ?(s|min|h)\b", "T", text)


def _outputs(work: Path) -> dict[str, str]:
    """What a run wrote: {path: sha1 of the bytes}."""
    return _files(work / "out")


def _pages(work: Path) -> dict[str, list[str]]:
    """Each HTML page a run wrote, as its parts: every table one part, the text between tables the others (a
    table that holds a measured time differs as a whole between two runs), timings in the text masked."""
    return {str(p.relative_to(work / "out")): re.split(r"(?=<table)|(?<=</table>)", _untimed(p.read_text()))
            for p in sorted((work / "out").rglob("*.html"))}


def _json_untimed(stdout: str) -> str:
    try:
        data = json.loads(stdout)
    except ValueError:
        return _untimed(stdout)

    def strip(v):
        if isinstance(v, dict):
            return {k: strip(x) for k, x in v.items() if "second" not in k and not k.endswith("_s") and k != "out"}
        if isinstance(v, list):
            return [strip(x) for x in v]
        return v
    return json.dumps(strip(data), sort_keys=True)


def run(command: str, mode: str, stages: list[str], warm: Path, base: Path) -> dict:
    """One run of ``command``: interrupted (``foreground``) at the first of ``stages`` whose line appears, or
    (``background``, SIGINT ignored) sent SIGINT from each stage's line on; None: uninterrupted."""
    args, lines, fills = COMMANDS[command]
    work = Path(tempfile.mkdtemp(prefix=f"sigint-{command}-", dir=base))
    cache = work / "cache"
    shutil.copytree(warm, cache, ignore=lambda d, names: [n for n in names if Path(d) == warm and n in fills])
    before = _files(cache)
    (work / "out").mkdir()
    ignore = mode == "background"
    proc = subprocess.Popen([sys.executable, "-m", "ssskit.cli", *args], cwd=work, env=_env(cache),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=(lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if ignore else None)
    pending = [(s, re.compile(lines[s])) for s in stages]
    sent: list[str] = []
    err: list[str] = []
    firing = threading.Event()
    t0 = time.monotonic()

    def keep_sending() -> None:  # background: SIGINT every 0.1 s from the first stage's line on
        while proc.poll() is None:
            try:
                os.killpg(proc.pid, signal.SIGINT)
            except ProcessLookupError:
                return
            time.sleep(0.1)

    guard = threading.Timer(HANG_S, lambda: os.killpg(proc.pid, signal.SIGKILL))
    guard.daemon = True
    guard.start()
    stdout: list[str] = []
    reader = threading.Thread(target=lambda: stdout.append(proc.stdout.read()), daemon=True)
    reader.start()
    for text in proc.stderr:
        err.append(text)
        if pending and pending[0][1].search(text):
            stage, _ = pending.pop(0)
            sent.append(stage)
            if ignore:
                if not firing.is_set():
                    firing.set()
                    threading.Thread(target=keep_sending, daemon=True).start()
            else:
                os.killpg(proc.pid, signal.SIGINT)
                pending.clear()
    code = proc.wait()
    guard.cancel()
    reader.join()
    seconds = time.monotonic() - t0
    left = True
    for _ in range(600):  # the group ends with the command: its workers are joined before it exits
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            left = False
            break
        time.sleep(0.1)
    stderr = "".join(err)
    (work / "stderr.txt").write_text(stderr)
    result = {"command": command, "mode": mode, "stages": stages, "interrupted_at": sent, "exit": code,
              "seconds": round(seconds, 1), "group_left": left, "traceback": "Traceback" in stderr,
              "wound_down": stderr.count("winding down"), "work": str(work)}
    result["outputs"] = _outputs(work)
    result["pages"] = _pages(work)
    result["staging_left"] = [p.name for p in (work / "out").iterdir() if p.name.startswith(".")]
    result["stdout"] = _json_untimed("".join(stdout))
    result["cache_added"] = sorted(set(_files(cache)) - set(before))
    if code not in (0, 130):
        result["stderr_tail"] = stderr[-2000:]
    return result


def stable(a: dict, b: dict) -> dict:
    """What two uninterrupted runs ``a`` and ``b`` agree on: the demo measures times (the adaptive section's phase
    table, its equal-time comparison and the sample counts chosen from them), which differ from run to run.
    {"files": {path: digest} of the files equal in both, "varying": [paths that differ], "pages": {path: [part
    (text, or a whole table) or None where the two differ]}, "stdout": the stdout if equal, else None}."""
    files = {k: v for k, v in a["outputs"].items() if b["outputs"].get(k) == v}
    pages = {}
    for name, cells in a["pages"].items():
        other = b["pages"].get(name, [])
        pages[name] = ([x if x == y else None for x, y in zip(cells, other)] if len(cells) == len(other)
                       else [None] * len(cells))
    return {"files": files, "varying": sorted(set(a["outputs"]) - set(files)), "pages": pages,
            "names": sorted(a["outputs"]), "stdout": a["stdout"] if a["stdout"] == b["stdout"] else None}


def judge(r: dict, base: dict) -> list[str]:
    """What is wrong with run ``r`` (an empty list: it passed), against :func:`stable` of two uninterrupted runs."""
    bad = []
    if r["traceback"]:
        bad.append("traceback")
    if r["group_left"]:
        bad.append("a process of its group outlived it")
    if r["mode"] == "foreground":
        if r["exit"] != 130:
            bad.append(f"exit {r['exit']}, not 130")
        if r["outputs"] or r["staging_left"]:
            bad.append(f"wrote {sorted(r['outputs']) + r['staging_left']}")
        if r["stdout"].strip():
            bad.append("printed a result")
        stray = [f for f in r["cache_added"] if f not in base["cache_added"]]
        if stray:
            bad.append(f"cached what an uninterrupted run does not: {stray}")
        if len(r["interrupted_at"]) != 1:
            bad.append("its stage never came")
    else:
        if r["exit"] != 0:
            bad.append(f"exit {r['exit']}, not 0")
        if sorted(r["outputs"]) != base["names"]:
            bad.append(f"other files than an uninterrupted run: {sorted(set(r['outputs']) ^ set(base['names']))}")
        diff = sorted(k for k, v in base["files"].items() if r["outputs"].get(k) != v)
        if diff:
            bad.append(f"outputs differ from an uninterrupted run: {diff[:10]}")
        for name, cells in base["pages"].items():
            mine = r["pages"].get(name, [])
            if len(mine) != len(cells) or any(c is not None and c != m for c, m in zip(cells, mine)):
                bad.append(f"{name} differs from an uninterrupted run beyond what two uninterrupted runs differ in")
        if base["stdout"] is not None and r["stdout"] != base["stdout"]:
            bad.append("stdout differs from an uninterrupted run")
        if len(r["interrupted_at"]) != len(r["stages"]):
            bad.append(f"stages reached: {r['interrupted_at']}")
    return bad


def recheck_pages(folder: Path) -> int:
    """The page comparison of :func:`judge` again, on the runs a matrix kept (``--keep``): the first two runs of a
    command that wrote a page are its uninterrupted ones; every later one that wrote a page is a background run."""
    report: dict = {}
    for command in COMMANDS:
        runs = sorted((d for d in folder.glob(f"sigint-{command}-*") if list((d / "out").rglob("*.html"))),
                      key=lambda d: (d / "stderr.txt").stat().st_mtime)
        if len(runs) < 3:
            continue
        base = stable({"outputs": {}, "pages": _pages(runs[0]), "stdout": ""},
                      {"outputs": {}, "pages": _pages(runs[1]), "stdout": ""})
        report[command] = {d.name: [name for name, parts in base["pages"].items()
                                    if len(_pages(d).get(name, [])) != len(parts)
                                    or any(c is not None and c != m for c, m in zip(parts, _pages(d)[name]))]
                           for d in runs[2:]}
        report[command]["varying_parts"] = {name: sum(c is None for c in parts) for name, parts in base["pages"].items()}
    print(json.dumps(report, indent=1))
    return 1 if any(v for r in report.values() for k, v in r.items() if k != "varying_parts") else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=sorted(COMMANDS))
    ap.add_argument("--warm-cache", type=Path, default=None,
                    help="a cache to copy for each run [default: $SSSKIT_CACHE_DIR or ~/.cache/ssskit]")
    ap.add_argument("--keep", action="store_true", help="keep each run's folder")
    ap.add_argument("--src", type=Path, default=SRC[0], help="the src folder of the ssskit to run")
    ap.add_argument("--recheck-pages", type=Path, default=None, metavar="DIR",
                    help="compare the pages of the runs kept in DIR (--keep) with its first two, uninterrupted, runs")
    a = ap.parse_args()
    SRC[0] = a.src.resolve()
    if a.recheck_pages:
        return recheck_pages(a.recheck_pages)
    from ssskit.cache import cache_root

    warm = a.warm_cache or cache_root()
    base = Path(tempfile.mkdtemp(prefix="sigint-matrix-"))
    commands = [a.only] if a.only else list(COMMANDS)
    report: dict = {"src": str(SRC[0]), "machine": os.uname().nodename, "cpus": os.cpu_count(), "warm_cache": str(warm), "rounds": []}
    failed = 0
    baselines = {}
    for c in commands:  # two uninterrupted runs: what they agree on is what an interrupted one must give
        pair = [run(c, "uninterrupted", [], warm, base) for _ in range(2)]
        for b in pair:
            if b["exit"] != 0:
                print(json.dumps({"baseline_failed": {k: v for k, v in b.items() if k != "pages"}}, indent=1))
                return 1
        baselines[c] = {**stable(*pair), "cache_added": sorted(set(pair[0]["cache_added"]) | set(pair[1]["cache_added"]))}
    report["baselines"] = {c: {"outputs": len(b["names"]), "varying_between_two_uninterrupted_runs": b["varying"],
                               "stdout_equal": b["stdout"] is not None} for c, b in baselines.items()}
    for k in range(a.repeat):
        load_before = os.getloadavg()
        cases = []
        for c in commands:
            stages = list(COMMANDS[c][1])
            runs = [run(c, "foreground", [s], warm, base) for s in stages]
            runs.append(run(c, "background", stages, warm, base))
            for r in runs:
                r["failures"] = judge(r, baselines[c])
                failed += bool(r["failures"])
                cases.append({key: r[key] for key in ("command", "mode", "interrupted_at", "exit", "seconds",
                                                     "wound_down", "failures")})
        report["rounds"].append({"round": k + 1, "loadavg_before": [round(x, 2) for x in load_before],
                                 "loadavg_after": [round(x, 2) for x in os.getloadavg()], "cases": cases})
        print(json.dumps(report["rounds"][-1]), file=sys.stderr, flush=True)
    report["failed_cases"] = failed
    if not a.keep:
        shutil.rmtree(base, ignore_errors=True)
    print(json.dumps(report, indent=1))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
