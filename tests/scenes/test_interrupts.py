"""A Mitsuba render that SIGINT wound down is an interruption, never an image (issue 34, part 4).

Mitsuba installs its own SIGINT handler around every render (whatever SIGINT's disposition was); on a signal it
cancels the render, re-raises the signal to the handler before its own, and the render returns the samples it has
as if it had finished. The signal here comes from inside the render itself, when Mitsuba logs "Starting render
job" (after its stop flag is cleared and its handler installed), so it is sent while the render runs on any
machine, at any load. Linux delivers a signal sent to the process to its main thread, which runs the handler
when it is next scheduled: a render shorter than that wait (a 64 x 48 G-buffer at 4 spp renders in 2 ms) ended
before the handler ran once in the full suite at load 4-5 (2026-12-06), so the renders hit here are long enough
(about 0.1 s and more) to hold the signal. Waiting inside the appender instead deadlocks: Mitsuba's handler logs
"winding down" under the logger lock the appender holds.
"""

import contextlib
import os
import signal
import threading

import numpy as np
import pytest

from ssskit.compute.workers import ignored_sigint_blocked
from ssskit.scenes import render_gbuffer, render_reference
from ssskit.scenes.mitsuba_variant import RenderInterrupted, _logger, mitsuba

pytestmark = pytest.mark.skipif(os.name != "posix", reason="signals")

ALBEDO = (0.6, 0.4, 0.3)


@contextlib.contextmanager
def sigint_inside_renders(times=1, skip=0):
    """Within the block, SIGINT is sent to this process from inside the ``times`` Mitsuba renders (``None``: every
    one) that follow the first ``skip``; yields the list of the renders it hit."""
    mi = mitsuba()
    hits, started = [], []

    class Hook(mi.Appender):
        def append(self, level, text):
            if "Starting render job" not in text:
                return
            started.append(text)
            if len(started) > skip and (times is None or len(hits) < times):
                hits.append(text)
                os.kill(os.getpid(), signal.SIGINT)

        def log_progress(self, *args):
            pass

    logger = _logger(mi)
    hook, level = Hook(), logger.log_level()
    logger.add_appender(hook)
    logger.set_log_level(mi.LogLevel.Info)  # "Starting render job" is an Info line
    try:
        yield hits
    finally:
        logger.set_log_level(level)
        logger.remove_appender(hook)


@contextlib.contextmanager
def sigint_handled_by(handler):
    before = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


def _gbuffer():
    return render_gbuffer("slab", ALBEDO, width=128, height=96, spp=64, seed=1)  # (a render long enough: above)


def test_a_wound_down_gbuffer_render_is_an_interruption():
    """SIGINT to a process whose handler only notes it (so nothing else raises): Mitsuba's handler cancelled the
    G-buffer render, which returned a partial image as a result; now RenderInterrupted (a KeyboardInterrupt)."""
    noted = []
    with sigint_handled_by(lambda *a: noted.append(a)), sigint_inside_renders() as hits:
        with pytest.raises(RenderInterrupted):
            _gbuffer()
    assert len(hits) == 1 and noted  # the signal came inside the render and reached the handler before Mitsuba's


@pytest.mark.skip(reason="segfaulted once in the full suite (2026-12-06): the signal sent from inside Mitsuba's log "
                         "appender on a thread that is not the main one runs Mitsuba's handler nested in that appender, "
                         "and its own log line re-enters it; sending it from another thread instead deadlocks on Mitsuba's "
                         "logger lock. The product's renders off the main thread (demo workers) run with SIGINT blocked.")
def test_a_wound_down_render_on_another_thread_is_an_interruption():
    """The same from a thread that is not the main one (``mi.render`` called directly there)."""
    noted, raised = [], []

    def work():
        try:
            _gbuffer()
        except BaseException as exc:  # noqa: BLE001
            raised.append(exc)

    with sigint_handled_by(lambda *a: noted.append(a)), sigint_inside_renders() as hits:
        t = threading.Thread(target=work)
        t.start()
        t.join()
    assert len(hits) == 1 and [type(e) for e in raised] == [RenderInterrupted]


def test_a_wound_down_reference_is_neither_a_result_nor_cached(tmp_path, monkeypatch):
    """A path-traced reference whose second chunk was wound down (after the render of its mask and a first
    chunk): an interruption, and its cache stays empty (a partial chunk was averaged in and the reference cached)."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    from ssskit.materials import get_material

    noted = []
    with sigint_handled_by(lambda *a: noted.append(a)), sigint_inside_renders(skip=2) as hits:
        with pytest.raises(RenderInterrupted):
            render_reference("slab", get_material("skin1"), width=64, height=48, spp=384, chunk_spp=128,
                             progress=False)
    assert len(hits) == 1 and noted
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]


def test_an_ignored_sigint_leaves_the_render_whole():
    """SIGINT ignored (a script's background job) but arriving inside a render: Mitsuba's handler still winds it
    down and drops the signal, and ssskit renders it again: the G-buffer an uninterrupted render gives."""
    clean = _gbuffer()
    with sigint_handled_by(signal.SIG_IGN), sigint_inside_renders(times=2) as hits:
        hit = _gbuffer()
    assert len(hits) == 2  # the first render and its rerun were both hit; the third was left alone
    for name in ("diffuse", "depth", "normal", "mask"):
        np.testing.assert_allclose(getattr(hit, name), getattr(clean, name), rtol=1e-6, atol=1e-7, err_msg=name)


def test_an_ignored_sigint_blocked_never_reaches_mitsuba(capfd):
    """With an ignored SIGINT blocked, as the CLI does for its whole run (``ignored_sigint_blocked``), Mitsuba's
    handler never runs: no "winding down", no rerun, the render as an uninterrupted one, from a thread started
    inside the block (the way the render's helper thread and every worker start). A thread started before the
    block could still take the signal: blocking is for the start of a process, before any thread."""
    clean = _gbuffer()
    out = []
    with sigint_handled_by(signal.SIG_IGN), ignored_sigint_blocked():
        t = threading.Thread(target=lambda: out.append(_blocked_render()))
        t.start()
        t.join()
    hit, hits = out[0]
    assert len(hits) == 1 and "winding down" not in capfd.readouterr().err
    np.testing.assert_allclose(hit.diffuse, clean.diffuse, rtol=1e-6, atol=1e-7)


def _blocked_render():
    """In a thread whose SIGINT is blocked, send it from inside its render to that thread alone (``pthread_kill``:
    the other threads of a test process, started before any block, would take a process-wide one)."""
    mi = mitsuba()
    me = threading.get_ident()
    hits = []

    class Hook(mi.Appender):
        def append(self, level, text):
            if "Starting render job" in text and not hits:
                hits.append(text)
                signal.pthread_kill(me, signal.SIGINT)

        def log_progress(self, *args):
            pass

    logger = _logger(mi)
    hook, level = Hook(), logger.log_level()
    logger.add_appender(hook)
    logger.set_log_level(mi.LogLevel.Info)
    try:
        return _gbuffer(), hits
    finally:
        logger.set_log_level(level)
        logger.remove_appender(hook)
