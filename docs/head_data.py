"""Regenerate the shipped head scan, src/ssskit/scenes/data/head.npz, from the PLY (values unchanged),
and print the head's breadth and length (file units and mm at ssskit's scale: docs/head.md, "Scale").

    python docs/head_data.py [--ply ../shared/data/head/head.ply]

tests/scenes/test_head.py checks the shipped file against the PLY read by trimesh when the PLY is at hand.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ssskit.scenes.head import DATA_PATH, MM_PER_UNIT, head_measures, write_head_data


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ply", default=str(Path(__file__).resolve().parents[1].parent / "shared" / "data" / "head" / "head.ply"))
    args = ap.parse_args(argv)
    path = write_head_data(args.ply, DATA_PATH)
    units = head_measures()
    out = {"file": str(path), "bytes": path.stat().st_size, "units": units,
           "mm": {k: v * MM_PER_UNIT for k, v in units.items()}, "mm_per_unit": MM_PER_UNIT}
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
