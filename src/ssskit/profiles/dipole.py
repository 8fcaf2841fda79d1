"""The classical dipole diffusion profile of Jensen et al. 2001 ([JMLH01] in the separable-SSS
supplement, which takes its 11 materials from that paper).

With sigma_s' = sigma_s (1 - g), sigma_t' = sigma_a + sigma_s', alpha' = sigma_s' / sigma_t',
sigma_tr = sqrt(3 sigma_a sigma_t'), z_r = 1 / sigma_t', z_v = z_r (1 + 4 A_b / 3),
A_b = (1 + F_dr) / (1 - F_dr), F_dr = -1.440 / eta^2 + 0.710 / eta + 0.668 + 0.0636 eta:

    R_d(r) = alpha' / (4 pi) * sum_{z in (z_r, z_v)} z (sigma_tr d_z + 1) exp(-sigma_tr d_z) / d_z^3,
    d_z = sqrt(r^2 + z^2)                                            [JMLH01, Sec. 2.4, dipole R_d(r)]

    total R_d = alpha' / 2 (1 + exp(-4/3 A_b sqrt(3 (1 - alpha')))) exp(-sqrt(3 (1 - alpha')))
                                                                      [JMLH01, total diffuse reflectance]

The energy outside radius rho follows from the antiderivative
d/dd [exp(-sigma d) / d] = -(sigma d + 1) exp(-sigma d) / d^2 (with r dr = d dd):

    S(rho) = alpha' / 2 * sum_z z exp(-sigma_tr d_z(rho)) / d_z(rho),

which at rho = 0 gives back the closed-form total (sigma_tr z_r = sqrt(3 (1 - alpha'))).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ProfileError
from ..quantities import ANISOTROPY, COEFFICIENT, checks
from .base import RadialProfile
from .domain import DIPOLE_ETA, TRANSPORT_MFP


def fresnel_diffuse_reflectance(eta: float) -> float:
    """Diffuse Fresnel reflectance F_dr(eta) = -1.440/eta^2 + 0.710/eta + 0.668 + 0.0636 eta.

    The rational fit used by [JMLH01] (after Egan and Hilgeman); eta is the relative index.
    """
    return -1.440 / eta**2 + 0.710 / eta + 0.668 + 0.0636 * eta


class DipoleProfile(RadialProfile):
    """One channel of the [JMLH01] dipole. Coefficients in mm^-1, eta relative to the outside."""

    model = "dipole"

    @checks(ProfileError, sigma_a=(COEFFICIENT, "the dipole's sigma_a"), sigma_s=(COEFFICIENT, "the dipole's sigma_s"),
            g=(ANISOTROPY, "the dipole's g"), eta=(DIPOLE_ETA, "the dipole model's relative index eta"))
    def __init__(self, sigma_a: float, sigma_s: float, g: float = 0.0, eta: float = 1.3) -> None:
        self.sigma_a, self.sigma_s, self.g, self.eta = float(sigma_a), float(sigma_s), float(g), float(eta)
        sigma_s_r = sigma_s * (1.0 - g)
        self.sigma_t_r = sigma_a + sigma_s_r
        self.z_r = 1.0 / self.sigma_t_r if self.sigma_t_r > 0 else math.inf  # (sigma_t' = 0: an infinite path)
        TRANSPORT_MFP.check(self.z_r, "the dipole model's transport mean free path 1/sigma_t'", ProfileError)
        self.alpha_r = sigma_s_r / self.sigma_t_r
        self.sigma_tr = math.sqrt(3.0 * sigma_a * self.sigma_t_r)
        f_dr = fresnel_diffuse_reflectance(eta)
        self.a_boundary = (1.0 + f_dr) / (1.0 - f_dr)
        self.z_v = self.z_r * (1.0 + 4.0 / 3.0 * self.a_boundary)

    def eval(self, r: ArrayLike) -> NDArray[np.float64]:
        r2 = np.square(self.radii(r))
        out = np.zeros_like(r2)
        for z in (self.z_r, self.z_v):
            d = np.sqrt(r2 + z * z)
            out += z * (self.sigma_tr * d + 1.0) * np.exp(-self.sigma_tr * d) / d**3
        return self.alpha_r / (4.0 * np.pi) * out

    def total_rd(self) -> float:
        s = math.sqrt(3.0 * (1.0 - self.alpha_r))
        return 0.5 * self.alpha_r * (1.0 + math.exp(-4.0 / 3.0 * self.a_boundary * s)) * math.exp(-s)

    def energy_outside(self, rho: ArrayLike) -> NDArray[np.float64]:
        r2 = np.square(np.asarray(rho, dtype=float))
        out = np.zeros_like(r2)
        for z in (self.z_r, self.z_v):
            d = np.sqrt(r2 + z * z)
            out += z * np.exp(-self.sigma_tr * d) / d
        return 0.5 * self.alpha_r * out

    def length_scale_mm(self) -> float:
        return 1.0 / self.sigma_tr if self.sigma_tr > 0 else self.z_v

    def params(self) -> dict[str, float]:
        return {"sigma_a": self.sigma_a, "sigma_s": self.sigma_s, "g": self.g, "eta": self.eta}
