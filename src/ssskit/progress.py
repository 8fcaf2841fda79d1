"""Progress from anywhere in the library: :func:`reporting` blocks that route :func:`report` messages to the
CLI's stderr lines, plain-line progress bars for logs, and the :func:`heartbeat` that says what is still
running when nothing was reported for a while.

It imports neither numpy nor the rest of the package, so the CLI's entry point can set it up before it
knows which command runs (``ssskit --help`` stays fast)."""

from __future__ import annotations

import contextlib
import contextvars
import os
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any, Protocol


class ProgressBar(Protocol):
    """What :func:`progress_bar` returns (a tqdm bar, or plain lines for a log): the calls ssskit makes."""

    def update(self, n: int = 1, /) -> object: ...

    def set_postfix_str(self, s: str, /) -> None: ...

    def close(self) -> None: ...


class _LineProgress:
    """A tqdm-like progress report for a stderr that is no terminal (a log file, CI): one plain line
    at each tenth of the total, at least every :data:`LINE_INTERVAL_S` seconds while work is done, and
    at the end, instead of carriage-return redraws."""

    def __init__(self, total: int, desc: str, unit: str, initial: int = 0) -> None:
        self.total, self.desc, self.unit, self.n = max(int(total), 1), desc, unit, int(initial)
        self.initial = int(initial)
        self.postfix, self._next = "", self._step(self.n)
        self._t0 = self._last = time.perf_counter()

    def _step(self, n: int) -> int:
        tenth = max(self.total // 10, 1)
        return (n // tenth + 1) * tenth

    def update(self, k: int = 1) -> None:
        self.n += int(k)
        now = time.perf_counter()
        if self.n >= self._next or self.n >= self.total or now - self._last >= LINE_INTERVAL_S:
            self._next = self._step(self.n)
            self._last = now
            self._say()

    def set_postfix_str(self, text: str) -> None:
        self.postfix = text

    def _say(self) -> None:
        extra = f", {self.postfix}" if self.postfix else ""
        elapsed = time.perf_counter() - self._t0
        done = self.n - self.initial
        left = ""
        if done > 0 and self.n < self.total and elapsed >= ETA_AFTER_S:  # the rate so far, carried to the end
            left = f", about {duration_text(elapsed * (self.total - self.n) / done)} left"
        line = f"{self.desc}: {self.n:,}/{self.total:,} {self.unit}{extra} ({elapsed:.0f} s{left})"
        print(f"  {line}", file=sys.stderr, flush=True)
        noted(line)

    def close(self) -> None:
        pass


#: the longest a plain-line progress report stays silent while its work advances (seconds)
LINE_INTERVAL_S = 5.0
#: a plain line estimates the time left once its work has run this long (seconds; before, the rate is noise)
ETA_AFTER_S = 2.0


def duration_text(seconds: float) -> str:
    """A duration for people: "40 s", "12 min", "3.5 h"."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 90 * 60:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


# ---- progress -------------------------------------------------------------------------------------

_REPORTER: contextvars.ContextVar[Callable[[str], None] | None] = contextvars.ContextVar("ssskit_reporter", default=None)


@contextlib.contextmanager
def reporting(fn: Callable[[str], None] | None) -> Iterator[None]:
    """Within the block, :func:`report` passes progress messages to ``fn`` (the CLI's stderr lines): long
    computations deep in the library (an optimisation, a Monte Carlo run) say how far they are without a
    callback through every call in between. ``None`` silences them."""
    token = _REPORTER.set(fn)
    try:
        yield
    finally:
        _REPORTER.reset(token)


def reporting_active() -> bool:
    """Whether a :func:`reporting` block with a reporter encloses the caller."""
    return _REPORTER.get() is not None


def report(message: str) -> None:
    """A progress message for the enclosing :func:`reporting` block (nothing outside one)."""
    fn = _REPORTER.get()
    if fn is not None:
        fn(message)


class Ticker:
    """:func:`report` at most every ``interval_s`` seconds, the first after ``interval_s``: for progress
    from inner loops, e.g. each step of an optimisation (a quick loop says nothing)."""

    def __init__(self, interval_s: float = 2.0) -> None:
        self.interval_s = interval_s
        self._last = time.perf_counter()

    def __call__(self, message: str | Callable[[], str]) -> None:
        now = time.perf_counter()
        if now - self._last >= self.interval_s and reporting_active():
            self._last = now
            report(message() if callable(message) else message)


def plain_progress() -> bool:
    """Whether progress is written as plain lines: stderr is no terminal, or ``SSSKIT_PROGRESS=lines``
    (set in worker processes, whose redrawn bars would garble a shared terminal)."""
    return os.environ.get("SSSKIT_PROGRESS", "").strip().lower() == "lines" or not sys.stderr.isatty()


def say(message: str) -> None:
    """One progress line on stderr (stdout carries only results)."""
    print(f"  {message}", file=sys.stderr, flush=True)
    noted(message)


#: when the last progress line was written, and what it said (for :func:`heartbeat`)
_LAST: dict[str, Any] = {"t": time.perf_counter(), "msg": ""}


def noted(message: str) -> None:
    """Record that a progress line was just written (every writer of progress lines calls it)."""
    _LAST["t"], _LAST["msg"] = time.perf_counter(), message.strip()


@contextlib.contextmanager
def heartbeat(interval_s: float = 8.0) -> Iterator[None]:
    """While the block runs, and progress goes out as plain lines (:func:`plain_progress`), a line on
    stderr whenever no progress line came for ``interval_s`` seconds: what ran last and for how long (a
    compilation, a solver or a render step that reports nothing itself). Nothing on a terminal, whose bars
    show their own time."""
    import threading

    if not plain_progress():
        yield
        return
    stop = threading.Event()

    def beat() -> None:
        said = 0.0
        while not stop.wait(0.5):
            now = time.perf_counter()
            if not _LAST.get("idle") and now - max(_LAST["t"], said) >= interval_s:
                last = f": {_LAST['msg'][:90]}" if _LAST["msg"] else ""
                print(f"  ... still working, {now - _LAST['t']:.0f} s since the last step{last}", file=sys.stderr,
                      flush=True)
                said = now

    _LAST["t"] = time.perf_counter()
    thread = threading.Thread(target=beat, name="ssskit-heartbeat", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


def add_to_total(bar: ProgressBar, n: int) -> None:
    """Grow (or, n < 0, shrink) the work a bar expects: a bar shared by several runs (the channels of one
    simulation) counts only the work still to do, so its estimate of the time left covers all of them."""
    setattr(bar, "total", (getattr(bar, "total", 0) or 0) + int(n))


@contextlib.contextmanager
def idle() -> Iterator[None]:
    """While the block runs the process waits on someone else (a server for its requests), not on work: the
    heartbeat says nothing."""
    _LAST["idle"] = True
    try:
        yield
    finally:
        _LAST["idle"] = False
        _LAST["t"] = time.perf_counter()


def progress_bar(total: int, desc: str, unit: str = "it", enabled: bool = True, initial: int = 0,
                 **tqdm_kw: Any) -> ProgressBar:
    """A progress bar on stderr: tqdm on a terminal, plain lines otherwise (:func:`plain_progress`: at
    each tenth and at least every :data:`LINE_INTERVAL_S` seconds, readable in logs), nothing when not
    ``enabled``. Supports update, set_postfix_str and close."""
    if not enabled:
        from tqdm import tqdm

        return tqdm(total=total, disable=True)
    if plain_progress():
        return _LineProgress(total, desc, unit, initial)
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, initial=initial, **tqdm_kw)
