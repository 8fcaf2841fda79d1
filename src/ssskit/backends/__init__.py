"""Backends: who runs the screen-space passes, behind one small contract per pass.

    >>> from ssskit.backends import BACKENDS, get_backend, backend_status
    >>> sorted(BACKENDS.names())                            # doctest: +SKIP
    ['numba', 'numpy']
    >>> backend_status()["numpy"]["available"]              # doctest: +SKIP
    True

* ``numpy``: float64, vectorised over pixels, written to be read: the oracle every other backend is
  tested against;
* ``numba``: float32 on the CPU, parallel over rows, vectorised (the default);
* ``gl``: float32 GLSL compute shaders through moderngl/EGL, on a GPU or on Mesa's llvmpipe.

A backend is registered by name with a factory; :func:`get_backend` builds it once and checks that
it can run here (otherwise a :class:`~ssskit.errors.BackendError` saying why). How to add one:
``docs/architecture.md``.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable

from ..errors import BackendError
from ..registry import Registry
from .base import Backend
from .plan import DEPTH_MODES, SEPARABLE_FRAME, SeparablePlan, TermTable, build_separable_plan, check_arrays, term_rows

BACKENDS: Registry[Callable[[], Backend]] = Registry("backend", BackendError)
_INSTANCES: dict[str, Backend] = {}


def _numpy() -> Backend:
    from .numpy_backend import NumpyBackend

    return NumpyBackend()


def _numba() -> Backend:
    from .numba_backend import NumbaBackend

    return NumbaBackend()


def _gl() -> Backend:
    from .gl import GLBackend

    return GLBackend()


BACKENDS.register("numba", _numba)
BACKENDS.register("numpy", _numpy)
BACKENDS.register("gl", _gl)

#: the backend used when none is named
DEFAULT_BACKEND = "numba"


def _instance(name: str) -> Backend:
    factory = BACKENDS.get(name)
    key = next(n for n, f in BACKENDS.items() if f is factory)  # the canonical registry name
    if key not in _INSTANCES:
        _INSTANCES[key] = factory()
    return _INSTANCES[key]


def get_backend(name: str = DEFAULT_BACKEND) -> Backend:
    """The named backend, ready to run, or a BackendError (unknown name, or why it cannot run here)."""
    backend = _instance(name)
    ok, why = backend.availability()
    if not ok:
        raise BackendError(f"backend {backend.name!r} is not available: {why}")
    return backend


def warm_up_in_background(name: str, passes: Iterable[str]) -> threading.Thread | None:
    """Start :meth:`Backend.warm_up` of ``passes`` on the named backend on a daemon thread and return the thread,
    or None where the backend compiles nothing on first use. The thread works on an instance of its own (the
    shared one keeps its scratch buffers for the real frames); numba compiles under one lock, so a real frame
    that needs a kernel the thread is compiling waits for it instead of compiling it again. Meant to overlap
    a first frame's compilation (one thread) with the work before the pass: Mitsuba's G-buffer, which releases
    the GIL. Errors are dropped here: the real frame meets and reports them."""
    backend = get_backend(name)
    if not backend.compiles_on_first_use:
        return None
    names = list(passes)
    from .base import check_warm_up

    check_warm_up(names)
    fresh = type(backend)()

    def run() -> None:
        try:
            fresh.warm_up(names)
        except Exception:  # noqa: BLE001 - the real frame reports what goes wrong
            pass

    thread = threading.Thread(target=run, name="ssskit-warm-up", daemon=True)
    thread.start()
    return thread


def backend_status() -> dict[str, dict]:
    """Every registered backend: {name: {"available": bool, "details": str, "description": str}}."""
    out = {}
    for name in BACKENDS.names():
        b = _instance(name)
        ok, details = b.availability()
        out[name] = {"available": ok, "details": details, "description": b.description}
    return out


__all__ = [
    "BACKENDS",
    "Backend",
    "DEFAULT_BACKEND",
    "DEPTH_MODES",
    "SEPARABLE_FRAME",
    "SeparablePlan",
    "TermTable",
    "backend_status",
    "build_separable_plan",
    "check_arrays",
    "get_backend",
    "term_rows",
    "warm_up_in_background",
]
