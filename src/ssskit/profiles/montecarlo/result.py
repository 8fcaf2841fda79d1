"""The result of one MCML simulation, assembled from per-batch tallies (shared by both engines).

Normalisation (as MCML's SumScaleResult): Rd(r_i) = W_i / (2 pi r_i dr N) with r_i = (i + 1/2) dr
the bin centre and W_i the weight escaping in annulus i; totals are weight sums / N. Standard errors
use the batch method: the spread of per-batch means (:func:`batch_stats`).

MCML's last radial bin collects every photon escaping beyond the grid: it is no density, so it is
kept out of ``rd`` (which holds the nr - 1 regular annuli) and reported as ``overflow``. Two totals,
named apart everywhere: ``total_rd`` (all diffusely reflected light, MCML's Rd) and
``total_rd_in_grid`` = total_rd - overflow = 2 pi sum R(r_i) r_i dr (what the profile integrates to).

The exit-direction tally (``exit_rd``, :data:`N_EXIT_BINS` bins uniform in cos^2 theta outside, of
equal projected solid angle pi / N): the radiance leaving a uniformly lit surface in bin k, for
irradiance E, is L_k = E N exit_rd[k] / pi, so ``radiance_factor()`` = N exit_rd / total_rd is 1
for a Lambertian exit and says how far the material's exit is from one (MCML's Rd_a, other bins).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .config import N_EXIT_BINS, MCConfig


@dataclass
class MCResult:
    """Tallies of one simulation (one channel). Lengths mm, Rd mm^-2; shapes (nr - 1,) for ``r_mm``
    (centres of the regular bins), ``rd`` and ``rd_se``; totals are fractions of the incident light:
    ``total_rd`` all diffusely reflected light, ``overflow`` the part escaping beyond the grid
    (MCML's last bin), ``total_rd_in_grid`` the rest; ``exit_rd`` (N_EXIT_BINS,) the reflected
    light per exit-direction bin (module docstring)."""

    config: MCConfig
    r_mm: np.ndarray
    rd: np.ndarray
    rd_se: np.ndarray
    total_rd: float
    total_rd_se: float
    tt: float
    tt_se: float
    absorbed: float
    absorbed_se: float
    rsp: float
    seconds: float
    photons: int
    overflow: float = 0.0
    overflow_se: float = 0.0
    exit_rd: np.ndarray = field(default_factory=lambda: np.full(N_EXIT_BINS, np.nan))
    exit_rd_se: np.ndarray = field(default_factory=lambda: np.full(N_EXIT_BINS, np.nan))
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def total_rd_in_grid(self) -> float:
        """The diffuse reflectance inside the grid, total_rd - overflow = 2 pi sum_i R(r_i) r_i dr."""
        return self.total_rd - self.overflow

    @property
    def grid_mm(self) -> float:
        """Where the regular bins end (mm)."""
        return (self.config.nr - 1) * self.config.dr_mm

    def radiance_factor(self) -> np.ndarray:
        """(N_EXIT_BINS,): radiance leaving a uniformly lit surface per exit-direction bin, relative to
        a Lambertian exit of the same total: N exit_rd / total_rd (1 for Lambertian; the last bin is
        within 12.9 degrees of the normal)."""
        return N_EXIT_BINS * self.exit_rd / self.total_rd

    def radiance_factor_at(self, mu: float, bins: int = 4) -> tuple[float, float]:
        """(factor, standard error): the radiance factor at exit cosine ``mu`` near the normal, from a
        straight line in cos^2 fitted (weighted by the standard errors) through the last ``bins`` exit
        bins at their centres. A single bin averages 12.9 degrees, over which the factor of a
        strongly scattering medium changes by ~1%; a camera looking along the normal sits at its edge.
        """
        if not (0.0 < mu <= 1.0) or not (2 <= bins <= N_EXIT_BINS):
            raise ValueError(f"need 0 < mu <= 1 and 2 <= bins <= {N_EXIT_BINS}, got {mu!r}, {bins!r}")
        f = self.radiance_factor()[-bins:]
        se = (N_EXIT_BINS * self.exit_rd_se / self.total_rd)[-bins:]
        c = ((np.arange(N_EXIT_BINS) + 0.5) / N_EXIT_BINS)[-bins:]
        w = 1.0 / np.maximum(se, 1e-300) ** 2
        a = np.stack([np.ones(bins), c], axis=1)
        cov = np.linalg.inv(a.T @ (a * w[:, None]))
        coef = cov @ (a.T @ (w * f))
        x = np.array([1.0, mu * mu])
        return float(x @ coef), float(np.sqrt(x @ cov @ x))

    @property
    def photons_per_second(self) -> float:
        return self.photons / self.seconds if self.seconds > 0 else float("inf")

    def to_dict(self) -> dict[str, Any]:
        return {
            "Rd": self.rd.tolist(),
            "Rd_se": self.rd_se.tolist(),
            "total_Rd": self.total_rd,
            "total_Rd_se": self.total_rd_se,
            "total_Rd_in_grid": self.total_rd_in_grid,
            "overflow": self.overflow,
            "overflow_se": self.overflow_se,
            "grid_mm": self.grid_mm,
            "exit_Rd": self.exit_rd.tolist(),
            "radiance_factor_normal": float(self.radiance_factor()[-1]),
            "Tt": self.tt,
            "Tt_se": self.tt_se,
            "absorbed": self.absorbed,
            "absorbed_se": self.absorbed_se,
            "Rsp": self.rsp,
        }


def batch_stats(values: np.ndarray, sizes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean per photon and its standard error from per-batch weight sums (batch method).

    values: (B, ...) weight sums per batch; sizes: (B,) photons per batch. The mean is
    sum(values) / N; the standard error is the spread of the per-batch means, weighted by batch
    size, with B / (B - 1) for the degrees of freedom (NaN for a single batch).
    """
    n = sizes.sum()
    mean = values.sum(axis=0) / n
    b = sizes.shape[0]
    if b < 2:
        return mean, np.full_like(mean, np.nan)
    shape = (-1,) + (1,) * (values.ndim - 1)
    per = values / sizes.reshape(shape)
    wts = (sizes / n).reshape(shape)
    var = np.sum(wts**2 * (per - mean) ** 2, axis=0) * b / (b - 1)
    return mean, np.sqrt(var)


def assemble_result(cfg: MCConfig, bins: np.ndarray, totals: np.ndarray, seconds: float,
                    extra: dict[str, Any] | None = None, rsp: float | None = None) -> MCResult:
    """An :class:`MCResult` from an engine's per-batch tallies over all of ``cfg``'s batches.

    bins: (cfg.n_batches, cfg.nr) escaping weight per radial bin, the last one for every radius beyond
    the grid; totals: (cfg.n_batches, 3 + N_EXIT_BINS) weight sums [diffusely reflected, transmitted,
    absorbed, reflected per exit-direction bin...]; seconds: the simulation's run time; rsp: the
    specular reflectance if not the smooth surface's ``cfg.specular_reflectance()``.
    """
    sizes = cfg.batch_sizes()
    if bins.shape != (sizes.shape[0], cfg.nr) or totals.shape != (sizes.shape[0], 3 + N_EXIT_BINS):
        raise ValueError(f"tallies of shape {bins.shape} and {totals.shape} do not match the configuration's "
                         f"{sizes.shape[0]} batches, {cfg.nr} bins and {N_EXIT_BINS} exit bins")
    n = cfg.nr - 1  # the regular bins; bin n collects everything beyond them
    r_mm = (np.arange(n) + 0.5) * cfg.dr_mm
    area = 2.0 * np.pi * r_mm * cfg.dr_mm
    mean_bins, se_bins = batch_stats(bins, sizes)
    mean_tot, se_tot = batch_stats(totals, sizes)
    return MCResult(
        config=cfg, r_mm=r_mm, rd=mean_bins[:n] / area, rd_se=se_bins[:n] / area,
        total_rd=float(mean_tot[0]), total_rd_se=float(se_tot[0]), tt=float(mean_tot[1]), tt_se=float(se_tot[1]),
        absorbed=float(mean_tot[2]), absorbed_se=float(se_tot[2]), rsp=cfg.specular_reflectance() if rsp is None else float(rsp),
        seconds=seconds,
        photons=cfg.photons, overflow=float(mean_bins[n]), overflow_se=float(se_bins[n]),
        exit_rd=mean_tot[3:].copy(), exit_rd_se=se_tot[3:].copy(), extra=dict(extra or {}),
    )


__all__ = ["MCResult", "assemble_result", "batch_stats"]
