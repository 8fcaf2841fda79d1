"""1D taps for the screen-space separable pass: importance-sampled, uniform, and the engine's quadratic.

A :class:`SeparableTaps` is what the pass runs: for each separable term r of a kernel (rank R),
N tap offsets o_rk in mm along the filtering axis (shared by R, G and B), RGB weights w_rkc and a
sign s_rc, so that the 2D kernel applied is

    A_c(x, y) = sum_r s_rc k_rc(x) k_rc(y),   k_rc = sum_k w_rkc delta(x - o_rk)   (paper Eq. 2)

Weights are normalised so that every channel's 2D kernel sums to 1 (the pass conserves energy; the
material's total diffuse reflectance belongs to the albedo layer). Taps are stored centre first,
sorted by |offset|, so the taps inside a jitter radius are a prefix.

Placement (``method``):

* ``importance`` (separable-SSS paper section 6): the N cells are equal-probability quantiles
  [F^-1(k/N), F^-1((k+1)/N)] of the dominant channel's 1D function |a| (the widest channel, the
  one with the largest axis standard deviation), so all channels sample the same positions; each
  tap sits at its cell's centroid under |a|; each channel's weight is its a integrated over the
  cell (exact for the tabulated cell averages).
* ``uniform``: N equally spaced offsets over the kernel's support, the central interval holding
  ``SUPPORT_FRACTION`` (99%) of the dominant channel's |a| (the paper's Fig. 11 discretises the 1D
  function uniformly over its domain); each cell is the set of points nearest to its tap, the outer
  cells reaching the kernel's edge.
* ``quadratic``: the engines' spacing o_i = sign(t_i) t_i^2 / R (Jimenez 2012 demo) over the same
  support, weights integrated over the cells between tap midpoints.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..errors import KernelError, SamplingError
from ..quantities import FRACTION, LENGTH_MM, POSITIVE, Quantity, check_choice, check_instance, check_shape

#: taps of one 1D pass: odd, for a centre tap
TAP_COUNT = Quantity("tap count", 1, 2**31 - 1, "", "taps of one 1D pass, odd for a centre tap", integer=True, odd=True)

if TYPE_CHECKING:  # imported where used: taps load without the kernels package
    from ..kernels.base import AnyKernel, Kernel

TAP_METHODS = ("importance", "uniform", "quadratic")
_SUBDIV = 64  # sub-cells per kernel cell when integrating centroids
SUPPORT_FRACTION = 0.99  # of the dominant |a|: the span of uniform and quadratic taps


@dataclass(frozen=True, eq=False)
class SeparableTaps:
    """Taps of a rank-R separable kernel (module docstring): offsets (R, N) mm, weights (R, N, 3), signs (R, 3)."""

    offsets_mm: np.ndarray
    weights: np.ndarray
    signs: np.ndarray
    method: str
    extent_mm: float
    tau_max_mm2: float | None = None
    width_mm: float = 1.0
    source: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        o = np.atleast_2d(np.asarray(self.offsets_mm, dtype=float))  # offsets (R, N), weights (R, N, 3), signs (R, 3)
        w = np.asarray(self.weights, dtype=float)
        o = check_shape(o, "tap offsets", ("R", "N"), SamplingError, finite=True)
        w = check_shape(w[None] if w.ndim == 2 else w, "tap weights", o.shape + (3,), SamplingError, finite=True)
        s = check_shape(np.atleast_2d(np.asarray(self.signs, dtype=float)), "tap signs", (o.shape[0], 3), SamplingError)
        if not np.all(np.abs(s) == 1):
            raise SamplingError("tap signs must be +-1")
        order = np.argsort(np.abs(o), axis=1, kind="stable")
        o = np.take_along_axis(o, order, axis=1)
        w = np.take_along_axis(w, order[..., None], axis=1)
        for name, val in (("offsets_mm", o), ("weights", w), ("signs", s)):
            object.__setattr__(self, name, np.ascontiguousarray(val))
        LENGTH_MM.check(self.extent_mm, "tap extent", SamplingError)

    @property
    def rank(self) -> int:
        return int(self.offsets_mm.shape[0])

    @property
    def taps(self) -> int:
        return int(self.offsets_mm.shape[1])

    def total(self) -> NDArray[np.float64]:
        """Sum of the 2D kernel per channel: sum_r s_r (sum_k w_rk)^2, shape (3,)."""
        return np.sum(self.signs * self.weights.sum(axis=1) ** 2, axis=0)

    def normalised(self) -> "SeparableTaps":
        t = POSITIVE.check_array(self.total(), "the totals of taps to normalise", SamplingError, "channels")
        return self._replace(weights=self.weights / np.sqrt(t))

    def jitter_count(self, jitter: float) -> int:
        """How many taps (a prefix) lie within the jitter radius of the centre (paper section 6).

        The radius is ``jitter`` times the kernel size, the full span 2 * extent_mm of the taps
        (the paper: "closer than 10% of the kernel size").
        """
        FRACTION.check(jitter, "jitter radius (a fraction of the kernel size)", SamplingError)
        if jitter == 0:
            return 0
        return int(np.max(np.sum(np.abs(self.offsets_mm) <= jitter * 2.0 * self.extent_mm + 1e-12, axis=1)))

    def to_kernel(self, cell_mm: float, n: int | None = None) -> Kernel:
        """The taps deposited on a grid by linear interpolation (bilinear fetches), as a :class:`Kernel`."""
        from ..kernels.base import Kernel, TapKernel

        if n is None:
            n = 2 * int(np.ceil(np.max(np.abs(self.offsets_mm)) / cell_mm)) + 3
        comps = [TapKernel(self.offsets_mm[r], self.weights[r], self.method).to_kernel(cell_mm, n).components[:, 0]
                 for r in range(self.rank)]
        return Kernel(cell_mm, np.stack(comps, axis=1), self.signs.T, f"taps:{self.method}", {"taps": self.taps},
                      self.source)

    def to_dict(self) -> dict[str, Any]:
        return {"type": "separable_taps", "method": self.method, "taps": self.taps, "rank": self.rank,
                "extent_mm": self.extent_mm, "tau_max_mm2": self.tau_max_mm2, "width_mm": self.width_mm,
                "offsets_mm": self.offsets_mm.tolist(), "weights": self.weights.tolist(),
                "signs": self.signs.tolist(), "source": self.source}

    def _replace(self, **kw: Any) -> "SeparableTaps":
        return dataclasses.replace(self, **kw)


def _fine(kernel: Kernel, r: int) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                          NDArray[np.float64], float]:
    """Fine sub-cell edges and cumulative integrals of every channel's a_r and of the dominant |a_r|."""
    comps = kernel.components[:, r]  # (3, n)
    comps = 0.5 * (comps + comps[:, ::-1])  # kernels are even; remove rounding asymmetry
    h = kernel.cell_mm / _SUBDIV
    fine = np.repeat(comps, _SUBDIV, axis=1)  # (3, n*SUB) piecewise constant
    edges = (np.arange(fine.shape[1] + 1) - fine.shape[1] / 2.0) * h
    x = 0.5 * (edges[1:] + edges[:-1])
    widths = np.sqrt((np.abs(fine) * x**2).sum(axis=1) / np.maximum(np.abs(fine).sum(axis=1), 1e-300))
    dom = int(np.argmax(widths))
    p = np.abs(fine[dom])
    POSITIVE.check(p.sum(), f"the energy of kernel term {r} to sample", SamplingError)
    cum = np.concatenate([np.zeros((3, 1)), np.cumsum(fine * h, axis=1)], axis=1)
    pcum = np.concatenate([[0.0], np.cumsum(p * h)])
    mcum = np.concatenate([[0.0], np.cumsum(p * x * h)])
    return edges, cum, pcum, mcum, float(widths[dom])


def _cell_weights(edges: NDArray[np.float64], cum: NDArray[np.float64],
                  bounds: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 3): each channel's integral over the cells between consecutive ``bounds``."""
    at = np.stack([np.interp(bounds, edges, cum[c]) for c in range(3)], axis=1)
    return np.diff(at, axis=0)


def _term_taps(kernel: Kernel, r: int, n: int,
               method: str) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    edges, cum, pcum, mcum, width = _fine(kernel, r)
    lo, hi = edges[0], edges[-1]
    # importance cells: equal-probability quantiles of the dominant |a| (paper section 6)
    q = np.linspace(0.0, pcum[-1], n + 1)
    # invert the increasing cumulative; flat stretches (zero density) resolve to their left end
    bounds = np.interp(q, pcum, edges)
    bounds[0], bounds[-1] = lo, hi
    mass = np.diff(np.interp(bounds, edges, pcum))
    first = np.diff(np.interp(bounds, edges, mcum))
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = np.where(mass > 0, first / mass, 0.5 * (bounds[1:] + bounds[:-1]))
    centroid = 0.5 * (centroid - centroid[::-1])  # exact symmetry, centre tap at 0
    tail = 0.5 * (1.0 - SUPPORT_FRACTION) * pcum[-1]
    support = np.interp([tail, pcum[-1] - tail], pcum, edges)
    span = float(0.5 * (support[1] - support[0])) if n > 1 else 0.0
    if method == "importance":
        offsets = centroid
    elif span == 0.0:
        offsets = np.zeros(n)
    elif method == "uniform":
        offsets = np.linspace(-span, span, n)
    else:  # quadratic (make_taps checked the name)
        rng = 3.0 if n > 20 else 2.0
        t = np.linspace(-rng, rng, n)
        offsets = np.sign(t) * t**2 / rng * (span / rng)
    if method != "importance":
        mid = 0.5 * (offsets[1:] + offsets[:-1])
        bounds = np.concatenate([[lo], mid, [hi]])
    weights = _cell_weights(edges, cum, bounds)
    # the kernel is even: make the taps exact mirror pairs (o, -o with equal weights), removing the
    # rounding of the cell integrals, so the pass plan pairs them exactly
    return 0.5 * (offsets - offsets[::-1]), 0.5 * (weights + weights[::-1]), width


def make_taps(kernel: AnyKernel, n: int | None = None, method: str = "importance") -> SeparableTaps:
    """Taps for any :class:`Kernel` or engine :class:`TapKernel` (module docstring), normalised.

    ``n``: taps per 1D pass (odd; default 7). A TapKernel is used as shipped (its own offsets and
    weights; ``method`` does not apply), so ``n`` must be None or its own tap count. A kernel with a
    depth-correction width (the two-Gaussian model's ``depth_sigma_mm`` = max(sigma_near,
    sigma_far) over channels) keeps tau_max = depth_sigma_mm^2 for supplement E's depth test.
    """
    from ..kernels.base import Kernel, TapKernel

    if isinstance(kernel, TapKernel):
        if n is not None and n != kernel.taps:
            raise SamplingError(f"the {kernel.method} kernel ships {kernel.taps} taps, not {n} "
                                f"(ask the kernel for {n} taps instead, e.g. {kernel.method}:{n})")
        o = kernel.offsets_mm
        return SeparableTaps(o[None], kernel.weights[None], np.ones((1, 3)), kernel.method,
                             float(np.max(np.abs(o))) or 1.0, None, _tap_width(o, kernel.weights),
                             {"kernel": kernel.method, **kernel.source}).normalised()
    check_instance(kernel, Kernel, "the kernel of taps", KernelError)
    n = int(TAP_COUNT.check(7 if n is None else n, "tap count", SamplingError))
    method = check_choice("tap placement", method, TAP_METHODS, SamplingError)
    offs, wts, widths = [], [], []
    for r in range(kernel.rank):
        o, w, width = _term_taps(kernel, r, n, method)
        offs.append(o)
        wts.append(w)
        widths.append(width)
    offsets = np.stack(offs)
    extent = float(np.max(np.abs(offsets))) or kernel.cell_mm
    tau = None if kernel.depth_sigma_mm is None else float(kernel.depth_sigma_mm) ** 2
    taps = SeparableTaps(offsets, np.stack(wts), kernel.signs.T, method, extent, tau, float(widths[0]),
                         {"kernel": kernel.method, "params": kernel.params, **kernel.source})
    return taps.normalised()


def _tap_width(offsets: NDArray[np.float64], weights: NDArray[np.float64]) -> float:
    w = np.abs(weights).max(axis=1)
    return float(np.sqrt(np.sum(w * offsets**2) / np.sum(w))) or 1.0
