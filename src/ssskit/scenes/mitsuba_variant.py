"""Mitsuba 3, imported when a scene is first rendered (never at ``import ssskit``), with the ``scalar_rgb``
variant every scene and reference of ssskit renders in (CPU, any machine)."""

from __future__ import annotations

from types import ModuleType

from ..errors import SceneError


def mitsuba() -> ModuleType:
    """The ``mitsuba`` module with the ``scalar_rgb`` variant set, or a SceneError saying how to get it."""
    try:
        import mitsuba as mi
    except ImportError:  # pragma: no cover - mitsuba is a core dependency
        raise SceneError("the 3D scenes need Mitsuba 3: pip install mitsuba") from None
    if mi.variant() != "scalar_rgb":
        mi.set_variant("scalar_rgb")
    return mi


__all__ = ["mitsuba"]
