"""An interrupt while a thread pool starts its workers never leaves the process unable to exit (issue 34, part 4).

``ThreadPoolExecutor`` starts a worker on a submit, waits for it to run, then records it for the interpreter's exit;
a KeyboardInterrupt inside that wait left the worker unrecorded and idle for good, and the process's exit waited for
it forever: a Ctrl-C'd ``ssskit render`` hung after its separable pass's first frame (benchmarks/sigint_matrix.py at
load 5, 2026-12-06). Here the signal is sent from inside the worker's start (the moment of the race, not a timing
guess) in a child process that holds its pool as the CLI does; the child must print "interrupted" and exit. The
timeout is a hang guard, never a measure: without :func:`ssskit.compute.workers.submit_all` the child never exits.
"""

import os
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.skipif(os.name != "posix", reason="signals")

CHILD = textwrap.dedent("""
    import os, signal, threading, time
    start = threading.Thread.start
    other = threading.Thread(target=time.sleep, args=(600,), daemon=True)  # a thread of another library's
    other.start()

    def interrupted_start(self):
        start(self)
        if self.name.startswith("ssskit-"):
            {send}

    threading.Thread.start = interrupted_start
    try:
        {call}
    except KeyboardInterrupt:
        print("interrupted", flush=True)
""")

CALLS = {
    "the numba backend's rows": "from ssskit.backends.numba_backend import NumbaBackend\n"
                                "    backend = NumbaBackend()  # held, as the CLI holds its backends\n"
                                "    backend._rows(128, lambda y0, y1: None)",
    "the Monte Carlo engine's pool": "from ssskit.compute.workers import submit_all\n"
                                     "    from ssskit.profiles.montecarlo.engine_numba import _pool\n"
                                     "    [f.result() for f in submit_all(_pool(2), abs, [(-1,), (-2,)])]",
}


#: to the process (Linux picks a thread that does not block it), or to another thread (Python still raises it in
#: the main thread: blocking it there was not enough, the full suite showed once)
SENDS = {"to the process": "os.kill(os.getpid(), signal.SIGINT)",
         "to another thread": "signal.pthread_kill(other.ident, signal.SIGINT)"}


@pytest.mark.parametrize("send", SENDS.values(), ids=list(SENDS))
@pytest.mark.parametrize("call", CALLS.values(), ids=list(CALLS))
def test_an_interrupt_while_a_pool_starts_its_workers_leaves_the_process_free_to_exit(call, send):
    env = {**os.environ, "NUMBA_NUM_THREADS": "2"}
    try:
        out = subprocess.run([sys.executable, "-c", CHILD.format(call=call, send=send)], env=env, capture_output=True,
                             text=True, timeout=120)
    except subprocess.TimeoutExpired:
        pytest.fail("the child did not exit: a pool worker started during the interrupt was left unrecorded")
    assert out.returncode == 0 and out.stdout.strip() == "interrupted", out.stderr[-2000:]
