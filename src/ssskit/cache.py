"""One on-disk cache root for everything ssskit computes once and reuses.

The root is ``$SSSKIT_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/ssskit`` (default
``~/.cache/ssskit``). Each kind of result has its own sub-folder, named here so that no module
borrows another's: ``mcml`` (Monte Carlo profiles), ``reference`` (path-traced images),
``meshes`` (the built-in scenes' PLY meshes), ``gbuffers`` (per-frame G-buffers of sequences), ``figures``
(the frame sequences behind the adaptive sampler's figures), ``demo`` (the demo report's sections, keyed
by their settings and the package's source, so a second ``ssskit demo`` copies them instead of computing).
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path
from typing import Literal, get_args

#: sub-folders of the cache root, one per kind of cached result (a type for mypy; cache_dir refuses any other kind)
Kind = Literal["mcml", "reference", "meshes", "demo", "gbuffers", "figures"]
KINDS: tuple[Kind, ...] = get_args(Kind)
#: the longest readable part of a cache file's name (bytes of UTF-8): with the key, the suffix and the atomic
#: writer's temporary prefix and suffix a name stays far below the 255 bytes most file systems allow
NAME_BYTES = 80


def cache_root() -> Path:
    """$SSSKIT_CACHE_DIR, else $XDG_CACHE_HOME/ssskit (XDG default ~/.cache)."""
    env = os.environ.get("SSSKIT_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "ssskit"


def source_digest() -> str:
    """A hash of ssskit's own source (Python and GLSL): a cached result keyed by it is reused only by
    the code that made it."""
    import hashlib

    root = Path(__file__).parent
    h = hashlib.sha1()
    for path in sorted(root.rglob("*.py")) + sorted(root.rglob("*.comp")):
        h.update(str(path.relative_to(root)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def cache_dir(kind: Kind) -> Path:
    """The folder of one kind of cached result (see :data:`KINDS`); not created here."""
    if kind not in KINDS:  # (the type says so to mypy; a caller's string is checked here, so no path leaves the root)
        raise ValueError(f"cache kind must be one of {', '.join(KINDS)}, got {kind!r}")
    return cache_root() / kind


def cache_file(kind: Kind, name: str, key: str, suffix: str) -> Path:
    """``cache_dir(kind) / "{name}-{key}{suffix}"`` with a bounded, readable ``name`` (a scene's or a mesh's, which
    come from a user's file names): characters other than letters, digits, ``.``, ``_`` and ``-`` become ``_`` (no
    separator or NUL reaches the path), and a name longer than :data:`NAME_BYTES` keeps its beginning and ends in
    ``~`` and 8 hex digits of the whole name's sha1, so two long names with the same beginning stay apart. (A
    240-character mesh name made a name over the file system's 255 bytes: the mesh could not be rendered.)"""
    readable = re.sub(r"[^A-Za-z0-9._-]", "_", name) or "_"
    if len(readable.encode()) > NAME_BYTES:
        readable = f"{readable[:NAME_BYTES - 9]}~{hashlib.sha1(name.encode()).hexdigest()[:8]}"
    return cache_dir(kind) / f"{readable}-{key}{suffix}"
