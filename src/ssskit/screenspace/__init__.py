"""Screen-space SSS: G-buffers and the separable pass (separable-SSS paper section 6, supplement E)."""

from .gbuffer import Camera, GBuffer, GBufferError, load_gbuffer, motion_vectors
from .separable import (
    BACKENDS,
    DEPTH_MODES,
    PassError,
    default_depth_mode,
    filter_arrays,
    jitter_angles,
    region_depth_mm,
    separable_sss,
)

__all__ = [
    "BACKENDS",
    "Camera",
    "DEPTH_MODES",
    "GBuffer",
    "GBufferError",
    "PassError",
    "default_depth_mode",
    "filter_arrays",
    "jitter_angles",
    "load_gbuffer",
    "motion_vectors",
    "region_depth_mm",
    "separable_sss",
]
