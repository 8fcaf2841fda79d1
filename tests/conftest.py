import numpy as np
import pytest

from ssskit.materials import MATERIALS


#: how ssskit.progress.heartbeat's lines begin: progress, which a machine loaded enough to keep a command silent
#: for 8 s adds to stderr before its one error line (the one-line rule is about the error, not about progress)
HEARTBEAT_PREFIX = "  ... still working, "


def without_heartbeats(stderr: str) -> str:
    """``stderr`` less the heartbeat's progress lines, so a test of the one error line holds at any load."""
    return "".join(line for line in stderr.splitlines(keepends=True) if not line.startswith(HEARTBEAT_PREFIX))


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


#: max distance in float32 ulps between a CPU backend's float32 adaptive history and the numpy oracle's
#: (ssskit.backends.adaptive_plan step 2: the same float32 operations in the same order). They agree bit
#: for bit on one CPU only while both call the same maths: numba's LLVM may contract a*b + c into one FMA
#: and links its own vector maths (SVML on AVX-512 CPUs) for pow, which the gamma-corrected luminance
#: S = Y^(1/gamma) calls, while numpy uses glibc's; both are accurate to about 1 ulp, not the same ulp.
#: Eqs. 8 and 6 carry that ulp of S into n_bar and mu, so those are bounded in their own ulps. Eq. 9's
#: sigma^2 = (1 - a)(a d^2 + sigma^2) squares d = S - mu, a difference that cancels: an ulp of S is many
#: ulps of a small sigma^2, but moves sigma = sqrt(sigma^2) by about a * ulp(S) (d sigma ~ a dS for
#: sigma ~ |d|), so sigma is bounded in ulps of mu, the luminance's own scale (seen on an AVX-512 EPYC:
#: 58 of 1728 mu 1 ulp apart, sigma at most 1.25 ulps of mu apart, i.e. 88 ulps of sigma^2). The bound
#: leaves room for that to add up over a few frames. Bit identity across thread counts on one machine is
#: asserted exactly elsewhere, never across CPUs or backends.
ULPS = {("numpy", "float64"): 0, ("numba", "float32"): 4}


def ulp_distance(a, b) -> np.ndarray:
    """Elementwise distance between two float32 arrays in float32 ulps, counted on the ordered integer
    line of float32 values (exact across binades; NaNs must not occur)."""
    def ordered(x):
        i = np.asarray(x, np.float32).view(np.int32).astype(np.int64)
        return np.where(i < 0, -(i & 0x7FFFFFFF), i)

    return np.abs(ordered(a) - ordered(b))


def assert_history_ulps(actual, desired, backend: str, where=None) -> None:
    """An (H, W, 4) adaptive history within ULPS of the oracle's (see there): n_bar and mu in their own
    float32 ulps, sigma = sqrt(channel 2) in float32 ulps of mu, the availability flag exactly; only
    where the (H, W) boolean ``where`` holds (default: everywhere). The message names the worst channel."""
    from ssskit.backends import get_backend

    bound = ULPS[(backend, np.dtype(get_backend(backend).dtype).name)]
    a, d = np.asarray(actual, np.float32), np.asarray(desired, np.float32)
    keep = np.ones(a.shape[:2], bool) if where is None else np.asarray(where, bool)
    scale = np.spacing(np.maximum(np.abs(d[..., 1]), np.float32(2.0 ** -24)))  # one ulp of mu
    sigma = np.abs(np.sqrt(a[..., 2].astype(np.float64)) - np.sqrt(d[..., 2].astype(np.float64))) / scale
    worst = {"n_bar": ulp_distance(a[..., 0], d[..., 0]), "mu": ulp_distance(a[..., 1], d[..., 1]),
             "sigma (ulps of mu)": sigma, "available": np.where(a[..., 3] == d[..., 3], 0.0, np.inf)}
    for name, dist in worst.items():
        w = float(np.where(keep, dist, 0).max(initial=0))
        assert w <= bound, f"adaptive history on {backend}: {name} {w:.3g} ulps from the oracle (bound {bound})"


def tolerance(backend: str) -> float:
    """Max absolute deviation of ``backend`` from the numpy oracle (see TOLERANCES)."""
    from ssskit.backends import get_backend

    return TOLERANCES[(backend, np.dtype(get_backend(backend).dtype).name)]
