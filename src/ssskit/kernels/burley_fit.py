"""Burley-to-separable fit (Xie et al. 2020, appendix A.1, Eqs. 25-27).

Fit the parameters of a separable model's radial profile R_S(r; theta_S) to Burley's R_B(r; A, d)
with one of three error functions over samples r_j in (0, r_0.99]:

    difference  S_Delta = sum (R_B - R_S)^2                 (Eq. 25)
    ratio       S_R     = sum (R_B / R_S - 1)^2             (Eq. 26)
    derivative  S_D     = sum (R_B' - R_S')^2               (Eq. 27)

Models: ``jimenez2012`` (theta_S = {falloff}, the engine profile of
:mod:`ssskit.kernels.jimenez2012`, as in Xie) and ``two_gaussian`` (theta_S = {sigma_n, sigma_f, w},
paper Eq. 6 read as a radial mixture of 2D Gaussians). Both R_S are normalised to Burley's total A,
so only the shape is fitted. Derivatives are central differences on the sample grid for both
curves. The separable kernel is then A(x, y) = A_tot p(x) p(y) with p the 1D-normalised profile
along an axis (what the engine convolves with).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import KernelError
from ..quantities import Choice
from ..profiles.base import RadialProfile, RGBProfile
from .base import Kernel
from .jimenez2012 import _PI_ENGINE, JIMENEZ2012_GAUSSIANS
from .methods import gaussian_cell_averages

ERROR_FUNCTIONS = ("difference", "ratio", "derivative")
FIT_MODELS = ("jimenez2012", "two_gaussian")
#: the fit's two names, each declared once (:func:`fit_burley_channel`, and ``burley_fit:ERROR`` specs)
ERROR_FUNCTION = Choice("error function", ERROR_FUNCTIONS)
FIT_MODEL = Choice("separable model", FIT_MODELS)


def _mixture(model: str, params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(weights, sigmas) of the model's radial profile as a sum of 2D Gaussians, weights summing to 1."""
    if model == "jimenez2012":
        s = 0.001 + params[0]
        c = np.array([g[0] for g in JIMENEZ2012_GAUSSIANS])
        v = np.array([g[1] for g in JIMENEZ2012_GAUSSIANS])
        # c exp(-r^2 / (2 v s^2)) / (2 * 3.14 * v) = c s^2 (pi / 3.14) G2(r; sqrt(v) s)
        w = c * s**2 * np.pi / _PI_ENGINE
        return w / w.sum(), np.sqrt(v) * s
    sn, sf, w = params
    return np.array([w, 1.0 - w]), np.array([sn, sf])


def _radial(model: str, params: np.ndarray, r: np.ndarray, total: float) -> np.ndarray:
    w, sig = _mixture(model, params)
    return total * np.sum(w * np.exp(-(r[:, None] ** 2) / (2.0 * sig**2)) / (2.0 * np.pi * sig**2), axis=1)


def _errors(rb: np.ndarray, rs: np.ndarray, r: np.ndarray) -> dict[str, float]:
    return {
        "difference": float(np.sum((rb - rs) ** 2)),
        "ratio": float(np.sum((rb / np.maximum(rs, 1e-300) - 1.0) ** 2)),
        "derivative": float(np.sum((np.gradient(rb, r) - np.gradient(rs, r)) ** 2)),
    }


def fit_burley_channel(channel: RadialProfile, model: str = "jimenez2012", error: str = "difference", samples: int = 256) -> dict[str, Any]:
    """Fit one channel (any radial profile, usually Burley's); returns params and every error value.

    ``relative_l2``: the 2D L2 error ||R_B - R_S|| / ||R_B|| (2 pi r-weighted), a common yardstick
    for comparing the three fits.
    """
    from scipy.optimize import least_squares

    model, error = FIT_MODEL.check(model, error=KernelError), ERROR_FUNCTION.check(error, error=KernelError)
    total = float(channel.total_rd())
    r_max = float(channel.radius_at_fraction(0.99))
    r = np.linspace(0.0, r_max, samples + 1)[1:]
    rb = channel.eval(r)
    r50 = float(channel.radius_at_fraction(0.5))

    if model == "jimenez2012":
        # the engine profile's 50% radius is ~1.62 (0.001 + falloff) mm: start there
        x0 = np.array([np.log(max(r50 / 1.62, 1e-3))])

        def unpack(x):
            return np.array([np.exp(x[0])])
    else:
        x0 = np.array([np.log(r50 / 3.0), np.log(r50 * 1.5), 0.0])

        def unpack(x):
            a, b = np.exp(x[:2])
            return np.array([min(a, b), max(a, b), 1.0 / (1.0 + np.exp(-x[2])) if a <= b else 1.0 / (1.0 + np.exp(x[2]))])

    def resid(x):
        rs = _radial(model, unpack(x), r, total)
        if error == "difference":
            return rb - rs  # Eq. 25
        if error == "ratio":
            return rb / np.maximum(rs, 1e-300) - 1.0  # Eq. 26
        return np.gradient(rb, r) - np.gradient(rs, r)  # Eq. 27

    sol = least_squares(resid, x0, method="trf", max_nfev=500)
    params = unpack(sol.x)
    rs = _radial(model, params, r, total)
    w2 = 2.0 * np.pi * r
    rel = float(np.sqrt(np.sum(w2 * (rb - rs) ** 2) / np.sum(w2 * rb**2)))
    names = ("falloff",) if model == "jimenez2012" else ("sigma_near_mm", "sigma_far_mm", "weight")
    return {"model": model, "error": error, "params": dict(zip(names, params.tolist())),
            "errors": _errors(rb, rs, r), "relative_l2": rel, "total": total}


def fit_burley_separable(profile: RGBProfile, model: str = "jimenez2012", error: str = "difference") -> list[dict[str, Any]]:
    """Per channel :func:`fit_burley_channel` of an RGB profile."""
    return [fit_burley_channel(ch, model, error) for ch in profile.channels]


def compare_error_functions(profile: RGBProfile, model: str = "jimenez2012") -> dict[str, Any]:
    """Fit with each of Eqs. 25-27 and report, per channel, which fit has the lowest relative 2D L2 error."""
    fits = {e: fit_burley_separable(profile, model, e) for e in ERROR_FUNCTIONS}
    best = [min(ERROR_FUNCTIONS, key=lambda e: fits[e][c]["relative_l2"]) for c in range(3)]
    return {"model": model, "fits": fits, "best": best}


def kernel_burley_fit(profile: RGBProfile, cell_mm: float, n: int, model: str = "jimenez2012", error: str = "difference") -> Kernel:
    """Rank-1 separable kernel of the fitted model (Xie 2020 A.1): A(x, y) = A_tot p(x) p(y).

    p is the fitted radial profile read along an axis, R_S(x, 0), normalised to integrate to 1:
    p(x) = sum_k (w_k / sigma_k) G(x; sigma_k) / sum_k (w_k / sigma_k), what the engine's separable
    pass convolves with.
    """
    fits = fit_burley_separable(profile, model, error)
    comps = np.zeros((3, 1, n))
    for c, fit in enumerate(fits):
        w, sig = _mixture(model, np.array(list(fit["params"].values())))
        # the 1D axis function of a 2D Gaussian G2(r; s) is proportional to G1(x; s) / (sqrt(2 pi) s)
        w1 = w / sig
        w1 /= w1.sum()
        comps[c, 0] = np.sqrt(fit["total"]) * (w1[:, None] * gaussian_cell_averages(sig, cell_mm, n)).sum(axis=0)
    params = {"model": model, "error": error, "fits": [f["params"] for f in fits],
              "relative_l2": [f["relative_l2"] for f in fits]}
    return Kernel(cell_mm, comps, np.ones((3, 1)), "burley_fit", params, {"model": profile.model, "name": profile.name})
