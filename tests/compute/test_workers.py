"""ssskit.compute.workers: jobs on spawned processes, their lines and results back in the parent, an error or a
dead worker raised in the parent once every worker has ended (multiprocessing.Pool replaces a dead worker
and waits for its job forever)."""

import math
import os

import pytest

from ssskit.compute.workers import line, run_jobs


def test_results_and_lines_come_back():
    lines, results = [], {}
    run_jobs([(line, ("first",)), (math.sqrt, (16.0,)), (line, ("second",))], 2, lines.append, results.__setitem__)
    assert results == {0: None, 1: 4.0, 2: None} and sorted(lines) == ["first", "second"]
    line("in the parent: nothing")  # no queue here


def test_a_jobs_error_is_raised_in_the_parent():
    with pytest.raises(ValueError, match="math domain error"):
        run_jobs([(math.sqrt, (-1.0,))], 1, print, lambda k, v: None)


def test_a_worker_that_dies_is_an_error_not_a_hang():
    with pytest.raises(RuntimeError, match=r"a worker process ended unexpectedly \(exit code 3\) with 1 job"):
        run_jobs([(os._exit, (3,))], 1, print, lambda k, v: None)


def test_the_workers_have_ended_when_the_error_is_raised():
    """The report's staging folder is removed as the error passes: no worker may still be writing into it."""
    import multiprocessing
    import time

    with pytest.raises(ValueError, match="math domain error"):
        run_jobs([(time.sleep, (30.0,)), (math.sqrt, (-1.0,))], 2, print, lambda k, v: None)
    assert multiprocessing.active_children() == []


def test_the_workers_environment():
    """``env`` is set in each worker before any job's imports (the demo's one BLAS thread per worker)."""
    results = {}
    run_jobs([(os.getenv, ("SSSKIT_TEST_WORKER_ENV",))], 1, print, results.__setitem__,
             env={"SSSKIT_TEST_WORKER_ENV": "set"})
    assert results == {0: "set"} and "SSSKIT_TEST_WORKER_ENV" not in os.environ


def test_a_job_starts_after_its_prerequisites():
    """Job 1 (instant) waits for job 0 (half a second) on another free worker: its result comes second; a job
    list whose jobs wait for each other is refused before any starts."""
    import time

    finished = []
    run_jobs([(time.sleep, (0.5,)), (math.sqrt, (4.0,)), (math.sqrt, (9.0,))], 2, print,
             lambda k, v: finished.append(k), after={1: [0]})
    assert finished.index(0) < finished.index(1) and finished[0] == 2
    with pytest.raises(ValueError, match=r"jobs \[0, 1\] wait for each other"):
        run_jobs([(math.sqrt, (1.0,)), (math.sqrt, (1.0,))], 2, print, lambda k, v: None, after={0: [1], 1: [0]})
    with pytest.raises(ValueError, match=r"jobs \[0\] wait for each other or for jobs not in the list"):
        run_jobs([(math.sqrt, (1.0,))], 1, print, lambda k, v: None, after={0: [5]})


def _sigint_state():
    import signal

    return signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, []), signal.getsignal(signal.SIGINT)


@pytest.mark.skipif(not hasattr(__import__("signal"), "pthread_sigmask"), reason="POSIX signal masks")
def test_a_worker_never_takes_sigint_and_the_parent_still_does():
    """A terminal's Ctrl-C reaches the workers too (the whole process group): a worker runs with SIGINT blocked
    (so neither Python nor Mitsuba's own handler, which Mitsuba installs during each render whatever the
    disposition, ever sees it) and ignored; the parent ends the workers. The parent's mask is as before."""
    import signal

    before = _sigint_state()
    results = {}
    run_jobs([(_sigint_state, ())], 1, print, results.__setitem__)
    assert results == {0: (True, signal.SIG_IGN)}
    assert _sigint_state() == before and not before[0]
