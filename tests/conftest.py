import numpy as np
import pytest

from ssskit.materials import MATERIALS


@pytest.fixture
def rng():
    return np.random.default_rng(20260101)


MATERIAL_CHANNELS = [(name, c) for name in MATERIALS.names() for c in range(3)]


@pytest.fixture(scope="session")
def skin():
    """Skin1's dipole profile."""
    from ssskit.profiles import profile_for_material

    return profile_for_material("skin1", "dipole")


@pytest.fixture(scope="session")
def taps7(skin):
    """7 importance-sampled taps of Skin1's pre-integrated kernel (separable-SSS paper section 6)."""
    from ssskit.kernels import build_kernel, default_grid
    from ssskit.sampling.taps import make_taps

    cell, n = default_grid(skin)
    return make_taps(build_kernel("preintegrated", skin, cell, n), 7)


# ---- backends ------------------------------------------------------------------------------------
#
# One fixture runs every pass test on every registered backend that is available here (the others
# are skipped with the backend's own reason), and one table holds the tolerance of each backend's
# result against the float64 numpy oracle, keyed by (backend, the dtype it computes in).

#: max |backend - numpy oracle| per (backend, dtype): float32 backends accumulate ~1e-7 per tap
#: relative rounding on values of order 1
TOLERANCES = {("numpy", "float64"): 1e-12, ("numba", "float32"): 2e-5, ("gl", "float32"): 1e-5}


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
