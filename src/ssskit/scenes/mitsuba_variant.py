"""Mitsuba 3, imported when a scene is first rendered (never at ``import ssskit``), with the ``scalar_rgb``
variant every scene and reference of ssskit renders in (CPU, any machine), and its log on stderr (stdout
carries only a command's result: ``--json`` is one JSON object)."""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Iterator
from types import ModuleType
from typing import Any

from ..errors import SceneError


def mitsuba() -> ModuleType:
    """The ``mitsuba`` module with the ``scalar_rgb`` variant set and its log on stderr
    (:func:`_log_to_stderr`; mitsuba is a core dependency)."""
    import mitsuba as mi

    if mi.variant() != "scalar_rgb":
        mi.set_variant("scalar_rgb")
    _log_to_stderr(mi)
    return mi


def load_scene(d: dict) -> Any:
    """Mitsuba's scene of the dict ``d`` (:func:`mitsuba`), or a SceneError with Mitsuba's own text: every
    scene ssskit builds is loaded here."""
    try:
        return mitsuba().load_dict(d)
    except Exception as exc:  # noqa: BLE001 - Mitsuba raises RuntimeError with its own text
        raise SceneError(f"Mitsuba could not build the scene: {exc}") from None


_STDERR_APPENDER: list[object] = []  # the appender installed, kept alive with its Python object


def _logger(mi: ModuleType) -> Any:
    """Mitsuba's logger, one for the whole process (``mi.logger()``; older releases: the thread's)."""
    return mi.logger() if hasattr(mi, "logger") else mi.Thread.thread().logger()


def _log_to_stderr(mi: ModuleType) -> None:
    """Mitsuba's log (its warnings: a mesh's invalid normals, a non-uniform scale, an invalid sample value) on
    ``sys.stderr`` instead of its default appender's stdout, once per process. Mitsuba's logger is one for
    the whole process (``mi.logger()``; the threads it renders on log through it), so replacing its
    appenders covers them; a worker process (spawned) installs its own when it first calls :func:`mitsuba`.
    Progress messages are dropped: ssskit reports its own progress."""
    if _STDERR_APPENDER:
        return

    class StderrAppender(mi.Appender):  # type: ignore[name-defined]
        def append(self, level: object, text: str) -> None:
            try:
                sys.stderr.write(text if text.endswith("\n") else text + "\n")
                sys.stderr.flush()
            except (OSError, ValueError):  # a closed stderr: the message is lost, the render goes on
                pass

        def log_progress(self, progress: float, name: str, formatted: str, eta: str, ptr: object = None) -> None:
            pass

    logger = _logger(mi)
    appender = StderrAppender()
    logger.clear_appenders()
    logger.add_appender(appender)
    _STDERR_APPENDER.append(appender)


@contextlib.contextmanager
def warnings_dropped() -> Iterator[None]:
    """Within the block Mitsuba logs errors only: for reading a mesh file, whose problems ssskit's own checks
    report as one ``ssskit: error: ...`` line (a zero-area face's "invalid vertex normals" warning came first)."""
    mi = mitsuba()
    logger = _logger(mi)
    before = logger.log_level()
    logger.set_log_level(mi.LogLevel.Error)
    try:
        yield
    finally:
        logger.set_log_level(before)


class RenderInterrupted(KeyboardInterrupt):
    """A Mitsuba render cancelled before its end: an interruption, never an image. Mitsuba's own SIGINT
    handler (installed around every ``Integrator.render`` on Linux and macOS, whatever SIGINT's disposition
    was: ``ScopedSignalHandler`` in ``src/render/python/integrator_v.cpp``) cancels the integrator, logs
    "Received interrupt signal, winding down..", re-raises the signal to the handler before it, and the render
    returns the samples it has as if it had finished. A KeyboardInterrupt, so every caller's clean-up runs
    and nothing (a file, a cache entry, a metric) is made of the partial image."""


def interruptible_render(scene: Any, **kwargs: Any) -> Any:
    """``mi.render(scene, **kwargs)``, the one way ssskit calls Mitsuba's renderer, so that SIGINT means the same
    to both (:class:`RenderInterrupted`):

    * a render Mitsuba wound down (its integrator's ``should_stop()`` after the render) is a
      :class:`RenderInterrupted`, never an image;
    * while SIGINT is ignored (inherited as ignored: a non-interactive shell's background job), Mitsuba's
      handler still winds the render down and drops the signal; the render then runs again with the same
      seed, so the image is the one an uninterrupted render gives. (The CLI blocks an ignored SIGINT in every
      thread, :func:`ssskit.compute.workers.ignored_sigint_blocked`, so Mitsuba's handler never runs there: it
      logs from inside the signal handler, and a flood of signals, one every 0.1 s, left every thread of a
      background ``ssskit render`` waiting inside it, for good.)
    * Ctrl-C or SIGTERM (handled as Ctrl-C by the CLI) stops it within a fraction of a second: in the main
      thread the render runs on a helper thread (Mitsuba releases the GIL) that the main thread waits for in
      short waits, so Python's signal handler runs; on the interrupt the scene's integrator is cancelled
      (``Integrator.cancel``: its render ended 0.04 s later on a 1024x1024 image, 0.004 s at 4096 spp) and the
      KeyboardInterrupt goes on. A direct call from the main thread ran to the end of the render first (minutes
      on a large image). Elsewhere (a worker thread): ``mi.render`` itself, then the same checks."""
    from ..compute.workers import sigint_ignored

    mi = mitsuba()
    integrator = kwargs.get("integrator") or scene.integrator()
    while True:
        image = _render_once(mi, scene, integrator, kwargs)
        if integrator is None or not integrator.should_stop():
            return image
        if not sigint_ignored():
            raise RenderInterrupted("Mitsuba's render was cancelled: its partial image is no result")


def _render_once(mi: ModuleType, scene: Any, integrator: Any, kwargs: dict[str, Any]) -> Any:
    """One ``mi.render`` call, on a helper thread that the main thread waits for (:func:`interruptible_render`)."""
    if threading.current_thread() is not threading.main_thread():
        return mi.render(scene, **kwargs)
    out: list[Any] = []
    failed: list[BaseException] = []
    done = threading.Event()  # not Thread.join: an interrupted join can report the thread ended (CPython 3.11)

    def work() -> None:
        try:
            out.append(mi.render(scene, **kwargs))
        except BaseException as exc:  # noqa: BLE001 - handed to the main thread
            failed.append(exc)
        finally:
            done.set()

    try:  # the start too: Thread.start waits for the thread, and a signal can interrupt that wait
        threading.Thread(target=work, name="ssskit-mitsuba-render", daemon=True).start()
        while not done.wait(_WAIT_S):
            pass
    except BaseException:
        # cancel until the render has ended: Mitsuba's render clears its stop flag when it starts, so a cancel
        # that came before the thread entered it is lost (a process that exits with the render alive can crash)
        deadline = _CANCEL_WAIT_S / _WAIT_S
        while integrator is not None and not done.wait(_WAIT_S) and deadline > 0:
            integrator.cancel()
            deadline -= 1
        raise
    if failed:
        raise failed[0]
    return out[0]


_WAIT_S = 0.05  # the main thread's wait between checks for a signal
_CANCEL_WAIT_S = 5.0  # the most a cancelled render is waited for before the interrupt goes on


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


_BESIDE: list[threading.Thread] = []  # the threads leaving_a_core_to was given, innermost last


@contextlib.contextmanager
def leaving_a_core_to(thread: threading.Thread | None) -> Iterator[None]:
    """Within the block each Mitsuba render (:func:`render_threads`) that starts while ``thread`` is alive runs
    on one thread less than Mitsuba's pool has (at least 1); one that starts after it ended, on all of them.
    For a thread compiling a pass's kernels while Mitsuba renders the G-buffer (one core, the longer of the two
    on a fresh machine): on 2 cores a first ``ssskit render`` took 10.5 s instead of 11.5 (medians of 4,
    benchmarks/RESULTS.md). None: nothing changes."""
    if thread is None:
        yield
        return
    _BESIDE.append(thread)
    try:
        yield
    finally:
        _BESIDE.remove(thread)


@contextlib.contextmanager
def render_threads() -> Iterator[None]:
    """Around one Mitsuba render: one thread less while a thread given to :func:`leaving_a_core_to` is alive,
    else nothing changes."""
    if not any(t.is_alive() for t in _BESIDE):
        yield
        return
    import drjit as dr

    mitsuba()
    with mitsuba_threads(dr.thread_count() - 1):
        yield


__all__ = ["RenderInterrupted", "interruptible_render", "leaving_a_core_to", "mitsuba", "mitsuba_threads",
           "render_threads", "warnings_dropped"]
