"""Screen-space SSS: cameras, G-buffers, pass settings and the separable pass (separable-SSS paper
section 6, supplement E). Each pass builds a plan that any backend (:mod:`ssskit.backends`) executes."""

from .camera import Camera, motion_vectors
from .gbuffer import LAYERS, GBuffer, load_gbuffer
from .separable import default_depth_mode, filter_arrays, plan_for, separable_sss
from .settings import PassSettings

__all__ = [
    "Camera",
    "GBuffer",
    "LAYERS",
    "PassSettings",
    "default_depth_mode",
    "filter_arrays",
    "load_gbuffer",
    "motion_vectors",
    "plan_for",
    "separable_sss",
]
