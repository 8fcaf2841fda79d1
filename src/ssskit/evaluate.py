"""Moved to :mod:`ssskit.pipeline.evaluate`; this alias stays until every caller imports it from there."""

from .pipeline.evaluate import FIG7_METHODS, Evaluation, evaluate, evaluation_grid

__all__ = ["FIG7_METHODS", "Evaluation", "evaluate", "evaluation_grid"]
