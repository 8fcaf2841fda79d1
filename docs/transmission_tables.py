"""Regenerate the transmission tables ssskit ships (src/ssskit/profiles/montecarlo/data/transmission_tables.json).

    python docs/transmission_tables.py                 # the 11 measured materials at the product's defaults
    python docs/transmission_tables.py --only skin1,ketchup --out /tmp/t.json   # a trial file

Each table is :func:`ssskit.profiles.montecarlo.transmission.transmission_table` of one material of
:func:`ssskit.profiles.montecarlo.shipped.table_materials` at its defaults (2 x 10^5 photons per run, seed 101,
the default thickness grid and floor), simulated on the numba engine (``shipped=False``: the shipped file is not
read), with a progress bar per run on stderr. Finished runs land in the ssskit cache (``$SSSKIT_CACHE_DIR``) and an
interrupted one is continued, so running the script again after Ctrl-C loses nothing. The file is written once
every table is done; prints one JSON line (size, times, thicknesses per table). The tables must be regenerated
when the engine version, the supplement's grid or a table's derivation (``TABLE_VERSION``) changes:
tests/profiles/test_shipped_tables.py fails until then.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import sys
import time
from pathlib import Path

from ssskit.profiles.montecarlo import simulate
from ssskit.profiles.montecarlo import transmission as tr
from ssskit.profiles.montecarlo.shipped import TABLES_FILE, table_materials, write_tables


def main(argv: list[str] | None = None) -> int:
    signal.signal(signal.SIGTERM, signal.default_int_handler)  # kill like Ctrl-C: the running simulation keeps its batches
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=TABLES_FILE, help="the file to write (default: the package's)")
    ap.add_argument("--only", default="", help="comma-separated material names (a trial file: the tests want all 11)")
    args = ap.parse_args(argv)
    wanted = {n.strip().lower() for n in args.only.split(",") if n.strip()}
    materials = [(label, m) for label, m in table_materials() if not wanted or label.lower() in wanted]
    if wanted - {label.lower() for label, _ in materials}:
        ap.error(f"unknown materials: {', '.join(sorted(wanted - {label.lower() for label, _ in materials}))}")
    entries = []
    t0 = time.perf_counter()
    for k, (label, m) in enumerate(materials, 1):
        print(f"[{k}/{len(materials)}] {label}: slabs of {tr.DEFAULT_PHOTONS:,} photons per channel "
              f"({time.perf_counter() - t0:.0f} s so far)", file=sys.stderr, flush=True)
        table = tr.transmission_table(m, shipped=False, resume=True, progress=True)
        runs = tr.table_runs(m)[: len(table.thickness_mm)]  # the table's simulations, from the cache: their own times
        seconds = sum(simulate(cfg, shipped=False).seconds for row in runs for cfg in row)
        entries.append((label, tr.table_key(m), table.to_dict(), seconds))
    made = {"date": time.strftime("%Y-%m-%d"), "machine": platform.processor() or platform.machine(),
            "python": platform.python_version(), "cpus": os.cpu_count()}
    defaults = {"photons": tr.DEFAULT_PHOTONS, "seed": tr.DEFAULT_SEED, "floor": tr.T_FLOOR, "grid_mm": list(tr.GRID_MM),
                "table_version": tr.TABLE_VERSION}
    path = write_tables(entries, args.out, made, defaults)
    print(json.dumps({"file": str(path), "kb": round(path.stat().st_size / 1024, 1), "tables": len(entries),
                      "thicknesses": {label: len(t["thickness_mm"]) for label, _, t, _ in entries},
                      "seconds_simulated": round(sum(e[3] for e in entries), 1),
                      "seconds_wall": round(time.perf_counter() - t0, 1)}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
