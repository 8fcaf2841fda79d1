"""Path-traced references of the built-in head (docs/head.md, "References"): Mitsuba volpathmis per view and
material, in independent chunks until the relative standard error of the SSS pixels' mean is at most
--rel-se or --max-spp is spent; cached (ssskit's reference cache), so the figures reuse them. Prints JSON
(per view: spp, seconds, every region's level and standard error) and writes it to --json.

    nice -n 10 python docs/head_references.py [--size 96x72] [--views front ear close] [--materials skin1]
        [--rel-se 0.02] [--max-spp 4096] [--json docs/head_references.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time


def main(argv: list[str] | None = None) -> dict:
    from ssskit.figures.head import head_references

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="96x72")
    ap.add_argument("--views", nargs="+", default=["front", "ear", "close"])
    ap.add_argument("--materials", nargs="+", default=["skin1"])
    ap.add_argument("--rel-se", type=float, default=0.02)
    ap.add_argument("--max-spp", type=int, default=4096)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    w, _, h = args.size.partition("x")
    t0 = time.time()
    rows = head_references(views=args.views, materials=args.materials, width=int(w), height=int(h),
                           rel_se=args.rel_se, max_spp=args.max_spp, progress=print)
    out = {"command": "python docs/head_references.py " + " ".join(argv or []), "rows": rows,
           "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "load_avg": os.getloadavg()},
           "seconds": time.time() - t0}
    text = json.dumps(out, indent=1)
    if args.json:
        with open(args.json, "w") as fh:
            fh.write(text + "\n")
    print(text)
    return out


if __name__ == "__main__":
    main()
