"""Guided rank-1 optimisation (paper Appendix A, Eqs. 7-8; supplement D, Eqs. S.7-S.9).

    a_s = argmin_a  int Gamma(x, y; k) (Rd(x, y) - a(x) a(y))^2 dx dy   s.t.  ||Rd||_1 = ||a||_1^2   (Eq. 7 / S.7)
    Gamma(x, y; k) = (x^2 + y^2)^(k/2) (1 - exp(-b x^2)) (1 - exp(-b y^2))                      (Eq. 8 / S.9)

with b = 50 on coordinates normalised to [-1, 1] over the kernel's grid (shared by R, G, B).
Solved coarse to fine as in supplement D: each level starts from the interpolated solution of the
next coarser one; the coarsest starts from the axis slice sqrt(Rd(x, 0)) scaled to the constraint
(a guess that knows nothing of Eq. 4). Each level is solved by sequential quadratic programming
(scipy's SLSQP, analytic gradient) in scaled variables, with a fallback where SLSQP stalls (see
:func:`_solve_level`; before that fallback, stalls on channels much narrower than the grid were
returned as results, up to 16,000 times the optimal objective).

Discretisation: a is even (Rd is radially symmetric), so only x >= 0 is optimised; a >= 0 (bounds),
which makes the constraint linear, sum a h = sqrt(||Rd||_1). Gamma is averaged over each cell
(3 x 3 Gauss-Legendre points) rather than sampled at its centre: on the axes the point values are
exactly 0, which would leave the centre cell of a unconstrained. Even so the formulation is nearly
degenerate there: a's centre cell meets only Gamma's suppressed cross, so the constraint's surplus
collects in it (18-32% of a's mass in Skin1 R for k = 0..4 on 87 cells; more for larger k and
for channels narrow against the grid).

What Appendix A claims, and what docs/kernel-accuracy.md measures (MCML Skin1, Marble, Ketchup;
256-px signals, 87-cell kernels, against the exact 2D convolution and Rd's exact cell integrals):

* "k ~ 2 yields the approximation of the actual diffusion kernel": not reproduced. The relative
  RMSE is lowest at k = 1 (edge, disk: Skin1, Ketchup; k = 2 within 1-4%), at k = 0 (Marble, every
  signal; k = 2 20% worse on the edge) or k = 4 (texture: Skin1, Ketchup); FLIP at k = 2 only for
  Skin1's edge and disk. The kernel's relative L2 error falls with k on that grid and is smallest
  at k = 2-3 in the wide channels on a 201-cell grid; its relative L1 error rises with k. The
  pre-integrated kernel beats every k by 1.7-2.6x off the exact (edge) case.
* "k = 0 sharper, k = 4 smoother": reproduced by r50, the radius holding half the 2D energy, in
  the channels wide against the grid: it grows k = 0 < 2 < 4 in 8 of 9 channels on 87 cells
  (Skin1 R 2.90, 2.99, 3.09 mm; not Skin1 G) and 6 of 9 on 201 cells (in Skin1 G, B and Ketchup G
  it falls again at k = 3-4 as the centre spike grows). The axis-marginal standard deviation and
  r90 are mostly U-shaped in k (smallest at k = 1-3); the FWHM of A(x, 0) falls with k (the spike).
* "k = 4 models the far-range scattering more faithfully": k = 4 puts the most energy beyond Rd's
  90% radius (Skin1 1.50-2.08x Rd's there, against 1.33-1.85x at k = 2): more, not more faithful.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ..errors import KernelError
from ..profiles.base import RadialProfile, RGBProfile
from ..quantities import POSITIVE, Quantity, checks
from .base import Kernel

#: the guide exponent k of the guided kernel (paper Appendix A): the paper uses 0..4, accepted up to 8
GUIDE_K = Quantity("guide exponent k", 0.0, 8.0, "", "the paper uses 0..4")

GUIDE_B = 50.0


def guide_function(u: np.ndarray, v: np.ndarray, k: float, b: float = GUIDE_B) -> np.ndarray:
    """Gamma(u, v; k) of Eq. 8 / S.9 at normalised coordinates u, v in [-1, 1]."""
    return (u**2 + v**2) ** (k / 2.0) * (1.0 - np.exp(-b * u**2)) * (1.0 - np.exp(-b * v**2))


def _cell_guide(n: int, k: float, b: float) -> np.ndarray:
    """Cell averages of Gamma on an n x n grid spanning [-1, 1]^2 (3-point Gauss-Legendre per axis)."""
    nodes, weights = np.polynomial.legendre.leggauss(3)
    h = 2.0 / n
    centres = -1.0 + h * (np.arange(n) + 0.5)
    pts = (centres[:, None] + 0.5 * h * nodes[None, :]).ravel()  # (n*3,)
    g = guide_function(pts[:, None], pts[None, :], k, b).reshape(n, 3, n, 3)
    return np.einsum("iajb,a,b->ij", g, weights, weights) / 4.0


def _levels(n: int, coarsest: int = 13) -> list[int]:
    levels = [n]
    while levels[-1] > 2 * coarsest:
        m = levels[-1] // 2
        levels.append(m + 1 - m % 2)
    return levels[::-1]


def _level_problem(rd: NDArray[np.float64], gamma: NDArray[np.float64], cell_mm: float) -> tuple[
        Callable[[NDArray[np.float64]], tuple[float, NDArray[np.float64]]], NDArray[np.float64], float]:
    """Eq. 7 on one grid in scaled variables: the cell weights w = a h / sqrt(||Rd||_1) of x >= 0.

    In these units the constraint is sum_x w = 1 for any profile and grid, and the objective is
    sum Gamma (Rd - a a^T)^2 divided by sum Gamma Rd^2 (both in the same units, so the value does
    not depend on the profile's scale). Returns (fun -> (f, grad), constraint coefficients, sqrt(||Rd||_1)).
    """
    n = rd.shape[0]
    c = n // 2
    root = float(np.sqrt(rd.sum() * cell_mm**2))
    rdw = rd * cell_mm**2 / root**2  # cells of Rd as fractions of ||Rd||_1
    norm = float((gamma * rdw**2).sum()) or 1.0
    coef = np.full(c + 1, 2.0)
    coef[0] = 1.0

    def fun(hv):
        w = np.concatenate([hv[:0:-1], hv])
        diff = rdw - np.outer(w, w)
        gd = gamma * diff
        f = float((gd * diff).sum()) / norm
        gw = -4.0 * (gd @ w) / norm
        g = gw[c:].copy()
        g[1:] += gw[c - 1 :: -1]
        return f, g

    return fun, coef, root


def _solve_level(rd: np.ndarray, gamma: np.ndarray, cell_mm: float, a0: np.ndarray, maxiter: int,
                 label: str = "") -> np.ndarray:
    """One solve of Eq. 7 on a grid: rd densities (mm^-2) (n, n), start a0 (n,), returns a (n,).

    Sequential quadratic programming (SLSQP, as in supplement D) in the scaled variables of
    :func:`_level_problem`, from a0. Where SLSQP stalls ('positive directional derivative for
    linesearch': it did on channels much narrower than the shared RGB grid, ketchup G and B, where
    Rd sits inside Gamma's suppressed centre cross, and used to return its start unchanged), fall
    back to quasi-Newton (L-BFGS) on w = v^2 / sum v^2, which keeps w >= 0 and sum w = 1 exactly,
    from a0 and from the axis slice sqrt(Rd(x, 0)), then polish the better result with SLSQP
    (which can hold cells at the bound w = 0, which the v^2 form cannot leave). The lowest
    objective wins.
    """
    from scipy.optimize import minimize

    from ..io import Ticker

    tick, steps = Ticker(5.0), [0]

    def step(_xk: np.ndarray) -> None:  # progress from inside the solver, at most every 5 s (ssskit.io.report)
        steps[0] += 1
        tick(lambda: f"{label}: step {steps[0]}")

    fun, coef, root = _level_problem(rd, gamma, cell_mm)
    c = rd.shape[0] // 2
    if not root > 0:  # no energy on this grid: a = 0 is the only feasible point
        return np.zeros(rd.shape[0])
    cons = {"type": "eq", "fun": lambda hv: np.array([coef @ hv - 1.0]), "jac": lambda hv: coef[None, :]}
    bounds = [(0.0, None)] * (c + 1)

    def feasible(hv):
        hv = np.maximum(np.where(np.isfinite(hv), hv, 0.0), 0.0)
        s = coef @ hv
        return hv / s if s > 0 else None

    def slsqp(h0):
        # scipy-stubs 1.17 types a constraint dict's fun as scalar-valued; SLSQP takes a vector-valued one
        # with its (m, n) Jacobian (scipy.optimize.minimize: "Constraints for COBYLA, SLSQP")
        sol = minimize(fun, h0, jac=True, method="SLSQP", bounds=bounds, constraints=[cons],  # type: ignore[call-overload]
                       options={"maxiter": maxiter, "ftol": 1e-15}, callback=step)
        return sol.success, feasible(sol.x)

    def fun_v(v):
        q = v * v
        s = float(coef @ q)
        f, g = fun(q / s)
        return f, 2.0 * v * (g - coef * float(g @ q) / s) / s

    starts = [h for h in (feasible(a0[c:]), feasible(np.sqrt(np.maximum(rd[c, c:], 0.0)))) if h is not None]
    ok, hv = slsqp(starts[0])
    if ok and hv is not None:
        best = hv
    else:
        cands = starts + ([hv] if hv is not None else [])
        for h0 in starts:
            v0 = np.sqrt(h0) + 1e-6 * np.sqrt(h0.max())  # no exact zeros: v = 0 is stationary in the v^2 form
            sol = minimize(fun_v, v0, jac=True, method="L-BFGS-B",  # type: ignore[call-overload]  # (stubs: callback)
                           options={"maxiter": 10 * maxiter, "ftol": 1e-13}, callback=step)
            h = feasible(sol.x**2)
            if h is not None:
                cands.append(h)
        best = min(cands, key=lambda h: fun(h)[0])
        _, hv = slsqp(best)
        if hv is not None and fun(hv)[0] < fun(best)[0]:
            best = hv
    return np.concatenate([best[:0:-1], best]) * root / cell_mm


def guided_1d(channel: RadialProfile, cell_mm: float, n: int, k: float = 2.0, b: float = GUIDE_B,
              maxiter: int = 300, label: str = "guided kernel") -> NDArray[np.float64]:
    """The optimal a (cell averages, mm^-1, shape (n,)) of Eq. 7 for one channel's radial profile;
    progress (each grid, and the solver's steps every few seconds) goes to :func:`ssskit.io.report`
    under ``label``."""
    from ..io import report

    extent = cell_mm * n
    a: NDArray[np.float64] | None = None
    prev_x: NDArray[np.float64] | None = None
    levels = _levels(n)
    for i, m in enumerate(levels):
        report(f"{label}: grid {i + 1} of {len(levels)} ({m} cells)")
        h = extent / m
        x = (np.arange(m, dtype=np.float64) - (m - 1) / 2.0) * h
        rd = channel.discretize_2d(h, m) / h**2
        if a is None or prev_x is None:  # the coarsest level (both are set together)
            a0 = np.sqrt(np.maximum(rd[m // 2], 0.0))
            a0 *= np.sqrt(rd.sum() * h**2) / (a0.sum() * h)
        else:
            a0 = np.interp(x, prev_x, a, left=0.0, right=0.0)
        a = _solve_level(rd, _cell_guide(m, k, b), h, a0, maxiter, f"{label}: grid {i + 1} of {len(levels)}")
        prev_x = x
    assert a is not None  # _levels(n) ends with n
    return a


@checks(KernelError, k=(GUIDE_K, GUIDE_K.name), b=(POSITIVE, "guide suppression b"))
def kernel_guided(profile: RGBProfile, cell_mm: float, n: int, k: float = 2.0, b: float = GUIDE_B) -> Kernel:
    """Guided rank-1 kernel A_s = a_s(x) a_s(y) (paper Appendix A, Eqs. 7-8), per channel.

    k in [0, 4] per the paper (accepted up to 8): a larger k weights errors far from the origin more.
    Measured (module docstring, docs/kernel-accuracy.md): the energy spreads outwards as k grows (r50,
    the half-energy radius, grows k = 0 < 2 < 4 in channels wide against the grid, and k = 4 puts the
    most energy in the far range, 1.3-2.1x Rd's beyond its 90% radius), while a's centre cell takes a
    growing share; no single k is closest to the exact kernel (k = 0-1 on edges and disks by relative
    RMSE, k = 0 or 4 on the texture), so k ~ 2 is a compromise rather than the paper's "approximation of
    the actual diffusion kernel". ``b`` is Gamma's centre-cross suppression (paper: 50).
    """
    comps = np.stack([guided_1d(ch, cell_mm, n, k, b, label=f"guided kernel (k = {k:g}), channel {name}")
                      for name, ch in zip("RGB", profile.channels)])[:, None, :]
    return Kernel(cell_mm, comps, np.ones((3, 1)), "guided", {"k": float(k), "b": float(b)},
                  {"model": profile.model, "name": profile.name})
