"""Settings of one rendered frame: material, profile, kernel, taps, scene size, ground truths, and the
pass settings. A frozen dataclass, loadable from and savable to TOML/JSON (``ssskit render
--settings FILE``), used alike by the Python API and the CLI, and checked when made: a bad value
fails before any work starts.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import SettingsError
from ..scenes.scenes import SIZE_RANGE  # image sizes of the built-in scenes (pixels per side)
from ..screenspace.burley import BurleySettings
from ..screenspace.settings import PassSettings
from ..settings import Settings, check_choice, check_int

#: photons per channel of Monte Carlo profiles: one range for every command
PHOTONS_RANGE = (1_000, 10_000_000_000)
TAP_RANGE = (1, 255)
#: the screen-space passes a frame can run (``method``)
METHODS = ("separable", "burley")


@dataclass(frozen=True)
class RenderSettings(Settings):
    """One frame of screen-space separable SSS and its comparison with ground truth.

    ``material``: a preset name or a material file; ``model``: the profile the kernel approximates
    (dipole, burley, gaussians, montecarlo; ``photons`` for montecarlo); ``kernel``: a method spec
    ``name[:value]`` (``svd:2``, ``artist:production``, ``jimenez2012:17``...); ``taps``: taps per 1D
    pass (odd; an engine tap kernel such as jimenez2012 is built with this many taps);
    ``tap_method``: importance, uniform or quadratic; ``width`` x ``height``, ``spp`` and ``seed``:
    the built-in scene's G-buffer render; ``exact``: also the exact 2D convolution; ``reference``:
    also a volumetric path trace with at least ``reference_spp`` samples per pixel, continued until
    the relative standard error of its mean over the SSS mask is at most ``reference_rel_se`` or
    ``reference_max_spp`` is spent (:func:`ssskit.scenes.render_reference`); ``perceptual``: FLIP in the metrics;
    ``sss``: the pass itself (:class:`PassSettings`: jitter, depth mode, frame, seed, backend).

    ``method``: the screen-space pass, ``separable`` (the kernel above and ``sss``) or ``burley``
    (the Monte Carlo pass of Xie 2020, :func:`ssskit.pipeline.burley.render_burley`, with ``burley``:
    :class:`~ssskit.screenspace.BurleySettings`; then ``spp`` is still the G-buffer's and the pass's
    samples per pixel are ``burley.spp``, and model, kernel, taps and ``sss`` are unused).
    :func:`ssskit.pipeline.render` runs the method named here.
    """

    material: str = "skin1"
    model: str = "dipole"
    photons: int = 200_000
    kernel: str = "preintegrated"
    taps: int = 7
    tap_method: str = "importance"
    width: int = 256
    height: int = 192
    spp: int = 32
    seed: int = 0
    exact: bool = True
    reference: bool = False
    reference_spp: int = 64
    reference_max_spp: int = 1024
    reference_rel_se: float = 0.01
    perceptual: bool = True
    sss: PassSettings = field(default_factory=PassSettings)
    method: str = "separable"
    burley: BurleySettings = field(default_factory=BurleySettings)

    def __post_init__(self) -> None:
        from ..kernels import parse_method_spec
        from ..profiles import MODELS
        from ..sampling.taps import TAP_METHODS

        if not isinstance(self.material, str) or not self.material.strip():
            raise SettingsError(f"material must be a preset name or a material file, got {self.material!r}")
        object.__setattr__(self, "model", check_choice("model", self.model, MODELS.names()))
        object.__setattr__(self, "photons", check_int("photons", self.photons, *PHOTONS_RANGE))
        if not isinstance(self.kernel, str):
            raise SettingsError(f"kernel must be a method spec such as 'svd:2', got {self.kernel!r}")
        parse_method_spec(self.kernel)  # unknown names and out-of-range parameters fail here
        taps = check_int("taps", self.taps, *TAP_RANGE)
        if taps % 2 == 0:
            raise SettingsError(f"taps must be odd (a centre tap), got {taps}")
        object.__setattr__(self, "taps", taps)
        object.__setattr__(self, "tap_method", check_choice("tap_method", self.tap_method, TAP_METHODS))
        object.__setattr__(self, "width", check_int("width", self.width, *SIZE_RANGE))
        object.__setattr__(self, "height", check_int("height", self.height, *SIZE_RANGE))
        object.__setattr__(self, "spp", check_int("spp", self.spp, 1, 4096))
        object.__setattr__(self, "seed", check_int("seed", self.seed, 0, 2**31 - 1))
        object.__setattr__(self, "reference_spp", check_int("reference_spp", self.reference_spp, 1, 1 << 20))
        object.__setattr__(self, "reference_max_spp", check_int("reference_max_spp", self.reference_max_spp, 1, 1 << 20))
        if self.reference_max_spp < self.reference_spp:
            object.__setattr__(self, "reference_max_spp", self.reference_spp)
        rel = self.reference_rel_se
        if isinstance(rel, bool) or not (isinstance(rel, (int, float)) and 0 < rel < 1):
            raise SettingsError(f"reference_rel_se must be a number in (0, 1), got {rel!r}")
        object.__setattr__(self, "reference_rel_se", float(rel))
        for name in ("exact", "reference", "perceptual"):
            if not isinstance(getattr(self, name), bool):
                raise SettingsError(f"{name} must be true or false, got {getattr(self, name)!r}")
        if not isinstance(self.sss, PassSettings):
            raise SettingsError(f"sss must be PassSettings, got {type(self.sss).__name__}")
        object.__setattr__(self, "method", check_choice("method", self.method, METHODS))
        if not isinstance(self.burley, BurleySettings):
            raise SettingsError(f"burley must be BurleySettings, got {type(self.burley).__name__}")
