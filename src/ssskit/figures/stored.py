"""Figure data computed once: a pickle per (name, key) in one of ssskit's cache folders."""

from __future__ import annotations

import hashlib
import json
import pickle
from pathlib import Path
from typing import Any, Callable, TypeVar

from ..cache import Kind, cache_dir
from ..io import atomic_output

T = TypeVar("T")


_MISSING = object()


def _path(kind: Kind, name: str, key: dict[str, Any]) -> Path:
    text = json.dumps(key, sort_keys=True, default=str)
    return cache_dir(kind) / f"{name}-{hashlib.sha1(text.encode()).hexdigest()[:16]}.pkl"


def _load(path: Path) -> Any:
    if path.is_file():
        try:
            with open(path, "rb") as fh:
                return pickle.load(fh)
        except Exception:  # noqa: BLE001 - an unreadable entry counts as missing
            pass
    return _MISSING


def peek(kind: Kind, name: str, key: dict[str, Any]) -> Any:
    """What :func:`stored` holds for ``key``, or None when nothing (readable) is stored; computes nothing."""
    value = _load(_path(kind, name, key))
    return None if value is _MISSING else value


def stored(kind: Kind, name: str, key: dict[str, Any], make: Callable[[], T]) -> T:
    """``make()`` once per ``key`` (JSON, non-JSON values by ``str``), pickled in ``cache_dir(kind)``;
    an unreadable entry is computed again."""
    path = _path(kind, name, key)
    value = _load(path)
    if value is not _MISSING:
        return value
    value = make()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as fh:
            pickle.dump(value, fh)
    return value
