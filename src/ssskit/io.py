"""File output: atomic writes and profile exports (CSV / NPZ / JSON).

Every writer goes through :func:`atomic_output`: data lands in a temporary file beside the target
and is renamed over it only when complete, so an interrupted or failed run never leaves a
half-written file.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from .errors import SsskitError


class OutputError(SsskitError):
    """An output path that cannot be written (bad extension, missing permissions...)."""


@contextlib.contextmanager
def atomic_output(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path with the same suffix beside ``path``; rename it over ``path`` on success."""
    target = Path(path)
    parent = target.parent if str(target.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".tmp{target.suffix}", dir=parent)
    except OSError as exc:
        raise OutputError(f"cannot write {str(target)!r}: {exc.strerror}") from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def write_text(path: str | Path, text: str) -> None:
    with atomic_output(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def check_suffix(path: str | Path, allowed: tuple[str, ...], what: str) -> str:
    """The lower-case suffix of ``path`` if it is one of ``allowed``; else a precise error."""
    suffix = Path(path).suffix.lower()
    if suffix not in allowed:
        raise OutputError(f"{what} {str(path)!r} must end in {' or '.join(allowed)}")
    return suffix


def save_arrays(path: str | Path, **arrays) -> None:
    """Write an ``.npz`` of named arrays atomically."""
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)


def save_profile_table(path: str | Path, r_mm: np.ndarray, rd: np.ndarray, meta: dict[str, Any]) -> None:
    """Write R(r) per channel: ``.csv`` (r_mm, Rd_R, Rd_G, Rd_B; mm and mm^-2) or ``.npz``.

    ``meta`` (model, material, totals...) becomes '#' header lines in CSV and a JSON string
    entry ``meta`` in NPZ.
    """
    suffix = check_suffix(path, (".csv", ".npz"), "profile output")
    r_mm = np.asarray(r_mm, dtype=float)
    rd = np.asarray(rd, dtype=float)
    if suffix == ".csv":
        with atomic_output(path) as tmp:
            header = "\n".join(f"{k}: {json.dumps(v)}" for k, v in meta.items())
            header += "\nr_mm,Rd_R,Rd_G,Rd_B  (Rd in mm^-2)"
            np.savetxt(tmp, np.column_stack([r_mm, rd]), delimiter=",", header=header, fmt="%.10e")
    if suffix == ".npz":
        save_arrays(path, r_mm=r_mm, Rd=rd, meta=np.array(json.dumps(meta)))
