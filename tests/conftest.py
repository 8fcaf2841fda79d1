import numpy as np
import pytest

from ssskit.materials import MATERIALS


@pytest.fixture
def rng():
    return np.random.default_rng(20260101)


MATERIAL_CHANNELS = [(name, c) for name in MATERIALS.names() for c in range(3)]


# ---- backends ------------------------------------------------------------------------------------
#
# One fixture runs every pass test on every registered backend that is available here (the others
# are skipped with the backend's own reason), and one table holds the tolerance of each backend's
# result against the float64 numpy oracle, keyed by (backend, the dtype it computes in).

#: max |backend - numpy oracle| per (backend, dtype): float32 backends accumulate ~1e-7 per tap
#: relative rounding on values of order 1
TOLERANCES = {("numpy", "float64"): 1e-12, ("numba", "float32"): 2e-5}


def _backend_params():
    from ssskit.backends import BACKENDS

    return BACKENDS.names()


@pytest.fixture(params=_backend_params())
def backend(request):
    """The name of an available backend (unavailable ones are skipped, saying why)."""
    from ssskit.backends import backend_status

    status = backend_status()[request.param]
    if not status["available"]:
        pytest.skip(f"backend {request.param} not available: {status['details']}")
    return request.param


def tolerance(backend: str) -> float:
    """Max absolute deviation of ``backend`` from the numpy oracle (see TOLERANCES)."""
    from ssskit.backends import get_backend

    return TOLERANCES[(backend, np.dtype(get_backend(backend).dtype).name)]
