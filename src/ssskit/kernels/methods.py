"""Separable approximations of a discretised 2D profile Rd (separable-SSS paper + supplement).

Every method takes an :class:`~ssskit.profiles.RGBProfile` and a grid (cell_mm, n) and returns a
:class:`~ssskit.kernels.base.Kernel` on that grid, so that approximations and the exact cell
integrals of Rd (``profile.discretize_2d(cell_mm, n)``) are compared cell for cell. ||Rd||_1 is
the sum of the cells on the grid (the energy the grid holds).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import KernelError
from ..materials import ARTIST_PRESETS
from ..profiles.base import RadialProfile, RGBProfile
from ..profiles.gaussians import WEIGHT_SUM
from ..quantities import FRACTION, LENGTH_MM, Quantity, checks, rgb
from .base import MAX_SVD_RANK, SVD_RANK, Kernel

#: the number of Gaussians of a sum-of-Gaussians kernel (supplement Eq. S.1)
GAUSSIAN_COUNT = Quantity("number of Gaussians", 1, 12, "", "terms of the fit", integer=True)


def _source(profile: RGBProfile) -> dict[str, Any]:
    return {"model": profile.model, "name": profile.name}


def _cell_edges(cell_mm: float, n: int) -> NDArray[np.float64]:
    return (np.arange(n + 1, dtype=np.float64) - n / 2.0) * cell_mm


def gaussian_cell_averages(sigma: ArrayLike, cell_mm: float, n: int) -> NDArray[np.float64]:
    """Cell averages (mm^-1) of unit 1D Gaussians G(x, sigma) on an n-cell grid; shape sigma.shape + (n,).

    Exact: (Phi((x + h/2) / sigma) - Phi((x - h/2) / sigma)) / h.
    """
    from scipy.special import ndtr

    sig = np.asarray(sigma, dtype=float)[..., None]
    cdf = ndtr(_cell_edges(cell_mm, n) / sig)
    return np.diff(cdf, axis=-1) / cell_mm


# ---- SVD rank-N (supplement B, Eqs. S.2-S.4) -----------------------------------------------------

def _eigen_terms(matrix: NDArray[np.float64], rank: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The ``rank`` leading terms of a symmetric matrix's SVD as signed outer products.

    For symmetric M the singular values are |lambda_i| of its eigen-decomposition and the
    singular vectors are +-e_i, so M = sum_i sign(lambda_i) (sqrt|lambda_i| e_i)(sqrt|lambda_i| e_i)^T
    and truncating after the ``rank`` largest |lambda_i| is the Eckart-Young optimum (Eqs. S.3-S.4).
    Returns (weights (rank, n), signs (rank,)).
    """
    lam, vec = np.linalg.eigh(0.5 * (matrix + matrix.T))
    order = np.argsort(-np.abs(lam))[:rank]
    lam, vec = lam[order], vec[:, order]
    w = vec.T * np.sqrt(np.abs(lam))[:, None]
    # orient each vector so that its largest-magnitude entry is positive (a deterministic sign)
    flip = np.sign(w[np.arange(rank), np.argmax(np.abs(w), axis=1)])
    return w * flip[:, None], np.where(lam >= 0, 1.0, -1.0)


def singular_values(profile: RGBProfile, cell_mm: float, n: int) -> NDArray[np.float64]:
    """Singular values sigma_i of the discrete Rd per channel (supplement Eq. S.2), shape (3, n), descending."""
    rd = profile.discretize_2d(cell_mm, n)
    return np.stack([np.linalg.svd(rd[..., c], compute_uv=False) for c in range(3)])


def kernel_svd(profile: RGBProfile, cell_mm: float, n: int, rank: int = 1, renormalise: bool = False) -> Kernel:
    """Rank-N truncated SVD of the discrete Rd (supplement Eqs. S.2-S.4): A_s = U Sigma_N V^T.

    With ``renormalise`` the L1 energy renormalisation of supplement B is applied,
    A~_s = A_s ||Rd||_1 / ||A_s||_1 (||.||_1 the sum of absolute cell values, as written there).
    """
    SVD_RANK.within(hi=min(n, MAX_SVD_RANK), reason="terms of the truncated SVD, at most the grid's cells"
                    ).check(rank, error=KernelError)
    rd = profile.discretize_2d(cell_mm, n)
    comps, signs = np.zeros((3, rank, n)), np.zeros((3, rank))
    for c in range(3):
        w, s = _eigen_terms(rd[..., c], rank)
        comps[c], signs[c] = w / cell_mm, s
    k = Kernel(cell_mm, comps, signs, "svd", {"rank": int(rank), "renormalise": bool(renormalise)}, _source(profile))
    if renormalise:
        k = k.scaled(np.abs(rd).sum(axis=(0, 1)) / k.l1_norm())
    return k


# ---- sum of Gaussians (d'Eon 2007; supplement Eq. S.1) -------------------------------------------

def fit_gaussians_2d(channel: RadialProfile, count: int,
                     fraction: float = 0.999) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Weights and variances (mm^2) of ``count`` 2D Gaussians fitted to a radial profile (Eq. S.1).

    Minimises the 2D L2 error int (R - sum w_i G(r; tau_i))^2 2 pi r dr on [0, r_fraction] over
    the log standard deviations (Levenberg-Marquardt), with the weights for given variances from
    non-negative least squares under the L1 constraint sum w_i = ||Rd||_1 (d'Eon's constraint
    ||A_g||_1 = ||Rd||_1), imposed by a heavily weighted row.
    """
    from scipy.optimize import least_squares, nnls

    total = float(channel.total_rd())
    r_lo = float(channel.radius_at_fraction(0.05))
    r_hi = float(channel.radius_at_fraction(fraction))
    r = (np.arange(2048) + 0.5) * (r_hi / 2048)
    wq = np.sqrt(2.0 * np.pi * r * (r_hi / 2048))
    b = np.append(channel.eval(r) * wq, 0.0)
    big = 1e3 * np.linalg.norm(b) / max(total, 1e-300)
    b[-1] = big * total

    def weights(log_sig):
        var = np.exp(2.0 * log_sig)
        basis = np.exp(-(r[:, None] ** 2) / (2.0 * var)) / (2.0 * np.pi * var) * wq[:, None]
        a = np.vstack([basis, big * np.ones(count)])
        w, _ = nnls(a, b, maxiter=100 * count)
        return w, a

    def resid(log_sig):
        w, a = weights(log_sig)
        return a @ w - b

    x0 = np.log(np.geomspace(max(r_lo / 2.0, 1e-6), r_hi / 3.0, count)) if count > 1 else np.log([r_hi / 4.0])
    # the standard deviations stay within [1e-4, 10] x the fit's reach: a Gaussian narrower than that holds
    # no sample of r, and its variance underflowed to 0 (NaN basis) on the 10^7-photon Skin1 profile
    lo, hi = np.log(1e-4 * r_hi), np.log(10.0 * r_hi)
    x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)
    sol = least_squares(resid, x0, method="trf", x_scale=1.0, max_nfev=200 * count, bounds=(lo, hi))
    w, _ = weights(sol.x)
    w *= total / WEIGHT_SUM.check(w.sum(), "the sum of the fitted Gaussian weights", KernelError)
    keep = w > 0
    return w[keep], np.exp(2.0 * sol.x[keep])


def kernel_gaussians(profile: RGBProfile, cell_mm: float, n: int, count: int = 6) -> Kernel:
    """Sum of ``count`` Gaussians (d'Eon et al. 2007; supplement Eq. S.1): A_g = sum_i w_i G(x, y; tau_i).

    Each 2D Gaussian is separable, w G(x, y; tau) = (sqrt(w) g(x)) (sqrt(w) g(y)), so the kernel has
    rank ``count`` and costs 2 count 1D convolutions. After the fit, each channel is rescaled so the
    discrete kernel's L1 norm equals the discrete ||Rd||_1 on the grid.
    """
    GAUSSIAN_COUNT.check(count, error=KernelError)
    comps = np.zeros((3, count, n))
    weights: list[list[float]] = []
    variances: list[list[float]] = []
    params = {"count": int(count), "weights": weights, "variances_mm2": variances}
    for c, ch in enumerate(profile.channels):
        w, var = fit_gaussians_2d(ch, count)
        comps[c, : w.size] = np.sqrt(w)[:, None] * gaussian_cell_averages(np.sqrt(var), cell_mm, n)
        weights.append(w.tolist())
        variances.append(var.tolist())
    k = Kernel(cell_mm, comps, np.ones((3, count)), "gaussians", params, _source(profile))
    return k.scaled(profile.discretize_2d(cell_mm, n).sum(axis=(0, 1)) / k.total())


# ---- pre-integrated (paper Sec. 4, Eqs. 4-5; supplement C, Eqs. S.5-S.6) --------------------------

def preintegrated_1d(rd: NDArray[np.float64]) -> NDArray[np.float64]:
    """a_p per channel from discrete cells rd (n, n, 3): a_p(x) = int Rd(x, y) dy (Eq. 4), shape (3, n) (cell weights)."""
    return rd.sum(axis=0).T


def kernel_preintegrated(profile: RGBProfile, cell_mm: float, n: int) -> Kernel:
    """The pre-integrated rank-1 kernel A_p(x, y) = a_p(x) a_p(y) / ||Rd||_1 (paper Eq. 5, supplement Eq. S.6).

    a_p(x) = int Rd(x, y) dy is summed from the exact cell integrals, so on the grid A_p reproduces
    the 2D convolution of any additively separable irradiance E1(x) + E2(y) exactly (Eq. 4).
    """
    rd = profile.discretize_2d(cell_mm, n)
    ap = preintegrated_1d(rd)
    comps = (ap / np.sqrt(ap.sum(axis=1, keepdims=True)))[:, None, :] / cell_mm
    return Kernel(cell_mm, comps, np.ones((3, 1)), "preintegrated", {}, _source(profile))


def kernel_preintegrated_svd(profile: RGBProfile, cell_mm: float, n: int, rank: int = 1) -> Kernel:
    """Pre-integrated kernel plus a rank-N SVD of the residual Rd - A_p (paper Sec. 7, Results, its
    "Limitations and future work" paragraph: "a low-rank approximation can be found by approximating
    the difference between the pre-integrated kernel and the actual diffusion profile").

    A = A_p + sum_{i<=N} s_i r_i r_i^T with the r_i the Eckart-Young terms of Rd - A_p (Eqs. S.2-S.4):
    rank N + 1, 2 (N + 1) 1D convolutions.
    """
    SVD_RANK.within(hi=min(n - 1, MAX_SVD_RANK), reason="terms of the residual's SVD, fewer than the grid's cells"
                    ).check(rank, "residual rank", KernelError)
    base = kernel_preintegrated(profile, cell_mm, n)
    resid = profile.discretize_2d(cell_mm, n) - base.to_2d()
    comps, signs = np.zeros((3, rank + 1, n)), np.ones((3, rank + 1))
    comps[:, 0] = base.components[:, 0]
    for c in range(3):
        w, s = _eigen_terms(resid[..., c], rank)
        comps[c, 1:], signs[c, 1:] = w / cell_mm, s
    return Kernel(cell_mm, comps, signs, "preintegrated_svd", {"rank": int(rank)}, _source(profile))


# ---- artist-friendly two-Gaussian model (paper Sec. 5, Eq. 6; Table 2) ----------------------------

def two_gaussian_1d(sigma_near: ArrayLike, sigma_far: ArrayLike, weight: ArrayLike, cell_mm: float,
                    n: int) -> NDArray[np.float64]:
    """Cell averages of a_m(x) = w G(x, sigma_n) + (1 - w) G(x, sigma_f) per channel (Eq. 6), shape (3, n)."""
    sn = np.broadcast_to(np.asarray(sigma_near, float), (3,))
    sf = np.broadcast_to(np.asarray(sigma_far, float), (3,))
    w = np.broadcast_to(np.asarray(weight, float), (3,))[:, None]
    return w * gaussian_cell_averages(sn, cell_mm, n) + (1.0 - w) * gaussian_cell_averages(sf, cell_mm, n)


def fit_artist(profile: RGBProfile, cell_mm: float, n: int) -> dict[str, list[float]]:
    """Fit (sigma_n, sigma_f, w) of Eq. 6 per channel to the profile's pre-integrated 1D kernel.

    The paper tunes its Table 2 presets by eye; ssskit fits a_m to a_p / ||a_p||_1 (Eq. 4) in least
    squares over the cells, which makes A_m the closest two-Gaussian model on straight edges, where
    A_p is exact. Returns {"sigma_near", "sigma_far" (mm), "weight"}, each a list of 3 (w per
    channel; the paper's presets share one w).
    """
    from scipy.optimize import least_squares

    ap = preintegrated_1d(profile.discretize_2d(cell_mm, n))
    target = ap / ap.sum(axis=1, keepdims=True) / cell_mm
    xs = np.abs((np.arange(n) - (n - 1) / 2.0) * cell_mm)
    order = np.argsort(xs, kind="stable")
    out: dict[str, list[float]] = {"sigma_near": [], "sigma_far": [], "weight": []}
    for c in range(3):
        t = target[c]
        cum = np.cumsum(t[order]) * cell_mm  # energy within |x|
        r_near, r_far = np.interp(0.25, cum, xs[order]), np.interp(0.8, cum, xs[order])
        x0 = [np.log(max(r_near, cell_mm / 4)), np.log(max(r_far, cell_mm / 2)), 0.0]

        def resid(p, t=t):
            w = 1.0 / (1.0 + np.exp(-p[2]))
            return (two_gaussian_1d(np.exp(p[0]), np.exp(p[1]), w, cell_mm, n)[0] - t) / t.max()

        sol = least_squares(resid, x0, method="lm", max_nfev=2000)
        s_n, s_f = np.exp(sol.x[:2])
        w = 1.0 / (1.0 + np.exp(-sol.x[2]))
        if s_n > s_f:
            s_n, s_f, w = s_f, s_n, 1.0 - w
        out["sigma_near"].append(float(s_n))
        out["sigma_far"].append(float(s_f))
        out["weight"].append(float(w))
    return out


@checks(KernelError, sigma_near=rgb(LENGTH_MM), sigma_far=rgb(LENGTH_MM), weight=(rgb(FRACTION), "artist weight w"))
def kernel_artist(profile: RGBProfile | None, cell_mm: float, n: int, preset: str = "close fit",
                  sigma_near: ArrayLike | None = None, sigma_far: ArrayLike | None = None,
                  weight: ArrayLike | None = None, match_energy: bool = True) -> Kernel:
    """The artist-friendly separable model A_m(x, y) = a_m(x) a_m(y) (paper Eq. 6).

    ``preset`` is a Table 2 preset ("close fit", "production") or "fit" (:func:`fit_artist`);
    explicit ``sigma_near``/``sigma_far`` (mm, positive) and ``weight`` (in [0, 1]), one number or three each,
    override it (a preset's are checked where it is made, :class:`~ssskit.materials.ArtistPreset`; a fit's are an
    exp() and a logistic of its parameters). a_m integrates to 1; with
    ``match_energy`` (and a profile) each channel is scaled to the discrete ||Rd||_1 of the profile,
    standing in for the albedo the engine multiplies afterwards.
    """
    name = "custom"
    if sigma_near is None or sigma_far is None or weight is None:
        if str(preset).strip().lower() == "fit":
            if profile is None:
                raise KernelError("the 'fit' artist preset needs a profile to fit")
            fit = fit_artist(profile, cell_mm, n)
            base: tuple[ArrayLike, ArrayLike, ArrayLike, str] = (fit["sigma_near"], fit["sigma_far"], fit["weight"],
                                                                 "fit")
        else:
            p = ARTIST_PRESETS.get(preset)
            base = (p.sigma_near, p.sigma_far, p.weight, p.name)
        sigma_near = base[0] if sigma_near is None else sigma_near
        sigma_far = base[1] if sigma_far is None else sigma_far
        weight = base[2] if weight is None else weight
        name = base[3]
    a = two_gaussian_1d(sigma_near, sigma_far, weight, cell_mm, n)
    params = {"preset": name, "sigma_near_mm": np.broadcast_to(np.asarray(sigma_near, float), (3,)).tolist(),
              "sigma_far_mm": np.broadcast_to(np.asarray(sigma_far, float), (3,)).tolist(),
              "weight": np.broadcast_to(np.asarray(weight, float), (3,)).tolist()}
    src = _source(profile) if profile is not None else {}
    depth_sigma = float(max(np.max(params["sigma_near_mm"]), np.max(params["sigma_far_mm"])))  # supplement E
    k = Kernel(cell_mm, a[:, None, :], np.ones((3, 1)), "artist", params, src, depth_sigma)
    if match_energy and profile is not None:
        k = k.normalised(profile.discretize_2d(cell_mm, n).sum(axis=(0, 1)))
        k.params["energy"] = "matched to the profile's ||Rd||_1"
    return k
