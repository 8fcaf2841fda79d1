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

The transmitted light of a finite slab has the same two tallies (MCML's Tt_r and Tt_a [WJZ95]): ``tt_r``
(mm^-2, Tt(r_i) = W_i / (2 pi r_i dr N) over the regular annuli, the light leaving the bottom face at
radius r from the beam's axis; ``tt_overflow`` beyond the grid) and ``exit_tt`` (the transmitted
light per exit-direction bin, the same bins as ``exit_rd``). A semi-infinite medium transmits nothing:
both are zero.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...quantities import Quantity, checks
from .config import N_EXIT_BINS, MCConfig

#: an exit cosine (the normal itself is the last bin's edge) and a number of exit bins a fit takes
EXIT_COSINE = Quantity("mu", 0.0, 1.0, "", "the cosine of an exit direction", lo_open=True, hi_open=True)
EXIT_BINS = Quantity("bins", 2, N_EXIT_BINS, "", "the exit bins a straight line is fitted through", integer=True)


@dataclass
class MCResult:
    """Tallies of one simulation (one channel). Lengths mm, Rd mm^-2; shapes (nr - 1,) for ``r_mm``
    (centres of the regular bins), ``rd`` and ``rd_se``; totals are fractions of the incident light:
    ``total_rd`` all diffusely reflected light, ``overflow`` the part escaping beyond the grid
    (MCML's last bin), ``total_rd_in_grid`` the rest; ``exit_rd`` (N_EXIT_BINS,) the reflected
    light per exit-direction bin; ``tt_r``, ``tt_r_se`` (nr - 1,), ``tt_overflow`` and ``exit_tt`` the
    same tallies of the transmitted light (module docstring; empty arrays where a stored result predates
    them)."""

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
    tt_r: np.ndarray = field(default_factory=lambda: np.zeros(0))
    tt_r_se: np.ndarray = field(default_factory=lambda: np.zeros(0))
    tt_overflow: float = 0.0
    tt_overflow_se: float = 0.0
    exit_tt: np.ndarray = field(default_factory=lambda: np.full(N_EXIT_BINS, np.nan))
    exit_tt_se: np.ndarray = field(default_factory=lambda: np.full(N_EXIT_BINS, np.nan))

    @property
    def has_transmitted_tallies(self) -> bool:
        """Whether ``tt_r`` and ``exit_tt`` hold the run's tallies (a stored result may predate them)."""
        return self.tt_r.shape == self.rd.shape and bool(np.all(np.isfinite(self.exit_tt)))

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

    @checks(ValueError, mu=EXIT_COSINE.within(hi=1.0), bins=EXIT_BINS)  # type: ignore[arg-type]
    def radiance_factor_at(self, mu: float, bins: int = 4) -> tuple[float, float]:
        """(factor, standard error): the radiance factor at exit cosine ``mu`` near the normal, from a
        straight line in cos^2 fitted (weighted by the standard errors) through the last ``bins`` exit
        bins at their centres. A single bin averages 12.9 degrees, over which the factor of a
        strongly scattering medium changes by ~1%; a camera looking along the normal sits at its edge.
        """
        idx = np.arange(N_EXIT_BINS - bins, N_EXIT_BINS)
        return _line_at(self.radiance_factor(), N_EXIT_BINS * self.exit_rd_se / self.total_rd, idx, mu)

    @checks(ValueError, mu=EXIT_COSINE, bins=EXIT_BINS.within(hi=N_EXIT_BINS - 1))  # type: ignore[arg-type]
    def tt_level_at(self, mu: float, bins: int = 4) -> tuple[float, float]:
        """(level, standard error): the transmitted light's radiance L at exit cosine ``mu`` as pi L / E (E the
        irradiance of the lit face; a Lambertian exit of the whole Tt gives Tt), N exit_tt per bin, from a
        straight line in cos^2 fitted (weighted by the standard errors) through the ``bins`` bins whose centres
        are nearest mu^2, the last bin left out (a normally incident run's unscattered beam leaves along the
        normal, into it): what a camera at exit cosine ``mu`` sees of the light the slab scattered."""
        centres = (np.arange(N_EXIT_BINS - 1) + 0.5) / N_EXIT_BINS
        idx = np.sort(np.argsort(np.abs(centres - mu * mu), kind="stable")[:bins])
        return _line_at(N_EXIT_BINS * self.exit_tt, N_EXIT_BINS * self.exit_tt_se, idx, mu)

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
            "Tt_r": self.tt_r.tolist(),
            "Tt_r_se": self.tt_r_se.tolist(),
            "Tt_overflow": self.tt_overflow,
            "exit_Tt": self.exit_tt.tolist(),
            "absorbed": self.absorbed,
            "absorbed_se": self.absorbed_se,
            "Rsp": self.rsp,
        }


def ring_sums(density: np.ndarray, dr: float, edges: Any, density_se: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray | None]:
    """The fraction of light in each ring [edges[k], edges[k + 1]) mm of a radial density (mm^-2) over
    annuli of width ``dr`` (Rd(r) or Tt(r): bin i covers [i dr, (i + 1) dr), counted in the ring of its
    centre): sum 2 pi r_i dr density_i; with ``density_se``, each ring's standard error from its annuli's in
    quadrature (a photon lands in one annulus: their batch errors are nearly independent)."""
    d = np.asarray(density, float)
    e = np.asarray(edges, float)
    r = (np.arange(d.shape[0]) + 0.5) * dr
    area = 2.0 * np.pi * r * dr
    k = np.searchsorted(e, r, side="right") - 1
    ok = (k >= 0) & (k < e.shape[0] - 1)
    sums = np.bincount(k[ok], weights=(d * area)[ok], minlength=e.shape[0] - 1)
    if density_se is None:
        return sums, None
    var = (np.asarray(density_se, float) * area) ** 2
    return sums, np.sqrt(np.bincount(k[ok], weights=var[ok], minlength=e.shape[0] - 1))


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


def _line_at(values: np.ndarray, ses: np.ndarray, idx: np.ndarray, mu: float) -> tuple[float, float]:
    """(value, standard error) at cos^2 = mu^2 of the straight line in cos^2 through exit bins ``idx`` (at their
    centres), weighted by their standard errors."""
    f, se = values[idx], ses[idx]
    c = (idx + 0.5) / N_EXIT_BINS
    w = 1.0 / np.maximum(se, 1e-300) ** 2
    a = np.stack([np.ones(idx.shape[0]), c], axis=1)
    cov = np.linalg.inv(a.T @ (a * w[:, None]))
    coef = cov @ (a.T @ (w * f))
    x = np.array([1.0, mu * mu])
    return float(x @ coef), float(np.sqrt(x @ cov @ x))


#: values per batch row of ``totals``: [diffusely reflected, transmitted, absorbed], the reflected and the
#: transmitted weight per exit-direction bin
N_TOTALS = 3 + 2 * N_EXIT_BINS


def assemble_result(cfg: MCConfig, bins: np.ndarray, totals: np.ndarray, seconds: float,
                    extra: dict[str, Any] | None = None, rsp: float | None = None, *,
                    tt_bins: np.ndarray) -> MCResult:
    """An :class:`MCResult` from an engine's per-batch tallies over all of ``cfg``'s batches (its callers, the
    engines' runs, make the arrays in these shapes from ``cfg``, or read them back shape-checked: ``run._load_partial``).

    bins, tt_bins: (cfg.n_batches, cfg.nr) diffusely reflected / transmitted weight per radial bin, the
    last one for every radius beyond the grid (a semi-infinite medium's tt_bins all zero);
    totals: (cfg.n_batches, :data:`N_TOTALS`) weight sums [diffusely reflected, transmitted, absorbed,
    reflected per exit-direction bin..., transmitted per exit-direction bin...]; seconds: the simulation's
    run time; rsp: the specular reflectance if not the smooth surface's ``cfg.specular_reflectance()``.
    """
    sizes = cfg.batch_sizes()
    n = cfg.nr - 1  # the regular bins; bin n collects everything beyond them
    r_mm = (np.arange(n) + 0.5) * cfg.dr_mm
    area = 2.0 * np.pi * r_mm * cfg.dr_mm
    mean_bins, se_bins = batch_stats(bins, sizes)
    mean_tt, se_tt = batch_stats(tt_bins, sizes)
    mean_tot, se_tot = batch_stats(totals, sizes)
    e = 3 + N_EXIT_BINS
    return MCResult(
        config=cfg, r_mm=r_mm, rd=mean_bins[:n] / area, rd_se=se_bins[:n] / area,
        total_rd=float(mean_tot[0]), total_rd_se=float(se_tot[0]), tt=float(mean_tot[1]), tt_se=float(se_tot[1]),
        absorbed=float(mean_tot[2]), absorbed_se=float(se_tot[2]), rsp=cfg.specular_reflectance() if rsp is None else float(rsp),
        seconds=seconds,
        photons=cfg.photons, overflow=float(mean_bins[n]), overflow_se=float(se_bins[n]),
        exit_rd=mean_tot[3:e].copy(), exit_rd_se=se_tot[3:e].copy(), extra=dict(extra or {}),
        tt_r=mean_tt[:n] / area, tt_r_se=se_tt[:n] / area, tt_overflow=float(mean_tt[n]),
        tt_overflow_se=float(se_tt[n]), exit_tt=mean_tot[e:].copy(), exit_tt_se=se_tot[e:].copy(),
    )


__all__ = ["MCResult", "N_TOTALS", "assemble_result", "batch_stats", "ring_sums"]
