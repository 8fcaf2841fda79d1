"""Screen-space SSS: cameras, G-buffers, pass settings, the separable pass (separable-SSS paper
section 6, supplement E) and the Burley Monte Carlo pass (Xie 2020 Sec. 4.2, 5). Each pass builds a
plan that any backend (:mod:`ssskit.backends`) executes."""

from .burley import BurleyParams, BurleySettings, burley_sss
from .camera import Camera, motion_vectors
from .gbuffer import LAYERS, GBuffer, load_gbuffer
from .separable import default_depth_mode, filter_arrays, plan_for, separable_sss
from .settings import PassSettings

__all__ = [
    "BurleyParams",
    "BurleySettings",
    "Camera",
    "GBuffer",
    "LAYERS",
    "PassSettings",
    "burley_sss",
    "default_depth_mode",
    "filter_arrays",
    "load_gbuffer",
    "motion_vectors",
    "plan_for",
    "separable_sss",
]
