"""Exact cell integrals of a radial profile on a square grid: the discrete 2D kernel Rd(x, y).

Each cell holds Int_cell R(sqrt(x^2 + y^2)) dx dy (dimensionless energy), not a point sample, so
the centre cell of a 1/r profile (Burley) is finite and correct, and the cells sum to the energy
inside the square.

Method (Green's theorem in polar form). For a radial density, the integral over the triangle
spanned by the origin and a segment [a, b] is (1/2 pi) Int_{theta_a}^{theta_b} E(rho(theta)) dtheta,
with E(rho) = 2 pi Int_0^rho R(r) r dr the energy within radius rho and rho(theta) the distance
from the origin to the segment's line along direction theta. Summing the signed triangles over a
cell's edges gives the cell's integral. Writing E = T - S (S = energy outside rho) keeps
precision in the tail: cell = T * (sum_edges dtheta) / (2 pi) - (1/2 pi) sum_edges Int S dtheta,
where the first term is T for the cell holding the origin and 0 for every other cell.
Along an edge x = x_k the angle is psi = atan(y / |x_k|) and rho = |x_k| / cos psi, which is
smooth on every edge because the origin sits at a cell centre (n odd, so |x_k| >= h / 2); the
theta integral uses Gauss-Legendre quadrature. Horizontal edges follow from vertical ones by
the profile's symmetry under reflection in y = x.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ProfileError
from ..quantities import KERNEL_CELLS, LENGTH_MM

_GL_ORDER = 24


def grid_coordinates(cell_mm: float, n: int) -> NDArray[np.float64]:
    """Cell-centre coordinates (mm) of an n-cell axis centred on the origin: (k - (n-1)/2) h."""
    return (np.arange(n, dtype=np.float64) - (n - 1) / 2.0) * cell_mm


def _check_grid(cell_mm: float, n: int) -> None:
    KERNEL_CELLS.within(lo=1).check(n, "grid size n", ProfileError)  # (odd: the origin at a cell centre)
    LENGTH_MM.check(cell_mm, "cell size", ProfileError)


class RadialEnergy(Protocol):
    """What the cell integrals need of a profile (a :class:`~ssskit.profiles.base.RadialProfile` has it)."""

    def total_rd(self) -> float: ...

    def energy_outside(self, rho: ArrayLike) -> NDArray[np.float64]: ...


def cell_integrals(profile: RadialEnergy, cell_mm: float, n: int) -> NDArray[np.float64]:
    """Integrals of ``profile`` (a RadialProfile) over n x n square cells of side ``cell_mm``.

    Returns an (n, n) float64 array indexed [row = y, column = x], the origin at the centre of
    cell (n // 2, n // 2). Its sum is the energy in the square of side n * cell_mm.
    """
    _check_grid(cell_mm, n)
    h = float(cell_mm)
    edges = (np.arange(n + 1) - n / 2.0) * h  # edge coordinates, none at 0 because n is odd
    total = float(profile.total_rd())

    nodes, weights = np.polynomial.legendre.leggauss(_GL_ORDER)
    ax = np.abs(edges)[:, None]  # |x_k|, shape (n+1, 1)
    psi = np.arctan2(edges[None, :], ax)  # (n+1, n+1): angle of (x_k, y_j) from the edge normal
    psi_a, psi_b = psi[:, :-1], psi[:, 1:]  # segment y_j -> y_{j+1}, shape (n+1, n)
    dpsi = psi_b - psi_a
    mid, half = 0.5 * (psi_a + psi_b), 0.5 * dpsi
    # Gauss-Legendre nodes along each edge: (n+1, n, order)
    theta = mid[..., None] + half[..., None] * nodes
    rho = ax[..., None] / np.cos(theta)
    s_int = half * np.einsum("...q,q->...", profile.energy_outside(rho), weights)
    # Signed contribution of the upward vertical edge x = x_k, y_j -> y_{j+1}:
    # counter-clockwise (positive) for x_k > 0, clockwise for x_k < 0.
    sign = np.sign(edges)[:, None]
    v = sign * (total * dpsi - s_int) / (2.0 * np.pi)
    # cell(i = x index, j = y index) = bottom + right + top + left, with horizontal edges
    # H[k, i] = -V[k, i] by the reflection symmetry in y = x.
    cells_xy = -v[:-1, :].T + v[1:, :] + v[1:, :].T - v[:-1, :]
    return np.ascontiguousarray(cells_xy.T)
