"""The shared interface of radial diffuse reflectance profiles R(r).

A :class:`RadialProfile` is one channel: R(r) in mm^-2 for r in mm, a density per unit *area*
of the surface. Its energy is measured with the radial measure 2 pi r dr:

    total_rd = 2 pi Int_0^inf R(r) r dr,    E(rho) = 2 pi Int_0^rho R(r) r dr,
    S(rho) = total_rd - E(rho)            (energy outside radius rho).

Each model supplies ``eval`` and a numerically stable ``energy_outside`` (closed forms where they
exist); the rest -- energy fractions, radii holding a fraction of the energy and the 2D cell
integrals -- is shared. :class:`RGBProfile` bundles three channels (R, G, B).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ProfileError
from ..materials import CHANNELS
from ..quantities import Quantity

#: a profile's radii (mm) and a share of its energy (within a radius): the numbers every profile takes
RADIUS_MM = Quantity("radii", 0.0, math.inf, "mm", "distances from the point where the light enters", hi_open=True)
ENERGY_FRACTION = Quantity("energy fraction", 0.0, 1.0, "", "a share of the profile's energy; all of it lies only "
                           "at an infinite radius", hi_open=True)


class RadialProfile(ABC):
    """One channel's radially symmetric diffuse reflectance profile R(r) (mm^-2, r in mm)."""

    model: str = "profile"

    @abstractmethod
    def eval(self, r: ArrayLike) -> NDArray[np.float64]:
        """R(r) in mm^-2 (per unit area), vectorised over r >= 0 (mm); a ProfileError for a negative or
        non-finite radius (:meth:`radii`)."""

    @staticmethod
    def radii(r: ArrayLike) -> NDArray[np.float64]:
        """``r`` as a float64 array of radii, or a ProfileError if one is negative, NaN or infinite (R(r) is
        defined for distances 0 <= r < inf; every :meth:`eval` takes its radii through here)."""
        arr = np.asarray(r, dtype=float)
        if arr.size and not (arr.min() >= 0.0 and arr.max() < np.inf):  # (a NaN fails the first: min is NaN)
            RADIUS_MM.check_array(arr, "a profile's radii", ProfileError)
        return arr

    @abstractmethod
    def total_rd(self) -> float:
        """Total diffuse reflectance 2 pi Int_0^inf R(r) r dr (dimensionless)."""

    @abstractmethod
    def energy_outside(self, rho: ArrayLike) -> NDArray[np.float64]:
        """S(rho) = 2 pi Int_rho^inf R(r) r dr, computed without cancellation for large rho."""

    @abstractmethod
    def params(self) -> dict[str, Any]:
        """The parameters that define this channel's profile (for reports and provenance)."""

    def totals(self) -> dict[str, float]:
        """The totals every JSON reports: ``total_Rd``, all diffusely reflected light (MCML's Rd; for a closed-form
        profile its integral to infinity, :meth:`total_rd`), one meaning in every command's JSON. A profile that
        leaves light out of R(r) (Monte Carlo beyond its grid) adds its other totals under their own names."""
        return {"total_Rd": float(self.total_rd())}

    def energy_within(self, rho: ArrayLike) -> NDArray[np.float64]:
        """E(rho) = 2 pi Int_0^rho R(r) r dr."""
        return self.total_rd() - self.energy_outside(rho)

    def radial_pdf(self, r: ArrayLike) -> NDArray[np.float64]:
        """Density of the radius per unit radius: p(r) = 2 pi r R(r) / total_rd (mm^-1)."""
        r = np.asarray(r, dtype=float)
        with np.errstate(invalid="ignore"):
            out = 2.0 * np.pi * r * self.eval(r) / self.total_rd()
        return np.where(r > 0, out, self._pdf_at_zero())

    def _pdf_at_zero(self) -> float:
        """lim_{r->0} 2 pi r R(r) / total_rd; 0 for profiles finite at r = 0."""
        return 0.0

    def radius_at_fraction(self, fraction: ArrayLike) -> NDArray[np.float64]:
        """The radius rho (mm) with E(rho) = fraction * total_rd, for 0 <= fraction < 1.

        Solved on S(rho) = (1 - fraction) total_rd, which keeps precision near fraction -> 1:
        a bracket found by doubling, then bisection to relative width 1e-14.
        """
        f = ENERGY_FRACTION.check_array(fraction, error=ProfileError)
        total = self.total_rd()
        target = (1.0 - f) * total
        scale = self.length_scale_mm()
        hi = np.full(f.shape, scale)
        for _ in range(200):
            short = self.energy_outside(hi) > target
            if not np.any(short):
                break
            hi = np.where(short, hi * 2.0, hi)
        lo = np.zeros(f.shape)
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            above = self.energy_outside(mid) > target
            lo = np.where(above, mid, lo)
            hi = np.where(above, hi, mid)
            if np.all(hi - lo <= 1e-14 * hi):
                break
        out = 0.5 * (lo + hi)
        return np.where(f == 0, 0.0, out)

    def length_scale_mm(self) -> float:
        """A characteristic length of the profile (mm), used to start searches."""
        return 1.0

    def discretize_2d(self, cell_mm: float, n: int) -> NDArray[np.float64]:
        """Cell integrals of R over an n x n grid of square cells, centred on the origin.

        See :func:`ssskit.profiles.discretize.cell_integrals`.
        """
        from .discretize import cell_integrals

        return cell_integrals(self, cell_mm, n)


@dataclass(frozen=True)
class RGBProfile:
    """Three channel profiles (R, G, B) with their provenance."""

    channels: tuple[RadialProfile, RadialProfile, RadialProfile]
    model: str
    name: str = ""
    provenance: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        if len(self.channels) != 3:
            raise ProfileError(f"an RGB profile needs 3 channels, got {len(self.channels)}")

    def eval(self, r: ArrayLike) -> NDArray[np.float64]:
        """R(r) per channel: shape r.shape + (3,), mm^-2."""
        return np.stack([c.eval(r) for c in self.channels], axis=-1)

    def total_rd(self) -> NDArray[np.float64]:
        """Total diffuse reflectance per channel, shape (3,)."""
        return np.array([c.total_rd() for c in self.channels])

    def radius_at_fraction(self, fraction: float) -> NDArray[np.float64]:
        """Per channel, the radius (mm) holding ``fraction`` of that channel's energy; shape (3,)."""
        return np.array([float(c.radius_at_fraction(fraction)) for c in self.channels])

    def discretize_2d(self, cell_mm: float, n: int) -> NDArray[np.float64]:
        """Cell integrals of each channel over an n x n grid centred on the origin: (n, n, 3)."""
        return np.stack([c.discretize_2d(cell_mm, n) for c in self.channels], axis=-1)

    def to_dict(self, r_mm: ArrayLike) -> dict[str, Any]:
        """The JSON shape of ``ssskit profile --json``: r_mm and per channel Rd and the totals (:meth:`RadialProfile.totals`)."""
        r_mm = np.asarray(r_mm, dtype=float)
        values = self.eval(r_mm)
        return {
            "model": self.model,
            "name": self.name,
            "r_mm": _finite_list(r_mm),
            "channels": {
                ch: {
                    "Rd": _finite_list(values[:, i]),
                    **self.channels[i].totals(),
                    "params": self.channels[i].params(),
                }
                for i, ch in enumerate(CHANNELS)
            },
        }


def _finite_list(a: ArrayLike) -> list[float | None]:
    """JSON has no infinity: non-finite values (R(0) of 1/r profiles) become null."""
    return [float(v) if math.isfinite(v) else None for v in np.asarray(a, dtype=float).ravel()]
