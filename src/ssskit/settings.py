"""Frozen settings dataclasses that load from and save to TOML or JSON files.

A settings class derives from :class:`Settings` and declares each field with :func:`setting`: its default, its
quantity (:mod:`ssskit.quantities`: range, unit, reason; a :class:`~ssskit.quantities.Choice` or
:class:`~ssskit.quantities.Flag`) and what it applies to (``applies=("pass", ("separable",))``: the field is
used only when the settings' ``pass`` is separable). :meth:`Settings.__post_init__` checks every declared
field (a :class:`~ssskit.errors.SettingsError` naming it, in the quantities' wording) and refuses, once and
in one wording, every field given (not at its default) that what runs does not use; a class adds only its
rules between fields. So every argument is validated when the settings are made, before any work starts.
Nested settings (a field whose type is another Settings class) become TOML tables / JSON objects.

    >>> from ssskit.screenspace import PassSettings
    >>> s = PassSettings(jitter=0.1, frame=3)
    >>> PassSettings.from_dict(s.to_dict()) == s
    True
"""

from __future__ import annotations

import dataclasses
import json
import typing
from pathlib import Path
from typing import Any, ClassVar, Self

from .errors import SettingsError, unknown_names_message
from .quantities import FRAMES, PHOTONS, SIZE_PX, TAPS, Choice, Flag, Quantity, Rule, check_keys, refuse_unused

#: ranges the settings and the command line share (here, below every layer that checks them, so the CLI's
#: option types need not import the pipeline): image sides of the built-in scenes (pixels), photons of a
#: Monte Carlo profile, taps of a 1D pass
SIZE_RANGE = (int(SIZE_PX.lo), int(SIZE_PX.hi))
PHOTONS_RANGE = (int(PHOTONS.lo), int(PHOTONS.hi))
#: the credit the built-in head's licence (CC BY 3.0) asks for (ssskit.scenes.head; here so that --help can name it
#: without importing the scenes)
HEAD_ATTRIBUTION = "Head scan: Lee Perry-Smith, Infinite-Realities (CC BY 3.0)"
#: photons per channel of a Monte Carlo profile by default: the supplement's (section F)
DEFAULT_PHOTONS = 10_000_000
TAP_RANGE = (int(TAPS.lo), int(TAPS.hi))
#: frames of one adaptive run or sequence (RenderSettings' AdaptivePass, adaptive_frames, sequence_gbuffers)
FRAMES_RANGE = (int(FRAMES.lo), int(FRAMES.hi))


Checkable = Quantity | Choice | Flag | Rule


def setting(quantity: Checkable | None, default: Any = dataclasses.MISSING, *,
            applies: tuple[str, tuple[str, ...]] | None = None, optional: bool = False,
            default_factory: Any = dataclasses.MISSING, rgb: bool = False) -> Any:
    """A declared settings field: its ``quantity`` (checked by :meth:`Settings.__post_init__`, None for a field
    its class checks itself), ``applies`` (``(category, values)``: used only when the settings'
    :meth:`~Settings.situation` gives ``category`` one of ``values``; given otherwise, it is refused),
    ``optional`` (None passes: the default is taken elsewhere) and ``rgb`` (one number or three, R, G, B)."""
    meta = {"quantity": quantity, "applies": applies, "optional": optional, "rgb": rgb}
    if default_factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=default_factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def like(cls: type, name: str, **changes: Any) -> Any:
    """A field declared as ``cls``'s field ``name`` (its quantity, default, ``optional``, ``rgb``, ``applies``),
    with ``changes`` (e.g. ``applies=``): a settings class that holds another's values declares them once."""
    f = {g.name: g for g in dataclasses.fields(cls)}[name]
    meta = {**f.metadata, **changes}
    return setting(meta.get("quantity"), f.default, applies=meta.get("applies"), optional=meta.get("optional", False),
                   default_factory=f.default_factory, rgb=meta.get("rgb", False))


class Settings:
    """Mixin for frozen dataclasses: declared fields checked when made (:func:`setting`), ``to_dict``,
    ``from_dict``, ``replace``, ``load`` and ``save``."""

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

    def __post_init__(self) -> None:
        """Check every field declared with a quantity (setting its canonical value: an int, a float, a name's
        spelling, three floats), then refuse the fields given that what runs does not use (:meth:`unused`)."""
        for f in dataclasses.fields(self):
            q = f.metadata.get("quantity")
            value = getattr(self, f.name)
            if q is None or (value is None and f.metadata.get("optional")):
                continue
            if f.metadata.get("rgb"):
                assert isinstance(q, Quantity)
                value = q.check_rgb(value, f.name, SettingsError)
            else:
                value = q.check(value, f.name, SettingsError)
            object.__setattr__(self, f.name, value)
        self.check_applies()

    def situation(self) -> dict[str, str]:
        """What runs, by category (the categories the fields' ``applies`` name): by default each category is
        a field of the same name. A class whose categories are derived (a pass's name, a moving camera)
        overrides this."""
        return {}

    def unused(self) -> dict[tuple[str, tuple[str, ...], str], list[str]]:
        """The fields given (not at their default) whose ``applies`` the :meth:`situation` does not meet,
        grouped by what they apply to and what runs instead: (category, values, what runs) -> names."""
        situation = self.situation()
        out: dict[tuple[str, tuple[str, ...], str], list[str]] = {}
        for f in dataclasses.fields(self):
            applies = f.metadata.get("applies")
            if applies is None:
                continue
            category, values = applies
            now = situation[category] if category in situation else str(getattr(self, category)).lower()
            if now in values:
                continue
            default = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
            if getattr(self, f.name) != default:
                out.setdefault((category, values, now), []).append(f.name)
        return out

    def check_applies(self) -> None:
        """Refuse, in the one wording (:func:`ssskit.quantities.refuse_unused`), the fields given that what
        runs does not use."""
        for (category, values, now), names in self.unused().items():
            refuse_unused(names, category, values, now, SettingsError)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            out[f.name] = v.to_dict() if isinstance(v, Settings) else (list(v) if isinstance(v, tuple) else v)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "") -> Self:
        """Build from plain data; unknown keys and wrong types are errors naming the key."""
        check_keys(data, where or cls.__name__, error=SettingsError)  # a table (its keys: the fields, below)
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
        from .io import read_document

        return read_document(path, "settings file", SettingsError, (".toml", ".json"), cls.from_dict)  # (io: its rules)

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

