"""Jobs on a few worker processes, with their progress lines passed back and a clean end.

:func:`run_jobs` runs a list of jobs (a module-level function and its arguments) on ``workers`` spawned
processes (numba's threading layers are not fork-safe), each worker taking, as it finishes one, the first
job in the list's order whose prerequisites have finished. A job says how far it is with :func:`line`; the
parent receives those lines and each job's result as they come. An error in a job is raised in the parent, with the workers ended first;
so are Ctrl-C in the parent (the workers start with SIGINT blocked and ignore it: the parent ends them) and a
worker that dies
(a crash or the kernel's OOM killer), which ``multiprocessing.Pool`` would silently replace and wait for
forever. Used by ``ssskit demo`` to build the report's sections side by side.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from typing import Any

_LINES: Any = None  # in a worker: the queue to the parent

#: the environment variables of the numeric libraries' own thread counts, read once when a library loads: numpy's
#: and scipy's BLAS (OpenBLAS, or MKL) and OpenMP (FLIP's flip-evaluator)
LIBRARY_THREADS = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS")


def one_library_thread() -> dict[str, str]:
    """The environment for one thread in each library of :data:`LIBRARY_THREADS`, keeping a count the user set:
    {variable: value}. ssskit's work in them is small (kernel grids up to ~200 cells, SLSQP's ~100 variables,
    FLIP on 256 x 256 test signals), where their threads cost more than they bring, measured on 2 cores:
    two BLAS threads took the guided kernel (Ketchup, k = 2) 3.4 s of CPU against 1.4 s; two OpenMP threads
    took FLIP 0.17 s per 256 x 256 pair against 0.10 s, wall and CPU (beside one other busy process); one BLAS
    thread halved the demo's kernel ranking's CPU, and one OpenMP thread then took it from 39 s to 27 s. Idle threads of these pools spin, so
    two processes side by side (``ssskit demo``'s workers) lose most. One thread also makes the results
    independent of the machine's core count (two BLAS threads changed the last bit of that kernel). The
    passes, the path tracer and the Monte Carlo engine keep their own threads. The CLI sets this before any
    command imports numpy; it has no effect on a library already loaded."""
    return {name: os.environ.get(name, "1") for name in LIBRARY_THREADS}


def sigint_ignored() -> bool:
    """Whether this process ignores SIGINT: its parent asked for it (a non-interactive shell starts a background
    job, ``cmd &``, with SIGINT ignored, and Python keeps an inherited SIG_IGN), or a worker set it."""
    return signal.getsignal(signal.SIGINT) == signal.SIG_IGN


@contextlib.contextmanager
def sigint_blocked() -> Iterator[None]:
    """Within the block SIGINT is blocked in the calling thread (``pthread_sigmask``), and so in every thread and
    process it starts meanwhile, for their whole life (a thread inherits its creator's mask; a spawned
    process keeps it across ``exec``). A blocked SIGINT is never handled by anyone, a library's handler
    included; it waits, pending, and is dropped when SIGINT's disposition is set to "ignore" (POSIX
    ``sigaction``), or taken by the calling thread when the block ends. Without ``pthread_sigmask``
    (Windows): nothing changes."""
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - POSIX only
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def submit_all(pool: Any, fn: Callable[..., Any], calls: Iterable[tuple[Any, ...]]) -> list[Any]:
    """``pool.submit(fn, *args)`` for each ``args`` of ``calls`` (a ``concurrent.futures`` thread pool held for the
    process's life): the futures, with a Ctrl-C that arrives meanwhile deferred to the end of the submits.
    ``ThreadPoolExecutor`` starts a worker on a submit, waits for it to run, then records it for the interpreter's
    exit; a KeyboardInterrupt inside that wait left the worker unrecorded and idle for good, and the exit waited
    for it forever (a Ctrl-C'd ``ssskit render`` at load 5, benchmarks/sigint_matrix.py, 2026-12-06). Blocking
    the signal in this thread is not enough: another thread (numba's, Mitsuba's) takes it and Python still raises
    it here. So in the main thread (the only one a KeyboardInterrupt is raised in) a Python handler that only
    notes SIGINT stands in for the submits, and a noted signal is raised again to the caller's handler after them;
    where the handler is not Python's (a library's), the submits run with SIGINT blocked, as before."""
    before = signal.getsignal(signal.SIGINT) if threading.current_thread() is threading.main_thread() else None
    if before is None:
        with sigint_blocked():
            return [pool.submit(fn, *args) for args in calls]
    noted: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: noted.append(signum))
    try:
        return [pool.submit(fn, *args) for args in calls]
    finally:
        signal.signal(signal.SIGINT, before)
        if noted:
            signal.raise_signal(signal.SIGINT)


@contextlib.contextmanager
def ignored_sigint_blocked() -> Iterator[None]:
    """Within the block, if this process ignores SIGINT (:func:`sigint_ignored`) and the caller is the main
    thread: SIGINT blocked (:func:`sigint_blocked`), so that it stays ignored by every part of the process.
    Mitsuba replaces SIGINT's handler during each render whatever the disposition was (its handler cancels
    the render, then re-raises the signal to the handler before it: to SIG_IGN, nowhere) and wound renders
    down that were meant to ignore it; blocked, the signal never reaches that handler, and Mitsuba's own
    restoring of SIG_IGN at the render's end drops it. For the CLI's whole run, entered before any thread
    starts. Otherwise nothing changes."""
    if not sigint_ignored() or threading.current_thread() is not threading.main_thread():
        yield
        return
    with sigint_blocked():
        yield


#: seconds between the parent's checks that its workers still live
POLL_S = 0.2


def line(message: str) -> None:
    """A progress line from inside a job, printed by the parent (in the parent itself: nothing)."""
    if _LINES is not None:
        _LINES.put(("line", None, message))


def _worker(tasks: Any, results: Any, env: dict[str, str]) -> None:
    global _LINES
    # Ctrl-C (SIGINT to the terminal's whole process group) is the parent's to handle: it ends the workers. The
    # worker was started with SIGINT blocked (run_jobs), so neither Python nor Mitsuba's handler, which it
    # installs during each render whatever the disposition, ever sees one; ignored too, should it be unblocked.
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ.update(env)
    _LINES = results
    while True:
        task = tasks.get()
        if task is None:
            return
        index, fn, args = task
        try:
            value = ("done", index, fn(*args))
        except BaseException as exc:  # noqa: BLE001 - passed to the parent, which raises it
            value = ("error", index, exc)
        try:
            results.put(value)
        except Exception as exc:  # noqa: BLE001 - an unpicklable result or error: say what it was
            results.put(("error", index, RuntimeError(f"job {index}: {value[2]!r} ({exc})")))


def run_jobs(jobs: Sequence[tuple[Callable[..., Any], tuple[Any, ...]]], workers: int,
             on_line: Callable[[str], None], on_result: Callable[[int, Any], None],
             env: dict[str, str] | None = None, after: Mapping[int, Collection[int]] | None = None) -> None:
    """Run ``jobs`` (function, arguments) on ``workers`` processes; the functions must be importable by name
    (module level). A worker that is free takes the first job in the list whose prerequisites are done:
    ``after`` maps a job's index to the indices of the jobs that must finish before it starts (e.g. the
    compilation of the kernels it runs, so that no two workers compile the same kernel). ``on_line`` gets
    every :func:`line` of a job, ``on_result(index, value)`` each job's return value as it finishes (in the
    parent). ``env``: set in each worker's environment. The first job error is raised here once every
    worker has ended."""
    import multiprocessing as mp
    import queue

    needs = {k: set(after.get(k, ())) if after else set() for k in range(len(jobs))}
    order: set[int] = set()
    while len(order) < len(jobs):  # every job can start once the ones before it in some order have finished
        ready = {k for k, ds in needs.items() if k not in order and ds <= order}
        if not ready:
            raise ValueError(f"jobs {sorted(set(needs) - order)} wait for each other or for jobs not in the list")
        order |= ready
    context = mp.get_context("spawn")
    tasks, results = context.Queue(), context.Queue()
    n = max(1, min(int(workers), len(jobs)))
    procs = [context.Process(target=_worker, args=(tasks, results, dict(env or {})), daemon=True,
                             name=f"ssskit-worker-{i}") for i in range(n)]
    waiting, idle, ended = list(range(len(jobs))), n, False
    finished: set[int] = set()

    def dispatch() -> None:
        nonlocal idle, ended
        while idle and waiting:
            ready = next((k for k in waiting if needs[k] <= finished), None)
            if ready is None:  # (a job that runs now is a prerequisite: the check above)
                return
            waiting.remove(ready)
            tasks.put((ready, *jobs[ready]))
            idle -= 1
        if not waiting and not ended:  # every job handed out: each worker's end, sent once
            for _ in range(n):
                tasks.put(None)
            ended = True

    try:
        with sigint_blocked():  # each worker process starts with SIGINT blocked (see _worker)
            for p in procs:
                p.start()
        dispatch()
        while len(finished) < len(jobs):
            try:
                kind, index, value = results.get(timeout=POLL_S)
            except queue.Empty:
                # a worker ends with 0 only after the last job was taken; another exit is a crash or a kill
                dead = [p.exitcode for p in procs if p.exitcode not in (None, 0)]
                if dead or all(p.exitcode == 0 for p in procs):
                    raise RuntimeError(f"a worker process ended unexpectedly (exit code {(dead or [0])[0]}) with "
                                       f"{len(jobs) - len(finished)} job(s) unfinished")
                continue
            if kind == "line":
                on_line(value)
            elif kind == "error":
                raise value
            else:
                finished.add(index)
                idle += 1
                on_result(index, value)
                dispatch()
        for p in procs:
            p.join()
    except BaseException:
        # the workers are ended: the tasks they will never read must not keep this process from exiting (a
        # queue's feeder thread is joined at exit and would wait for room in a pipe nobody reads)
        tasks.cancel_join_thread()
        raise
    finally:
        for p in procs:
            if p.is_alive():
                p.terminate()
        for p in procs:
            if p.pid is not None:
                p.join()
        tasks.close()
        results.close()


__all__ = ["LIBRARY_THREADS", "POLL_S", "ignored_sigint_blocked", "line", "one_library_thread", "run_jobs", "submit_all",
           "sigint_blocked", "sigint_ignored"]
