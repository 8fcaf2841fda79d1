"""The registry of export formats (:class:`Format`: suffixes, writer, reader, the options that apply), filled by
:mod:`ssskit.export.formats` and by any module that adds a format (docs/architecture.md, "How to add an engine
format"); :func:`ssskit.export.export` writes through it and :func:`ssskit.export.readers.read_engine_file`
reads through it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..registry import Registry


@dataclass(frozen=True)
class Format:
    """An export format: ``suffixes`` it writes, ``kind`` ("kernel", "shader" or "engine"), ``options`` (the
    ExportSettings fields beyond :data:`COMMON` it takes), ``write(job) -> text`` (None: it wrote the file
    itself), ``read(path) -> EngineSource`` for an engine file read back as a material, ``check(request,
    source)`` for its own checks before any work (``source``: the checked material, :class:`~ssskit.export.readers.Source`), and a one-line ``description`` (the --format help)."""

    name: str
    suffixes: tuple[str, ...]
    kind: str
    options: tuple[str, ...]
    write: Callable[[Any], str | None]
    description: str
    read: Callable[..., Any] | None = None
    check: Callable[[Any, Any], None] | None = None


FORMATS: Registry[Format] = Registry("export format")


def get_format(name: object) -> Format:
    return FORMATS.get(name)  # type: ignore[arg-type]  # the registry refuses a non-string with the known names




__all__ = ["FORMATS", "Format", "get_format"]
