"""The pipeline: from a scene and frozen settings to a rendered frame and its errors, and the kernel
evaluations on test signals.

* :func:`render` (:mod:`.render`): one frame of screen-space separable SSS of a built-in scene, a
  G-buffer file or a GBuffer, under :class:`RenderSettings`, with its ground truths and metrics
  (:class:`RenderResult`);
* :func:`evaluate` (:mod:`.evaluate`): kernel approximations against the exact 2D convolution on
  test signals (paper Fig. 7, supplement S.3 and S.5).
"""

from .evaluate import FIG7_METHODS, Evaluation, evaluate, evaluation_grid
from .render import RenderResult, plan_render, render
from .settings import RenderSettings

__all__ = [
    "FIG7_METHODS",
    "Evaluation",
    "RenderResult",
    "RenderSettings",
    "evaluate",
    "evaluation_grid",
    "plan_render",
    "render",
]
