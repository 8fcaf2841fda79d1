"""The interface every 1D distribution in ssskit exposes (DESIGN: eval / pdf / sample / cdf / invert).

* ``eval(x)``: the unnormalised target function in the distribution's measure;
* ``pdf(x)``: the normalised density in that measure (stated by ``measure``);
* ``sample(u)``: maps uniform u in [0, 1) to a sample (inverse-CDF, so it is deterministic in u);
* ``cdf(x)`` and ``invert(x)``: P(X <= x), and the inverse of ``sample`` (u with sample(u) = x).
  For inverse-CDF samplers the two coincide; for approximate samplers (Xie 2020 Eq. 21) ``invert``
  inverts the approximation while ``cdf`` is the CDF of the samples it produces.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..quantities import Quantity

#: what ``sample`` takes: uniform variates, finite and in [0, 1] (each sampler checks them as it takes them)
UNIFORM = Quantity("uniform variates", 0.0, 1.0, "", "what a sampler maps to a sample")


class Distribution(ABC):
    """A continuous 1D distribution on ``support`` with the measure named in ``measure``."""

    measure: str = "per unit length"
    support: tuple[float, float] = (0.0, np.inf)

    @abstractmethod
    def eval(self, x: ArrayLike) -> NDArray[np.float64]: ...

    @abstractmethod
    def pdf(self, x: ArrayLike) -> NDArray[np.float64]: ...

    @abstractmethod
    def sample(self, u: ArrayLike) -> NDArray[np.float64]: ...

    @abstractmethod
    def cdf(self, x: ArrayLike) -> NDArray[np.float64]: ...

    def invert(self, x: ArrayLike) -> NDArray[np.float64]:
        """u with sample(u) = x; for exact inverse-CDF samplers this is the CDF."""
        return self.cdf(x)
