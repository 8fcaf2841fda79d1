"""The result of one MCML simulation, assembled from per-batch tallies (shared by both engines).

Normalisation (as MCML's SumScaleResult): Rd(r_i) = W_i / (2 pi r_i dr N) with r_i = (i + 1/2) dr
the bin centre and W_i the weight escaping in annulus i (the last bin also collects everything
beyond it); totals are weight sums / N. Standard errors use the batch method: the spread of
per-batch means (:func:`batch_stats`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .config import MCConfig

if TYPE_CHECKING:
    from .profile import MonteCarloProfile


@dataclass
class MCResult:
    """Tallies of one simulation (one channel). Lengths mm, Rd mm^-2; shapes (nr,) for
    ``r_mm`` (bin centres), ``rd`` and ``rd_se``; totals are fractions of the incident light."""

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
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def photons_per_second(self) -> float:
        return self.photons / self.seconds if self.seconds > 0 else float("inf")

    def profile(self) -> MonteCarloProfile:
        """This result as a :class:`~ssskit.profiles.montecarlo.MonteCarloProfile`."""
        from .profile import MonteCarloProfile

        return MonteCarloProfile(self)

    def to_dict(self) -> dict[str, Any]:
        return {
            "Rd": self.rd.tolist(),
            "Rd_se": self.rd_se.tolist(),
            "total_Rd": self.total_rd,
            "total_Rd_se": self.total_rd_se,
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
                    extra: dict[str, Any] | None = None) -> MCResult:
    """An :class:`MCResult` from an engine's per-batch tallies over all of ``cfg``'s batches.

    bins: (cfg.n_batches, cfg.nr) escaping weight per radial bin; totals: (cfg.n_batches, 3)
    weight sums [diffusely reflected, transmitted, absorbed]; seconds: the simulation's run time.
    """
    sizes = cfg.batch_sizes()
    if bins.shape != (sizes.shape[0], cfg.nr) or totals.shape != (sizes.shape[0], 3):
        raise ValueError(f"tallies of shape {bins.shape} and {totals.shape} do not match the configuration's "
                         f"{sizes.shape[0]} batches and {cfg.nr} bins")
    r_mm = (np.arange(cfg.nr) + 0.5) * cfg.dr_mm
    area = 2.0 * np.pi * r_mm * cfg.dr_mm
    mean_bins, se_bins = batch_stats(bins, sizes)
    mean_tot, se_tot = batch_stats(totals, sizes)
    return MCResult(
        config=cfg, r_mm=r_mm, rd=mean_bins / area, rd_se=se_bins / area,
        total_rd=float(mean_tot[0]), total_rd_se=float(se_tot[0]), tt=float(mean_tot[1]), tt_se=float(se_tot[1]),
        absorbed=float(mean_tot[2]), absorbed_se=float(se_tot[2]), rsp=cfg.specular_reflectance(), seconds=seconds,
        photons=cfg.photons, extra=dict(extra or {}),
    )


__all__ = ["MCResult", "assemble_result", "batch_stats"]
