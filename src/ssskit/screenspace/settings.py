"""Settings of the screen-space separable pass, as a frozen dataclass (TOML/JSON via ssskit.settings)."""

from __future__ import annotations

from dataclasses import dataclass

from ..backends import BACKENDS, DEFAULT_BACKEND, DEPTH_MODES
from ..settings import Settings, check_choice, check_float, check_int


@dataclass(frozen=True)
class PassSettings(Settings):
    """How the separable pass runs (separable-SSS paper section 6, supplement E).

    ``jitter``: jitter radius as a fraction of the kernel size, in [0, 1] (paper: 0.1,
    0.3 for close-ups); ``depth_mode``: gaussian, follow, none, or None for the kernel's default
    (gaussian for the two-Gaussian model, follow otherwise); ``frame`` and ``seed`` key the
    per-pixel jitter rotation; ``backend``: a name from :data:`ssskit.backends.BACKENDS`.
    """

    jitter: float = 0.1
    depth_mode: str | None = None
    frame: int = 0
    seed: int = 0
    backend: str = DEFAULT_BACKEND

    def __post_init__(self) -> None:
        object.__setattr__(self, "jitter", check_float("jitter", self.jitter, 0.0, 1.0))
        if self.depth_mode is not None:
            object.__setattr__(self, "depth_mode", check_choice("depth_mode", self.depth_mode, DEPTH_MODES))
        object.__setattr__(self, "frame", check_int("frame", self.frame, 0, 2**31 - 1))
        object.__setattr__(self, "seed", check_int("seed", self.seed, 0, 2**31 - 1))
        object.__setattr__(self, "backend", check_choice("backend", self.backend, BACKENDS.names()))
