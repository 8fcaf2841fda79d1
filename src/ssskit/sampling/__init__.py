"""Distributions with eval / pdf / sample / cdf / invert, Burley radius sampling (Xie 2020), and
the 1D taps of the separable screen-space pass (separable-SSS paper section 6)."""

from .base import UNIFORM, Distribution
from .burley_radius import XIE_C, BurleyRadial, BurleyRadialApprox, fit_xie_c, xie_cdf_error, xie_g
from .radial import ProfileRadial
from .taps import TAP_METHODS, SeparableTaps, make_taps

__all__ = [
    "BurleyRadial",
    "BurleyRadialApprox",
    "Distribution",
    "ProfileRadial",
    "SeparableTaps",
    "TAP_METHODS",
    "UNIFORM",
    "XIE_C",
    "fit_xie_c",
    "make_taps",
    "xie_cdf_error",
    "xie_g",
]
