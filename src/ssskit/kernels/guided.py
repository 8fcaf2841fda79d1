"""Guided rank-1 optimisation (paper Appendix A, Eqs. 7-8; supplement D, Eqs. S.7-S.9).

    a_s = argmin_a  int Gamma(x, y; k) (Rd(x, y) - a(x) a(y))^2 dx dy   s.t.  ||Rd||_1 = ||a||_1^2   (Eq. 7 / S.7)
    Gamma(x, y; k) = (x^2 + y^2)^(k/2) (1 - exp(-b x^2)) (1 - exp(-b y^2))                      (Eq. 8 / S.9)

with b = 50 on coordinates normalised to [-1, 1] over the kernel's grid. Solved by sequential
quadratic programming (scipy's SLSQP) with the analytic gradient, coarse to fine: each level
starts from the interpolated solution of the next coarser one; the coarsest starts from the
axis slice sqrt(Rd(x, 0)) scaled to the constraint (a guess that knows nothing of Eq. 4).

Discretisation: a is even (Rd is radially symmetric), so only x >= 0 is optimised; a >= 0 (bounds),
which makes the constraint linear, sum a h = sqrt(||Rd||_1). Gamma is averaged over each cell
(3 x 3 Gauss-Legendre points) rather than sampled at its centre: on the axes the point values are
exactly 0, which would leave the centre cell of a unconstrained.
"""

from __future__ import annotations

import numpy as np

from ..errors import KernelError
from .base import Kernel

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


def _solve_level(rd: np.ndarray, gamma: np.ndarray, cell_mm: float, a0: np.ndarray, maxiter: int) -> np.ndarray:
    """One SQP solve of Eq. 7 on a grid: rd densities (mm^-2) (n, n), start a0 (n,), returns a (n,)."""
    from scipy.optimize import minimize

    n = rd.shape[0]
    c = n // 2
    target = np.sqrt(rd.sum() * cell_mm**2)  # sum a h = sqrt(||Rd||_1)
    norm = float((gamma * rd**2).sum()) or 1.0
    coef = np.full(c + 1, 2.0 * cell_mm)
    coef[0] = cell_mm

    def full(hv):
        return np.concatenate([hv[:0:-1], hv])

    def fun(hv):
        a = full(hv)
        diff = rd - np.outer(a, a)
        gd = gamma * diff
        f = float((gd * diff).sum()) / norm
        ga = -4.0 * (gd @ a) / norm
        g = ga[c:].copy()
        g[1:] += ga[c - 1 :: -1]
        return f, g

    cons = {"type": "eq", "fun": lambda hv: np.array([coef @ hv - target]), "jac": lambda hv: coef[None, :]}
    h0 = np.maximum(a0[c:], 0.0)
    sol = minimize(fun, h0, jac=True, method="SLSQP", bounds=[(0.0, None)] * (c + 1), constraints=[cons],
                   options={"maxiter": maxiter, "ftol": 1e-14})
    hv = sol.x if np.all(np.isfinite(sol.x)) else h0
    return full(np.maximum(hv, 0.0))


def guided_1d(channel, cell_mm: float, n: int, k: float = 2.0, b: float = GUIDE_B, maxiter: int = 300) -> np.ndarray:
    """The optimal a (cell averages, mm^-1, shape (n,)) of Eq. 7 for one channel's radial profile."""
    extent = cell_mm * n
    a = None
    prev_x = None
    for m in _levels(n):
        h = extent / m
        x = (np.arange(m) - (m - 1) / 2.0) * h
        rd = channel.discretize_2d(h, m) / h**2
        if a is None:
            a0 = np.sqrt(np.maximum(rd[m // 2], 0.0))
            a0 *= np.sqrt(rd.sum() * h**2) / (a0.sum() * h)
        else:
            a0 = np.interp(x, prev_x, a, left=0.0, right=0.0)
        a = _solve_level(rd, _cell_guide(m, k, b), h, a0, maxiter)
        prev_x = x
    return a


def kernel_guided(profile, cell_mm: float, n: int, k: float = 2.0, b: float = GUIDE_B) -> Kernel:
    """Guided rank-1 kernel A_s = a_s(x) a_s(y) (paper Appendix A, Eqs. 7-8), per channel.

    k in [0, 4]: k = 0 emphasises near scattering (sharper), k ~ 2 approaches the pre-integrated
    kernel, k = 4 the far-range scattering (smoother).
    """
    if not (np.isfinite(k) and 0.0 <= k <= 8.0):
        raise KernelError(f"guide exponent k must lie in [0, 8] (the paper uses 0..4), got {k!r}")
    if not (np.isfinite(b) and b > 0):
        raise KernelError(f"guide suppression b must be > 0, got {b!r}")
    comps = np.stack([guided_1d(ch, cell_mm, n, k, b) for ch in profile.channels])[:, None, :]
    return Kernel(cell_mm, comps, np.ones((3, 1)), "guided", {"k": float(k), "b": float(b)},
                  {"model": profile.model, "name": profile.name})
