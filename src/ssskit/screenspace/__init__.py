"""Screen-space SSS: cameras, G-buffers, pass settings, the separable pass (separable-SSS paper
section 6, supplement E), the Burley Monte Carlo pass (Xie 2020 Sec. 4.2, 5) and its variance-guided
adaptive sample counts (Xie 2020 Sec. 4.1, :mod:`.adaptive`), run over frames by one loop (:mod:`.frames`). Each pass builds a plan that any backend
(:mod:`ssskit.backends`) executes."""

from .adaptive import AdaptiveSettings, circle_scenario, new_history, reproject_history, sample_counts, update_history
from .burley import BurleyParams, BurleySettings, burley_sss
from .camera import Camera, motion_vectors
from .frames import AdaptiveFrames, Frame, FrameRun, adaptive_frames, run_frames
from .gbuffer import LAYERS, GBuffer, load_gbuffer
from .separable import default_depth_mode, filter_arrays, plan_for, separable_sss
from .settings import PassSettings

__all__ = [
    "AdaptiveFrames",
    "AdaptiveSettings",
    "BurleyParams",
    "BurleySettings",
    "Camera",
    "Frame",
    "FrameRun",
    "GBuffer",
    "LAYERS",
    "PassSettings",
    "adaptive_frames",
    "burley_sss",
    "circle_scenario",
    "default_depth_mode",
    "filter_arrays",
    "load_gbuffer",
    "motion_vectors",
    "new_history",
    "plan_for",
    "reproject_history",
    "run_frames",
    "sample_counts",
    "separable_sss",
    "update_history",
]
