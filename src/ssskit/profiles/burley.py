"""Burley / Christensen normalized diffusion (Xie et al. 2020, Sec. 3.1).

    R(r) = A (exp(-r/d) + exp(-r/(3d))) / (8 pi d r)                      (Xie 2020, Eq. 4)

A is the surface albedo, A = Int_0^inf R(r) 2 pi r dr, and d a length fitted to a mean free path
ell for one of three configurations (Xie 2020, Eq. 5):

    searchlight            d = ell / (1.85 - A + 7 |A - 0.8|^3)     ell: volume mean free path
    diffuse transmission   d = ell / (1.9 - A + 3.5 (A - 0.8)^2)    ell: volume mfp after diffuse transmission
    diffuse mean free path d = ell / (3.5 + 100 (A - 0.33)^4)       ell: diffuse mean free path on the surface

Energy within radius rho: E(rho) = A cdf(rho), cdf(r) = 1 - exp(-r/d)/4 - 3 exp(-r/(3d))/4
(Xie 2020, Eq. 20), so S(rho) = A (exp(-rho/d)/4 + 3 exp(-rho/(3d))/4).
"""

from __future__ import annotations


import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ProfileError
from ..quantities import BURLEY_ALBEDO, Choice, FRACTION, LENGTH_MM as LENGTH, REFLECTANCE
from .base import ENERGY_FRACTION, RadialProfile


def burley_d_searchlight(albedo: ArrayLike, ell: ArrayLike) -> NDArray[np.float64]:
    """d for the searchlight configuration, Theta_1 of Xie 2020 Eq. 5; ell = volume mean free path."""
    a = _eq5_albedo(albedo)
    return np.asarray(ell, dtype=float) / (1.85 - a + 7.0 * np.abs(a - 0.8) ** 3)


def burley_d_diffuse_transmission(albedo: ArrayLike, ell: ArrayLike) -> NDArray[np.float64]:
    """d for diffuse surface transmission, Theta_2 of Xie 2020 Eq. 5."""
    a = _eq5_albedo(albedo)
    return np.asarray(ell, dtype=float) / (1.9 - a + 3.5 * (a - 0.8) ** 2)


def burley_d_dmfp(albedo: ArrayLike, ell: ArrayLike) -> NDArray[np.float64]:
    """d with ell the diffuse mean free path on the surface, Theta_3 of Xie 2020 Eq. 5."""
    a = _eq5_albedo(albedo)
    return np.asarray(ell, dtype=float) / (3.5 + 100.0 * (a - 0.33) ** 4)


#: The three configurations of Xie 2020 Eq. 5, by name.
BURLEY_CONFIGURATIONS = {
    "searchlight": burley_d_searchlight,
    "diffuse-transmission": burley_d_diffuse_transmission,
    "dmfp": burley_d_dmfp,
}


def burley_d(albedo: ArrayLike, ell: ArrayLike, configuration: str = "searchlight") -> NDArray[np.float64]:
    """d from the albedo A and a mean free path ell (mm) for a named Eq. 5 configuration."""
    key = configuration.replace("_", "-") if isinstance(configuration, str) else configuration
    fn = BURLEY_CONFIGURATIONS[Choice("Burley configuration", BURLEY_CONFIGURATIONS).check(key, error=ProfileError)]
    return fn(albedo, LENGTH.check_array(ell, "mean free path ell", ProfileError))


#: the albedo Xie 2020 Eq. 5's fits s(A) take: A in [0, 1], the range they are stated for (Burley 2015 fitted them
#: over it); the profile itself, Eq. 4, needs A > 0 (:data:`ssskit.quantities.BURLEY_ALBEDO`, :class:`BurleyProfile`)
EQ5_ALBEDO = REFLECTANCE.within(reason="the range Xie 2020 Eq. 5's fits are stated for")


def _eq5_albedo(albedo: ArrayLike) -> NDArray[np.float64]:
    return np.asarray(EQ5_ALBEDO.check_array(albedo, "Burley albedo A", ProfileError))


def burley_cdf(r: ArrayLike, d: float | NDArray[np.float64]) -> NDArray[np.float64]:
    """cdf(r) = 1 - exp(-r/d)/4 - 3 exp(-r/(3d))/4 (Xie 2020, Eq. 20), via expm1 near r = 0."""
    r = np.asarray(r, dtype=float)
    return -0.25 * np.expm1(-r / d) - 0.75 * np.expm1(-r / (3.0 * d))


def burley_survival(r: ArrayLike, d: float | NDArray[np.float64]) -> NDArray[np.float64]:
    """1 - cdf(r) = exp(-r/d)/4 + 3 exp(-r/(3d))/4 (complement of Xie 2020, Eq. 20)."""
    r = np.asarray(r, dtype=float)
    return 0.25 * np.exp(-r / d) + 0.75 * np.exp(-r / (3.0 * d))


def burley_radial_pdf(r: ArrayLike, d: float | NDArray[np.float64]) -> NDArray[np.float64]:
    """Density of the radius per unit radius, d cdf / dr = (exp(-r/d) + exp(-r/(3d))) / (4d)."""
    r = np.asarray(r, dtype=float)
    return (np.exp(-r / d) + np.exp(-r / (3.0 * d))) / (4.0 * d)


def burley_inverse_cdf(xi: ArrayLike, d: float | NDArray[np.float64]) -> NDArray[np.float64]:
    """Exact inverse of Xie 2020 Eq. 20: the radius r (mm) with cdf(r) = xi, 0 <= xi <= 1.

    With u = exp(-r/(3d)), Eq. 20 reads u^3 + 3u - 4(1 - xi) = 0, a depressed cubic with the one
    real root u = 2 sinh(asinh(2 (1 - xi)) / 3) (Cardano, written in hyperbolic form so it has no
    cancellation; the analytic inverse Xie cites to Golubev 2019), r = -3 d ln u. Near xi = 0 the
    start is the series r = 2 d xi; three Newton steps on cdf(r) - xi (or, for xi > 1/2, on
    the survival function) bring the relative error below 1e-13.
    """
    xi = np.asarray(FRACTION.check_array(xi, "the inverse CDF's xi", ProfileError))
    eta = 1.0 - xi
    with np.errstate(divide="ignore"):
        u = 2.0 * np.sinh(np.arcsinh(2.0 * eta) / 3.0)
        r = -3.0 * d * np.log(u)
    r = np.where(xi < 1e-3, 2.0 * d * xi, r)
    upper = xi > 0.5
    finite = np.isfinite(r) & (xi > 0)
    r_work = np.where(finite, r, d)
    for _ in range(3):
        resid = np.where(upper, eta - burley_survival(r_work, d), burley_cdf(r_work, d) - xi)
        r_work = r_work - resid / burley_radial_pdf(r_work, d)
    r = np.where(finite, r_work, r)
    return np.where(xi == 0, 0.0, r)


class BurleyProfile(RadialProfile):
    """One channel of Burley's normalized diffusion with albedo A and length d (mm)."""

    model = "burley"

    def __init__(self, albedo: float, d: float) -> None:
        # Eq. 4: R(r) = A s exp(-s r / ...): at A = 0 no light beneath the surface, and a kernel normalised by it 0/0
        self.albedo = float(BURLEY_ALBEDO.check(albedo, "Burley albedo A", ProfileError))
        self.d = float(LENGTH.check(d, "Burley length d", ProfileError))

    def eval(self, r: ArrayLike) -> NDArray[np.float64]:
        """Xie 2020 Eq. 4 (mm^-2); infinite at r = 0 (the profile's 1/r singularity)."""
        r = self.radii(r)
        d = self.d
        with np.errstate(divide="ignore"):
            return self.albedo * (np.exp(-r / d) + np.exp(-r / (3.0 * d))) / (8.0 * np.pi * d * r)

    def total_rd(self) -> float:
        return self.albedo

    def energy_outside(self, rho: ArrayLike) -> NDArray[np.float64]:
        return self.albedo * burley_survival(rho, self.d)

    def energy_within(self, rho: ArrayLike) -> NDArray[np.float64]:
        """A cdf(rho), Xie 2020 Eq. 20, written with expm1 for precision near rho = 0."""
        return self.albedo * burley_cdf(rho, self.d)

    def _pdf_at_zero(self) -> float:
        return 1.0 / (2.0 * self.d)  # lim 2 pi r R(r) / A = (1 + 1) / (4 d)

    def radius_at_fraction(self, fraction: ArrayLike) -> NDArray[np.float64]:
        """Exact inverse of Eq. 20, :func:`burley_inverse_cdf`."""
        return burley_inverse_cdf(ENERGY_FRACTION.check_array(fraction, error=ProfileError), self.d)

    def length_scale_mm(self) -> float:
        return self.d

    def params(self) -> dict[str, float]:
        return {"A": self.albedo, "d_mm": self.d}
