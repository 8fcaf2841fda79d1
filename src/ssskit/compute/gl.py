"""An OpenGL 4.3 context without a window (EGL through moderngl), compute shaders with readable errors,
and GPU timing.

The context is made once per process with ``moderngl.create_standalone_context(backend="egl",
require=430)``: on an NVIDIA GPU that is the vendor's EGL driver, elsewhere Mesa's (llvmpipe, the CPU
driver, where there is no GPU). ``SSSKIT_EGL_LIBRARY`` names the EGL library to load (default: the
loader's ``libEGL.so.1``): pointing it at a file that does not exist is how the tests force the
absence of EGL.
"""

from __future__ import annotations

import os
import re
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..errors import BackendError

if TYPE_CHECKING:
    import moderngl

#: what the gl backend needs, for the messages
REQUIREMENTS = ("the Python package moderngl (pip install moderngl) and an EGL driver with OpenGL 4.3 "
                "(Debian/Ubuntu: apt install libegl1 libgl1-mesa-dri libegl-mesa0)")

_LOCK = threading.RLock()
_STATE: dict[str, Any] = {}  # "ctx": the moderngl.Context, or "error": why there is none


class ShaderError(BackendError):
    """A compute shader that does not compile; the message shows the driver's log and the source line."""


def _create() -> moderngl.Context:
    try:
        import moderngl
    except ImportError as e:  # pragma: no cover - depends on the installation
        raise BackendError(f"moderngl is not installed ({e}); the gl backend needs {REQUIREMENTS}") from None
    kwargs = {"backend": "egl", "require": 430}
    lib = os.environ.get("SSSKIT_EGL_LIBRARY")
    if lib:
        kwargs["libegl"] = lib
    try:
        # moderngl's stub types **settings as dicts; they are strings (backend="egl", libegl=path)
        ctx = moderngl.create_standalone_context(**kwargs)  # type: ignore[arg-type]
    except Exception as e:  # glcontext raises plain Exceptions with the loader's message
        msg = " ".join(str(e).split()) or type(e).__name__
        raise BackendError(f"no OpenGL 4.3 context through EGL ({msg}); the gl backend needs {REQUIREMENTS}") from None
    return ctx


def context() -> moderngl.Context:
    """The process's GL context (made on first use), current in the calling thread, or a BackendError
    saying what is missing. Every entry point of the backend calls it: ``with ctx:`` blocks make the
    context current and, on leaving, make the previous one (possibly none) current again."""
    with _LOCK:
        if "ctx" not in _STATE and "error" not in _STATE:
            try:
                _STATE["ctx"] = _create()
            except BackendError as e:
                _STATE["error"] = e
        if "error" in _STATE:
            raise _STATE["error"]
        ctx = _STATE["ctx"]
        ctx.__enter__()  # make it current here (it may have been released by a ``with`` block)
        return ctx


def renderer() -> str:
    """The GL renderer string (``llvmpipe (LLVM ...)`` on the CPU, the GPU's name on a GPU)."""
    ctx = context()
    return f"{ctx.info['GL_RENDERER']}, OpenGL {ctx.info['GL_VERSION']}"


def is_software() -> bool:
    """True on Mesa's CPU drivers (llvmpipe, softpipe), where GPU timer queries measure nothing useful."""
    name = context().info["GL_RENDERER"].lower()
    return "llvmpipe" in name or "softpipe" in name


_LOG_LINE = re.compile(r"(?:^|\s)\d+[:(](\d+)\)?\s*[:(]")


def compile_compute(source: str, name: str) -> moderngl.ComputeShader:
    """A moderngl ComputeShader of ``source``, or a ShaderError with the log and the offending line(s)."""
    import moderngl

    ctx = context()
    try:
        return ctx.compute_shader(source)
    except moderngl.Error as e:
        log = str(e).strip()
        lines = source.splitlines()
        shown = []
        for m in _LOG_LINE.finditer(log):
            n = int(m.group(1))
            if 1 <= n <= len(lines) and n not in shown:
                shown.append(n)
        where = "".join(f"\n  line {n}: {lines[n - 1].strip()}" for n in shown[:3])
        first = log.splitlines()[-1] if log else "no log"
        raise ShaderError(f"the {name} compute shader does not compile: {first}{where}") from None


def time_gpu(fn: Callable[[], object], batches: int = 20, batch: int = 10, warmup_ms: float = 50.0) -> list[float]:
    """ms per call of ``fn`` (which only queues GL work): ``batches`` medians-ready samples, each one
    GL_TIME_ELAPSED query around ``batch`` calls queued back to back (on llvmpipe: wall time around
    glFinish), after ``warmup_ms`` of calls so the GPU is busy and clocked up. Queueing a batch keeps the
    GPU fed: a query around one small call also counts the gaps while Python queues the next command.
    """
    ctx = context()
    gpu = not is_software()
    ctx.finish()
    t0 = time.perf_counter()
    while (time.perf_counter() - t0) * 1e3 < warmup_ms:
        fn()
        ctx.finish()
    samples: list[Any] = []  # GL_TIME_ELAPSED queries on a GPU, ms per call on llvmpipe
    for _ in range(batches):
        if gpu:
            q = ctx.query(time=True)
            with q:
                for _ in range(batch):
                    fn()
            samples.append(q)
        else:
            ctx.finish()
            t = time.perf_counter()
            for _ in range(batch):
                fn()
            ctx.finish()
            samples.append((time.perf_counter() - t) * 1e3 / batch)
    return checked_times([q.elapsed / 1e6 / batch for q in samples] if gpu else samples)


def checked_times(ms: list[float]) -> list[float]:
    """``ms`` if every figure is finite and non-negative, else a BackendError saying the GPU timer failed
    (a driver whose GL_TIME_ELAPSED query returns nothing usable), instead of a silently wrong timing."""
    import math

    bad = [v for v in ms if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0)]
    if bad:
        raise BackendError(f"the GL timer returned {len(bad)} unusable figure(s) (e.g. {bad[0]!r} ms): this driver's "
                           "GL_TIME_ELAPSED queries cannot time the passes; time them on another device")
    return [float(v) for v in ms]
