"""A small case-insensitive name → object registry, one per family (materials, profile models...)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

from .errors import SsskitError

T = TypeVar("T")


def _key(name: str) -> str:
    return name.strip().lower().replace("_", "-")


class Registry(Generic[T]):
    """Maps names to entries; lookups ignore case, surrounding spaces and ``_`` vs ``-``."""

    def __init__(self, kind: str, error: type[SsskitError] = SsskitError) -> None:
        self.kind = kind
        self._error = error
        self._entries: dict[str, tuple[str, T]] = {}

    def register(self, name: str, entry: T) -> T:
        key = _key(name)
        if key in self._entries:
            raise self._error(f"{self.kind} {name!r} is already registered")
        self._entries[key] = (name, entry)
        return entry

    def decorator(self, name: str) -> Callable[[T], T]:
        return lambda entry: self.register(name, entry)

    def get(self, name: str) -> T:
        if not isinstance(name, str):
            raise self._error(f"a {self.kind} is named by a string, got {type(name).__name__} {name!r} "
                              f"(known: {', '.join(self.names())})")
        try:
            return self._entries[_key(name)][1]
        except KeyError:
            known = ", ".join(self.names())
            raise self._error(f"unknown {self.kind} {name!r} (known: {known})") from None

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and _key(name) in self._entries

    def names(self) -> list[str]:
        """Canonical names in registration order."""
        return [name for name, _ in self._entries.values()]

    def items(self) -> Iterator[tuple[str, T]]:
        return iter(self._entries.values())

    def __len__(self) -> int:
        return len(self._entries)
