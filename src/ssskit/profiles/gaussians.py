"""Sums of radially symmetric 2D Gaussians (d'Eon et al. 2007; separable-SSS supplement Eq. S.1).

    R(r) = sum_i w_i G(v_i, r),   G(v, r) = exp(-r^2 / (2 v)) / (2 pi v)       (supplement Eq. S.1)

Each G integrates to 1 over the plane, so total R_d = sum_i w_i (the L1 norm of S.1), and the
energy outside rho is S(rho) = sum_i w_i exp(-rho^2 / (2 v_i)). Variances v_i are in mm^2.

Preset: the six-Gaussian skin profile of d'Eon, Luebke and Enderton 2007 ([dLE07]; the same table
is printed in GPU Gems 3, ch. 14), each channel normalised to total reflectance 1.
"""

from __future__ import annotations

import math
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ProfileError
from ..quantities import Quantity, check_shape
from .base import RadialProfile

#: [dLE07] six-Gaussian skin fit: variances (mm^2) and RGB weights per Gaussian.
DEON2007_SKIN_VARIANCES = (0.0064, 0.0484, 0.187, 0.567, 1.99, 7.41)
DEON2007_SKIN_WEIGHTS = (
    (0.233, 0.455, 0.649),
    (0.100, 0.336, 0.344),
    (0.118, 0.198, 0.0),
    (0.113, 0.007, 0.007),
    (0.358, 0.004, 0.0),
    (0.078, 0.0, 0.0),
)


#: a sum of Gaussians' weights (>= 0) and variances (mm^2, > 0)
WEIGHT = Quantity("weight", 0.0, math.inf, "", "a Gaussian's share of the profile", hi_open=True)
#: the sum of a sum of Gaussians' weights: its total R_d, some light (a fit whose weights all vanished has none)
WEIGHT_SUM = WEIGHT.within(lo=1e-300, reason="some light")
VARIANCE = Quantity("variance", 0.0, math.inf, "mm^2", "a Gaussian's width squared", lo_open=True, hi_open=True)

class GaussianSumProfile(RadialProfile):
    """One channel of a sum of 2D Gaussians, Eq. S.1: weights (dimensionless), variances (mm^2)."""

    model = "gaussians"

    def __init__(self, weights: ArrayLike, variances: ArrayLike) -> None:
        w = np.asarray(weights, dtype=float).ravel()
        v = check_shape(np.ravel(variances), "Gaussian variances", (w.size,), ProfileError, dtype=float)
        WEIGHT.check_array(w, "Gaussian weights", ProfileError)
        VARIANCE.check_array(v, "Gaussian variances", ProfileError)
        # (no weights at all: their sum 0 is refused here)
        WEIGHT_SUM.check(w.sum(), "the sum of the Gaussian weights", ProfileError)
        self.weights, self.variances = w, v

    def eval(self, r: ArrayLike) -> NDArray[np.float64]:
        r2 = np.square(self.radii(r))[..., None]
        return np.sum(self.weights * np.exp(-r2 / (2.0 * self.variances)) / (2.0 * np.pi * self.variances), axis=-1)

    def total_rd(self) -> float:
        return float(self.weights.sum())

    def energy_outside(self, rho: ArrayLike) -> NDArray[np.float64]:
        r2 = np.square(np.asarray(rho, dtype=float))[..., None]
        return np.sum(self.weights * np.exp(-r2 / (2.0 * self.variances)), axis=-1)

    def energy_within(self, rho: ArrayLike) -> NDArray[np.float64]:
        r2 = np.square(np.asarray(rho, dtype=float))[..., None]
        return np.sum(self.weights * -np.expm1(-r2 / (2.0 * self.variances)), axis=-1)

    def length_scale_mm(self) -> float:
        return float(math.sqrt(np.max(self.variances)))

    def params(self) -> dict[str, list[float]]:
        return {"weights": self.weights.tolist(), "variances_mm2": self.variances.tolist()}


def fit_gaussian_sum(profile: RadialProfile, n: int = 6, fraction: float = 0.999) -> GaussianSumProfile:
    """Fit ``n`` Gaussians to a radial profile with the L1 constraint of [dLE07] / Eq. S.1.

    The variances form a geometric ladder (as in [dLE07]'s fits, whose successive variances grow
    by a roughly constant factor) with standard deviations from half the radius holding 5% of the
    energy to a third of the radius holding ``fraction`` of it. Non-negative weights minimise the
    2 pi r-weighted squared error of R(r) on [0, r_fraction] (energy-weighted, as the supplement's
    plots are), with sum(w) = total R_d (the L1 constraint ||A_g||_1 = ||R_d||_1) enforced by a
    heavily weighted row, then exactly by rescaling.
    """
    from scipy.optimize import nnls

    Quantity("number of Gaussians", 1, 16, "", "terms of the fit", integer=True).check(n, error=ProfileError)
    total = profile.total_rd()
    r_lo = float(profile.radius_at_fraction(0.05))
    r_hi = float(profile.radius_at_fraction(fraction))
    sig = np.geomspace(max(r_lo / 2.0, 1e-6), r_hi / 3.0, n) if n > 1 else np.array([r_hi / 3.0])
    variances = sig**2
    r = np.linspace(0.0, r_hi, 2048)[1:]
    dr = r[1] - r[0]
    wq = np.sqrt(2.0 * np.pi * r * dr)
    basis = np.exp(-(r[:, None] ** 2) / (2.0 * variances)) / (2.0 * np.pi * variances)
    a = basis * wq[:, None]
    b = profile.eval(r) * wq
    scale = 1e3 * np.linalg.norm(b) / max(total, 1e-300)
    a = np.vstack([a, scale * np.ones(n)])
    b = np.append(b, scale * total)
    w, _ = nnls(a, b, maxiter=50 * n)
    w *= total / WEIGHT_SUM.check(w.sum(), "the sum of the fitted Gaussian weights", ProfileError)
    return GaussianSumProfile(w, variances)
