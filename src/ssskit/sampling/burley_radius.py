"""Sampling Burley's normalized diffusion by radius (Xie et al. 2020, Sec. 4.2).

The radius r of a point drawn from the 2D profile R(r) (Eq. 4) has, per unit radius,

    p(r) = 2 pi r R(r) / A = (exp(-r/d) + exp(-r/(3d))) / (4 d)        (from Xie 2020, Eq. 4)
    cdf(r) = 1 - exp(-r/d)/4 - 3 exp(-r/(3d))/4                       (Xie 2020, Eq. 20)

:class:`BurleyRadial` inverts Eq. 20 exactly; :class:`BurleyRadialApprox` uses Xie's approximate
inverse (Eq. 21)

    g(xi) = d ((2 - c) xi - 2) log(1 - xi),  c = 2.5715 by default,

and reports the density its samples really follow. :func:`fit_xie_c` refits c.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import SamplingError
from ..quantities import LENGTH_MM, Choice, Quantity, checks
from ..profiles.burley import (
    burley_cdf,
    burley_inverse_cdf,
    burley_radial_pdf,
)
from .base import UNIFORM, Distribution

#: Xie 2020's least-squares constant for Eq. 21.
XIE_C = 2.5715
#: Eq. 21's damping c this sampler takes (c >= 2 keeps g increasing) and a radius (mm; inf: the CDF is 1)
XIE_C_ANY = Quantity("c", 2.0, 10.0, "", "c >= 2 keeps Eq. 21's g increasing")
#: the midpoints of [0, 1] :func:`fit_xie_c` fits c at (fewer than 100 cannot resolve the CDF's error)
FIT_POINTS = Quantity("points", 100, 10**9, "", "midpoints of [0, 1] the fit of c takes", integer=True)
RADIUS = Quantity("radius", 0.0, math.inf, "mm", "a distance from the centre", hi_open=True)
#: Burley's length d (mm) a sampler takes
BURLEY_D = (LENGTH_MM, "Burley length d")


class BurleyRadial(Distribution):
    """Exact radius distribution of Burley's profile (Eq. 20 inverted exactly). Measure: per unit radius."""

    measure = "per unit radius (mm^-1); divide by 2 pi r for the per-area density"

    @checks(SamplingError, d=BURLEY_D)
    def __init__(self, d: float) -> None:
        self.d = d

    def eval(self, r: ArrayLike) -> NDArray[np.float64]:
        """2 pi r R(r) / A for A = 1 (the normalised Eq. 4 times the circumference)."""
        return burley_radial_pdf(r, self.d)

    def pdf(self, r: ArrayLike) -> NDArray[np.float64]:
        return burley_radial_pdf(r, self.d)

    def cdf(self, r: ArrayLike) -> NDArray[np.float64]:
        return burley_cdf(r, self.d)  # Eq. 20

    def sample(self, u: ArrayLike) -> NDArray[np.float64]:
        return burley_inverse_cdf(UNIFORM.check_array(u, error=SamplingError), self.d)


def xie_g(xi: ArrayLike, d: float, c: float = XIE_C) -> NDArray[np.float64]:
    """Xie 2020 Eq. 21: g(xi) = d ((2 - c) xi - 2) log(1 - xi), the approximate inverse of Eq. 20."""
    xi = np.asarray(xi, dtype=float)
    with np.errstate(divide="ignore"):
        return d * ((2.0 - c) * xi - 2.0) * np.log1p(-xi)


def _xie_g_of_t(t: NDArray[np.float64], c: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """g / d as a function of t = -log(1 - xi): t (c + (2 - c) exp(-t)), and its derivative."""
    e = np.exp(-t)
    return t * (c + (2.0 - c) * e), c + (2.0 - c) * e * (1.0 - t)


class BurleyRadialApprox(Distribution):
    """Radii from Xie's approximate inverse CDF (Eq. 21), with the density they actually follow.

    ``sample(u)`` = g(u); ``invert(r)`` = g^-1(r) = ``cdf(r)`` (the CDF of these samples);
    ``pdf(r)`` = 1 / g'(g^-1(r)); ``target_pdf`` is Burley's exact p(r).
    """

    measure = "per unit radius (mm^-1)"

    @checks(SamplingError, d=BURLEY_D, c=(XIE_C_ANY, "Eq. 21 damping c"))
    def __init__(self, d: float, c: float = XIE_C) -> None:
        # For c >= 2 both factors of Eq. 21 keep g increasing (g' > 0 on [0, 1)).
        self.d, self.c = d, c

    def sample(self, u: ArrayLike) -> NDArray[np.float64]:
        return xie_g(UNIFORM.check_array(u, error=SamplingError), self.d, self.c)

    def _t_of_r(self, r: ArrayLike) -> NDArray[np.float64]:
        """Solve g(t) = r / d for t = -log(1 - xi) >= 0 (g is increasing in t): Newton from r/(c d)."""
        y = np.asarray(r, dtype=float) / self.d
        finite = np.isfinite(y)
        y = np.where(finite, y, 1.0)
        t = y / self.c
        for _ in range(60):
            f, df = _xie_g_of_t(t, self.c)
            step = np.where(finite, (f - y) / df, 0.0)
            t = np.maximum(t - step, 0.5 * t)
            if np.all(np.abs(step) <= 1e-15 * np.maximum(t, 1e-300)):
                break
        return np.where(finite, t, np.inf)

    def cdf(self, r: ArrayLike) -> NDArray[np.float64]:
        r = np.asarray(r, dtype=float)
        if np.any(r < 0):
            RADIUS.check_array(np.where(np.isinf(r), 0.0, r), "radius", SamplingError)
        return -np.expm1(-self._t_of_r(r))

    def pdf(self, r: ArrayLike) -> NDArray[np.float64]:
        t = self._t_of_r(r)
        finite = np.isfinite(t)
        t = np.where(finite, t, 0.0)
        _, dg_dt = _xie_g_of_t(t, self.c)
        # dr/dxi = d * dg/dt * dt/dxi, dt/dxi = 1 / (1 - xi) = exp(t)
        return np.where(finite, np.exp(-t) / (self.d * dg_dt), 0.0)

    def eval(self, r: ArrayLike) -> NDArray[np.float64]:
        return self.pdf(r)

    def target_pdf(self, r: ArrayLike) -> NDArray[np.float64]:
        """Burley's exact radius density, which Eq. 21 approximates."""
        return burley_radial_pdf(r, self.d)


def xie_cdf_error(c: float, xi: ArrayLike | None = None) -> NDArray[np.float64]:
    """cdf(g(xi | c)) - xi on a grid (Eq. 20 applied to Eq. 21); independent of d."""
    x = (np.arange(100_000) + 0.5) / 100_000 if xi is None else np.asarray(xi, dtype=float)
    return burley_cdf(xie_g(x, 1.0, c), 1.0) - x


#: how :func:`fit_xie_c` fits c
FIT_METHOD = Choice("fit method", ("lsq", "minimax"))


@checks(SamplingError, method=(FIT_METHOD, FIT_METHOD.name), n=(FIT_POINTS, "n (points to fit c)"))
def fit_xie_c(method: str = "lsq", n: int = 100_000) -> tuple[float, float]:
    """Refit Eq. 21's c; returns (c, max |cdf(g(xi)) - xi| over xi).

    ``lsq``: least squares of cdf(g(xi | c)) - xi over n midpoints of [0, 1], the criterion Xie
    2020 states (Sec. 4.2, nonlinear least squares, tolerance 1e-6), which gives 2.5715.
    ``minimax``: minimises the maximum absolute CDF error instead.
    """
    from scipy.optimize import least_squares, minimize_scalar

    xi = (np.arange(n) + 0.5) / n
    if method == "lsq":
        def resid(c: NDArray[np.float64]) -> NDArray[np.float64]:
            return xie_cdf_error(c[0], xi)

        res = least_squares(resid, [XIE_C], xtol=1e-15, ftol=1e-15, gtol=1e-15)
        c = float(res.x[0])
    else:  # minimax
        sol = minimize_scalar(
            lambda c: float(np.max(np.abs(xie_cdf_error(c, xi)))), bounds=(2.0, 3.5), method="bounded",
            options={"xatol": 1e-10},
        )
        c = float(sol.x)
    return c, float(np.max(np.abs(xie_cdf_error(c, xi))))
