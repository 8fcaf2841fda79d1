"""Distributions with eval / pdf / sample / cdf / invert, and Burley radius sampling (Xie 2020)."""

from .base import Distribution, check_uniform
from .burley import XIE_C, BurleyRadial, BurleyRadialApprox, fit_xie_c, xie_cdf_error, xie_g
from .radial import ProfileRadial

__all__ = [
    "BurleyRadial",
    "BurleyRadialApprox",
    "Distribution",
    "ProfileRadial",
    "XIE_C",
    "check_uniform",
    "fit_xie_c",
    "xie_cdf_error",
    "xie_g",
]
