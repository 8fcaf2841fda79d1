"""Simulated profiles as :class:`~ssskit.profiles.base.RadialProfile` s: one channel
(:class:`MonteCarloProfile`) and a material's three (:func:`montecarlo_rgb`)."""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...materials import CHANNELS, LayeredMaterial, Material
from ..base import RadialProfile, RGBProfile
from .config import DEFAULT_PHOTONS
from .result import MCResult
from .sweep import simulate_material


class MonteCarloProfile(RadialProfile):
    """A simulated profile as a RadialProfile over the regular bins: R(r) constant on each annulus
    (MCML's bins), so the energy within rho is linear in rho^2 inside a bin.

    MCML's last bin collects every photon escaping beyond the grid; it is no density, so the result
    keeps it out of ``rd`` (:mod:`.result`): eval() is 0 beyond the grid, total_rd() is the energy of
    the regular bins (``result.total_rd_in_grid``), and ``overflow`` (= result.total_rd -
    total_rd()) says how much escaped beyond the grid; :meth:`total_rd_with_overflow` is MCML's Rd.
    """

    model = "montecarlo"

    def __init__(self, result: MCResult) -> None:
        self.result = result
        dr = result.config.dr_mm
        self.dr = dr
        rd = result.rd
        self.rd = rd
        self.edges = np.arange(rd.shape[0] + 1) * dr
        # energy per bin, exactly W_i / N (inverting the 2 pi r_i dr normalisation)
        energy = rd * 2.0 * np.pi * result.r_mm * dr
        self._total = float(energy.sum())
        self.overflow = float(result.overflow)
        # S at the bin edges: energy outside edge k (within the grid)
        self._outside = np.concatenate([np.cumsum(energy[::-1])[::-1], [0.0]])
        self._energy = energy

    def total_rd_with_overflow(self) -> float:
        """All diffusely reflected light, the grid's and beyond it (MCML's Rd)."""
        return float(self.result.total_rd)

    def totals(self) -> dict[str, float]:
        """``total_Rd`` with the overflow (MCML's Rd, as in ``ssskit simulate``'s JSON), ``total_Rd_in_grid`` (what
        R(r) integrates to, :meth:`total_rd`) and the ``overflow`` between them."""
        return {"total_Rd": self.total_rd_with_overflow(), "total_Rd_in_grid": self._total, "overflow": self.overflow}

    def eval(self, r: ArrayLike) -> NDArray[np.float64]:
        r = self.radii(r)
        n = self.rd.shape[0]
        i = np.floor(r / self.dr).astype(np.int64)
        inside = (i >= 0) & (i < n)
        return np.where(inside, self.rd[np.clip(i, 0, n - 1)], 0.0)

    def total_rd(self) -> float:
        return self._total

    def energy_outside(self, rho: ArrayLike) -> NDArray[np.float64]:
        rho = np.asarray(rho, dtype=float)
        n = self.rd.shape[0]
        i = np.clip(np.floor(rho / self.dr).astype(np.int64), 0, n - 1)
        lo = self.edges[i]
        frac = np.clip((rho**2 - lo**2) / (self.edges[i + 1] ** 2 - lo**2), 0.0, 1.0)
        out = self._outside[i] - frac * self._energy[i]
        return np.where(rho >= self.edges[-1], 0.0, np.maximum(out, 0.0))

    def length_scale_mm(self) -> float:
        return self.edges[-1] / 32.0

    def params(self) -> dict[str, Any]:
        cfg = self.result.config
        return {"photons": cfg.photons, "seed": cfg.seed, "dr_mm": cfg.dr_mm, "nr": cfg.nr,
                "grid_mm": float(self.edges[-1]),
                "layers": [asdict(l) for l in cfg.layers]}


def montecarlo_rgb(material: Material | LayeredMaterial, photons: int = DEFAULT_PHOTONS, seed: int = 1,
                   **kwargs: Any) -> RGBProfile:
    """An RGBProfile of simulated profiles (cached), usable wherever a profile is.

    ``kwargs`` go to :func:`~ssskit.profiles.montecarlo.simulate_material` (threads, progress,
    resume, restart, use_cache, batch_size, grid_fraction, roughness).
    """
    results = simulate_material(material, "all", photons=photons, seed=seed, **kwargs)
    r, g, b = (MonteCarloProfile(results[ch]) for ch in CHANNELS)
    return RGBProfile((r, g, b), "montecarlo", material.name,
                      {"material": material.to_dict(), "photons": photons, "seed": seed,
                       "grid_fraction": kwargs.get("grid_fraction"), "roughness": kwargs.get("roughness", 0.0)})


__all__ = ["MonteCarloProfile", "montecarlo_rgb"]
