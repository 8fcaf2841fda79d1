"""Settings of the screen-space separable pass, as a frozen dataclass (TOML/JSON via ssskit.settings)."""

from __future__ import annotations

from dataclasses import dataclass

from ..backends import BACKENDS, DEFAULT_BACKEND, DEPTH_MODES
from ..quantities import FRACTION, FRAME, SEED, Choice
from ..settings import Settings, setting


@dataclass(frozen=True)
class PassSettings(Settings):
    """How the separable pass runs (separable-SSS paper section 6, supplement E).

    ``jitter``: jitter radius as a fraction of the kernel size, in [0, 1] (paper: 0.1,
    0.3 for close-ups); ``depth_mode``: gaussian, follow, none, or None for the kernel's default
    (gaussian for the two-Gaussian model, follow otherwise); ``frame`` and ``seed`` key the
    per-pixel jitter rotation; ``backend``: a name from :data:`ssskit.backends.BACKENDS`.
    """

    jitter: float = setting(FRACTION, 0.1)
    depth_mode: str | None = setting(Choice("depth_mode", DEPTH_MODES), None, optional=True)
    frame: int = setting(FRAME, 0)
    seed: int = setting(SEED, 0)
    backend: str = setting(Choice("backend", BACKENDS.names), DEFAULT_BACKEND)
