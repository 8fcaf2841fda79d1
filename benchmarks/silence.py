"""The longest silence of a command: how long its stderr (a pipe, so no terminal) goes without a line.

    python benchmarks/silence.py -- ssskit simulate --material skin1,marble,ketchup --jobs 2
    python benchmarks/silence.py --env SSSKIT_CACHE_DIR=/tmp/empty-cache -- ssskit demo --out /tmp/demo
    python benchmarks/silence.py --log demo.log -- ssskit demo --out /tmp/demo   # keep the stamped lines

Runs the command with stdout and stderr as pipes and stamps every stderr line as it arrives; prints one
JSON object: the exit status, the wall time, the CPU time, the number of stderr lines, the longest gap in seconds
(from the start to the first line, between lines, and from the last line to the exit) and the lines
around it, and the load average before and after (the machine is shared: silences grow with load).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time


def stamped_run(cmd: list[str], env: dict[str, str] | None = None, log: str | None = None) -> dict:
    """Run ``cmd`` with its stderr stamped line by line (stdout drained); the JSON this script prints, plus
    ``lines``: every (seconds since the start, stderr line) and ``cpu_s``: the command's CPU seconds (user +
    system of it and the children it waited for, from getrusage)."""
    import resource

    load0 = os.getloadavg()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    stamps: list[tuple[float, str]] = []

    def drain_stdout() -> None:
        assert proc.stdout is not None
        for _ in proc.stdout:
            pass

    reader = threading.Thread(target=drain_stdout, daemon=True)
    reader.start()
    assert proc.stderr is not None
    out = open(log, "w") if log else None  # noqa: SIM115 - closed below
    for line in proc.stderr:
        stamps.append((time.perf_counter() - t0, line.rstrip("\n")))
        if out is not None:
            out.write(f"{stamps[-1][0]:8.1f} {stamps[-1][1]}\n")
            out.flush()
    if out is not None:
        out.close()
    code = proc.wait()
    reader.join()
    wall = time.perf_counter() - t0
    after_ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    times = [0.0] + [t for t, _ in stamps] + [wall]
    gaps = [b - a for a, b in zip(times, times[1:])]
    k = max(range(len(gaps)), key=gaps.__getitem__)
    silence_after = stamps[k - 1][1] if k >= 1 else "(start)"
    silence_before = stamps[k][1] if k < len(stamps) else "(exit)"
    return {"command": cmd, "exit": code, "wall_s": round(wall, 1),
            "cpu_s": round(after_ru.ru_utime - before.ru_utime + after_ru.ru_stime - before.ru_stime, 1),
            "stderr_lines": len(stamps), "longest_silence_s": round(gaps[k], 1), "silence_after": silence_after,
            "silence_before": silence_before, "load_before": [round(v, 2) for v in load0],
            "load_after": [round(v, 2) for v in os.getloadavg()], "lines": stamps}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", action="append", default=[], metavar="NAME=VALUE", help="extra environment")
    ap.add_argument("--log", default=None, metavar="FILE",
                    help="also write every stderr line to FILE, stamped with its seconds since the start")
    ap.add_argument("command", nargs=argparse.REMAINDER, help="the command, after --")
    args = ap.parse_args(argv)
    cmd = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not cmd:
        ap.error("give the command after --")
    env = dict(os.environ, **dict(e.split("=", 1) for e in args.env))
    result = stamped_run(cmd, env, args.log)
    del result["lines"]
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
