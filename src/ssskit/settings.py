"""Frozen settings dataclasses that load from and save to TOML or JSON files.

A settings class derives from :class:`Settings`, declares its fields with defaults and checks them
in ``__post_init__`` (raising :class:`~ssskit.errors.SettingsError` naming the field), so every
argument is validated when the settings are made, before any work starts. Nested settings
(a field whose type is another Settings class) become TOML tables / JSON objects.

    >>> from ssskit.screenspace import PassSettings
    >>> s = PassSettings(jitter=0.1, frame=3)
    >>> PassSettings.from_dict(s.to_dict()) == s
    True
"""

from __future__ import annotations

import dataclasses
import json
import math
import typing
from pathlib import Path
from collections.abc import Collection
from typing import Any, ClassVar, Self, SupportsIndex

from .errors import SettingsError, unknown_names_message

#: ranges the settings and the command line share (here, below every layer that checks them, so the CLI's
#: option types need not import the pipeline): image sides of the built-in scenes (pixels), photons of a
#: Monte Carlo profile, taps of a 1D pass
SIZE_RANGE = (8, 8192)
PHOTONS_RANGE = (1_000, 10_000_000_000)
#: photons per channel of a Monte Carlo profile by default: the supplement's (section F)
DEFAULT_PHOTONS = 10_000_000
TAP_RANGE = (1, 255)
#: frames of one adaptive run or sequence (RenderSettings' AdaptivePass, adaptive_frames, sequence_gbuffers)
FRAMES_RANGE = (1, 100_000)


class Settings:
    """Mixin for frozen dataclasses: ``to_dict``, ``from_dict``, ``replace``, ``load`` and ``save``."""

    # what @dataclass gives every subclass (declared, not set: the mixin itself is no dataclass), so the
    # type checker sees a Settings as the dataclass instance that dataclasses.fields/replace take
    __dataclass_fields__: ClassVar[dict[str, dataclasses.Field[Any]]]

    def __new__(cls, *args: Any, **kwargs: Any) -> Self:
        """Refuse keywords that name no field with a SettingsError (the dataclass's own __init__ would raise a
        TypeError), in :meth:`from_dict`'s wording."""
        if kwargs and dataclasses.is_dataclass(cls):
            names = [f.name for f in dataclasses.fields(cls)]
            unknown = sorted(set(kwargs) - set(names))
            if unknown:
                raise SettingsError(unknown_names_message(cls.__name__, unknown, names))
        return super().__new__(cls)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            out[f.name] = v.to_dict() if isinstance(v, Settings) else (list(v) if isinstance(v, tuple) else v)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "") -> Self:
        """Build from plain data; unknown keys and wrong types are errors naming the key."""
        if not isinstance(data, dict):
            raise SettingsError(f"{where or cls.__name__}: expected a table/object, got {type(data).__name__}")
        names = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - set(names))
        if unknown:
            raise SettingsError(unknown_names_message(where or cls.__name__, unknown, list(names)))
        hints = typing.get_type_hints(cls)
        kwargs: dict[str, Any] = {}
        for key, value in data.items():
            sub = _settings_class(hints.get(key))
            if sub is not None:
                kwargs[key] = sub.from_dict(value, where=f"{where + '.' if where else ''}{key}")
            else:
                kwargs[key] = tuple(value) if isinstance(value, list) else value
        return cls(**kwargs)

    def replace(self, **changes: Any) -> Self:
        """A copy with ``changes`` applied (validated again)."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def load(cls, path: str | Path) -> Self:
        """Read a ``.toml`` or ``.json`` settings file."""
        p = Path(path)
        suffix = p.suffix.lower()
        if suffix not in (".toml", ".json"):
            raise SettingsError(f"settings file {str(p)!r} must end in .toml or .json")
        from .io import check_regular_file

        check_regular_file(p, "settings file", SettingsError)
        try:
            text = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise SettingsError(f"cannot read settings file {str(p)!r}: {getattr(exc, 'strerror', None) or exc}") from None
        from .io import parse_document

        try:
            data = parse_document(text, suffix)
        except ValueError as exc:
            raise SettingsError(f"malformed settings file {str(p)!r}: {exc}") from None
        try:
            return cls.from_dict(data)
        except SettingsError as exc:
            raise SettingsError(f"{str(p)!r}: {exc}") from None

    def save(self, path: str | Path) -> None:
        """Write a ``.toml`` or ``.json`` settings file atomically (None values are left out)."""
        from .io import check_suffix, write_text

        suffix = check_suffix(path, (".toml", ".json"), "settings file")
        data = _drop_none(self.to_dict())
        if suffix == ".json":
            write_text(path, json.dumps(data, indent=2) + "\n")
        else:
            import tomli_w  # the maintained writer of TOML (tomllib, its reader, is in the standard library)

            try:
                write_text(path, tomli_w.dumps(data))
            except TypeError as exc:  # a value TOML cannot hold (tomli_w names its type)
                raise SettingsError(f"cannot write settings file {str(path)!r} as TOML: {exc}") from None


def _settings_class(hint: Any) -> type[Settings] | None:
    for t in (hint, *typing.get_args(hint)):
        if isinstance(t, type) and issubclass(t, Settings):
            return t
    return None


def _drop_none(d: dict[str, Any]) -> dict[str, Any]:
    return {k: (_drop_none(v) if isinstance(v, dict) else v) for k, v in d.items() if v is not None}


def check_int(name: str, value: object, lo: int, hi: int) -> int:
    """An int in [lo, hi] (bools refused), or a SettingsError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, SupportsIndex):  # an int, or what has __index__
        raise SettingsError(f"{name} must be an integer, got {value!r}")
    v = int(value)
    if not lo <= v <= hi:
        raise SettingsError(f"{name} must lie in [{lo}, {hi}], got {v}")
    return v


def check_float(name: str, value: Any, lo: float, hi: float, *, open_lo: bool = False) -> float:
    """A finite float in [lo, hi] (in (lo, hi] with ``open_lo``), or a SettingsError naming ``name``
    and the interval."""
    if isinstance(value, bool):
        raise SettingsError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SettingsError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and (lo < v if open_lo else lo <= v) and v <= hi):
        raise SettingsError(f"{name} must be a finite number in {'(' if open_lo else '['}{lo:g}, {hi:g}], "
                            f"got {value!r}")
    return v


def check_choice(name: str, value: object, choices: Collection[str]) -> str:
    """``value`` (case-insensitive) if it is one of ``choices``, returned in its canonical spelling."""
    if isinstance(value, str):
        for c in choices:
            if c.lower() == value.strip().lower():
                return c
    raise SettingsError(f"{name} must be one of {', '.join(choices)}, got {value!r}")
