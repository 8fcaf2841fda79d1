"""What the viewer's browser tests share: the static bust page as a user writes it, and float read-backs."""
from __future__ import annotations

import base64
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np


def static_bust(tmp_path_factory: Any) -> Path:
    """``ssskit view --scene bust --no-open --out DIR`` run as a user runs it (Skin1 alone: test time)."""
    out = tmp_path_factory.mktemp("view") / "site"
    proc = subprocess.run([sys.executable, "-m", "ssskit", "view", "--scene", "bust", "--no-open", "--out", str(out),
                           "--presets", "skin1"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return out


def read_target(pg: Any, name: str, w: int, h: int) -> np.ndarray:
    """A float target of the page (``window.ssskit.read``), (h, w, 4) float32, rows from the top."""
    raw = base64.b64decode(pg.evaluate(f"() => window.ssskit.read('{name}')"))
    return np.frombuffer(raw, np.float32).reshape(h, w, 4)[::-1].copy()
