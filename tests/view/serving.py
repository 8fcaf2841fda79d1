"""The viewer's server run in the test's process on a free port (the code `ssskit view` serves with)."""
from __future__ import annotations

import io
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def running(data: dict[str, Any], references: Any = None,
            given: dict[str, str] | None = None) -> Iterator[tuple[Any, io.StringIO]]:
    """(the :class:`~ssskit.view.server.ViewServer` serving ``data``, its log of refusals); shut down on exit."""
    from ssskit.view.server import ViewServer

    log = io.StringIO()
    srv = ViewServer(data, 0, log, references=references, given=given)
    threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True).start()
    try:
        yield srv, log
    finally:
        srv.shutdown()
        srv.server_close()
