"""Mitsuba 3, imported when a scene is first rendered (never at ``import ssskit``), with the ``scalar_rgb``
variant every scene and reference of ssskit renders in (CPU, any machine)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
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


@contextlib.contextmanager
def mitsuba_threads(n: int) -> Iterator[None]:
    """Within the block Mitsuba renders on ``n`` threads (Dr.Jit's pool; at least 1), then on as many as before.
    Its images do not depend on the count (each pixel's samples are seeded by the pixel: tested), so a caller
    can leave a core to other work, e.g. a thread compiling the pass's kernels meanwhile."""
    import drjit as dr

    mitsuba()
    before = dr.thread_count()
    dr.set_thread_count(max(1, int(n)))
    try:
        yield
    finally:
        dr.set_thread_count(before)


__all__ = ["mitsuba", "mitsuba_threads"]
