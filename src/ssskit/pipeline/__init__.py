"""The pipeline: from a scene and one frozen settings tree to rendered frames and their errors, and the
kernel evaluations on test signals.

* :func:`render` (:mod:`.render`): the pass :class:`RenderSettings` names (``pass_``, one of
  :data:`PASSES`) on a built-in scene, a G-buffer file or a GBuffer, with its ground truths and metrics:
  the separable pass (:class:`RenderResult`), the Burley pass (:mod:`.burley_frame`,
  :class:`BurleyResult`) or the adaptive run over frames (:mod:`.adaptive`, :class:`AdaptiveResult`);
  what the passes share (the scene's plan, the G-buffer, the ground truths): :mod:`.frame`;
* :func:`evaluate` (:mod:`.evaluate`): kernel approximations against the exact 2D convolution on
  test signals (paper Fig. 7, supplement S.3 and S.5).
"""

from .adaptive import AdaptiveFrame, AdaptiveResult, render_adaptive
from .burley_frame import BurleyResult, render_burley
from .evaluate import FIG7_METHODS, Evaluation, evaluate, evaluation_grid
from .render import RenderResult, plan, plan_render, render, render_separable
from .settings import PASSES, AdaptivePass, BurleyPass, RenderSettings, SeparablePass

__all__ = [
    "FIG7_METHODS",
    "PASSES",
    "AdaptiveFrame",
    "AdaptivePass",
    "AdaptiveResult",
    "BurleyPass",
    "BurleyResult",
    "Evaluation",
    "RenderResult",
    "RenderSettings",
    "SeparablePass",
    "evaluate",
    "evaluation_grid",
    "plan",
    "plan_render",
    "render",
    "render_adaptive",
    "render_burley",
    "render_separable",
]
