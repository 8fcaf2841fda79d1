"""Single-pass variance-guided adaptive sample counts with a temporal history (Xie et al. 2020, Sec. 4.1).

Per pixel and per frame the pass chooses how many Burley samples to take from a temporally accumulated
variance estimate, in one pass, with one history texture, leaving the engine's TAA untouched. A frame:

1. ``h = reproject_history(history, motion, valid)``: the previous history fetched through the motion
   vectors with a nearest-neighbour lookup and no rejection (C of Eq. 6 chosen as Eq. 18's lower bound);
   off-screen fetches and pixels where ``valid`` is False lose their history (disocclusion);
2. ``counts, n_hat = sample_counts(h, settings, mask)``: Eqs. 13-15 and the budget clamp;
3. the Burley pass with ``counts`` (:func:`ssskit.screenspace.burley_sss`; over frames, through the
   backend's runner: :func:`ssskit.screenspace.frames.run_frames`, :func:`~ssskit.screenspace.frames.adaptive_frames`);
4. ``history = update_history(h, shading_value(sss), counts, settings, mask)``: Eqs. 8, 6 and 9, with
   Eqs. 16-17 where the history was not available.

**History format** (the one texture passed between frames): an (H, W, 4) float32 array,

    [..., 0]  n_bar    EMA of the sample count (Eq. 8)
    [..., 1]  mu       EMA of the gamma-corrected luminance (Eq. 6)
    [..., 2]  sigma^2  exponential moving variance of it (Eq. 9, Finch 2009)
    [..., 3]  m        1 where the pixel holds history (the SSS mask of the frame that wrote it),
                       0 where not: C_s of Sec. 4.1.4, which switches Eqs. 16-17 on

so H_i = (n_bar_i, mu_i, sigma_i^2) of the paper plus the subsurface-mask history it reads in Eq. 16
(16 bytes per pixel; the paper stores the mask in a separate profile-id texture it keeps anyway).

``AdaptiveSettings.correction`` picks Eq. 15 as printed (``"sigma"``: (sigma - sigma0) / sigma0^2, units
of 1/sigma) or the variance form of Eq. 13's correction term (``"variance"``: (sigma^2 - sigma0^2) /
sigma0^2, dimensionless, the default). Which matches the paper's Figs. 2-3: ``docs/adaptive.md``.

    >>> s = AdaptiveSettings(sigma0_sq=0.08 ** 2, kappa=1.0)
    >>> run = circle_scenario(s, frames=150)           # Xie 2020 Sec. 4.1.3, Fig. 2
    >>> bool(abs(run.mu[-50:].mean() - 1.0) < 0.05)
    True
"""

from __future__ import annotations

import math
from dataclasses import dataclass


import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..backends.adaptive_plan import (
    AVAILABLE,
    CORRECTIONS,
    HISTORY_CHANNELS,
    LUMA_709,
    MU,
    N_BAR,
    VAR,
    as_plan,
    reference_clamp,
    reference_estimate,
    reference_luminance,
    reference_reproject,
    reference_update,
)
from ..errors import PassError, SettingsError
from ..quantities import FRACTION, SCALE, Choice, Flag, Quantity, check_fields, check_finite, check_instance, check_shape

#: the history's mean sample counts and variances (Xie 2020 Sec. 4.1.2): non-negative
HISTORY_MOMENT = Quantity("moment", 0.0, math.inf, "", "a mean count or a variance", hi_open=True)
#: a history's sides (pixels), and the toy scenario's frame and pixel counts and seed (:func:`circle_scenario`)
_SIDE = Quantity("side", 1, 1 << 16, integer=True)
_TOY_COUNT = Quantity("count", 1, 1_000_000, integer=True)
_TOY_SEED = Quantity("seed", 0, 2**63 - 1, integer=True)
#: the toy scenario's arguments (:func:`circle_scenario`)
_CIRCLE = {"frames": _TOY_COUNT, "pixels": _TOY_COUNT, "seed": _TOY_SEED, "scale": SCALE.within(1e-12, 1e12)}
from ..settings import Settings, setting
from .burley import BURLEY_SPP


#: the display gamma of a luminance (1 = linear)
GAMMA = Quantity("gamma", 0.1, 10.0, "", "a display gamma")


@dataclass(frozen=True)
class AdaptiveSettings(Settings):
    """Parameters of the variance-guided sampler (Xie 2020 Sec. 4.1; defaults: its Fig. 1 / Fig. 9 setting).

    ``sigma0_sq``: the target variance sigma0^2 of the per-frame mean (> 0; Xie: 1e-3, i.e. 30 dB on
    values in [0, 1]); ``kappa``: the correction factor of Eq. 14, in [0, 1]; ``b_min``, ``b_max``: the
    sample budget per pixel and frame (b_min <= b_max; Xie: [8, 64]; b_min is also beta, the floor of
    Eq. 7); ``alpha``: the EMA weight alpha0 of the current frame (Eqs. 6, 8, 9; in (0, 1]; Xie: 0.2,
    UE4's maximum TAA weight); ``correction``: ``"variance"`` or ``"sigma"`` (Eq. 15 as printed);
    ``gamma``: the display gamma of the luminance the history records (Sec. 4.1.2; 1 = linear).
    """

    sigma0_sq: float = setting(Quantity("sigma0_sq", 0.0, math.inf, "", "a variance", lo_open=True, hi_open=True), 1e-3)
    kappa: float = setting(FRACTION, 0.2)
    b_min: int = setting(BURLEY_SPP, 8)
    b_max: int = setting(BURLEY_SPP, 64)
    alpha: float = setting(Quantity("alpha", 0.0, 1.0, "", "an EMA weight", lo_open=True), 0.2)
    correction: str = setting(Choice("correction", CORRECTIONS), "variance")
    gamma: float = setting(GAMMA, 2.2)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.b_min > self.b_max:
            raise SettingsError(f"the sample budget needs b_min <= b_max, got b_min={self.b_min} > b_max={self.b_max}")

    def budget(self) -> Quantity:
        """A per-pixel sample count inside the budget [b_min, b_max] (a fixed count the caller gives a pixel in
        place of the guide's, e.g. ``disocclusion_spp``)."""
        return BURLEY_SPP.within(self.b_min, self.b_max, "inside the budget b_min:b_max")

    @property
    def k(self) -> float:
        """k = 2 / alpha - 1 (Xie 2020 Sec. 4.1.2: the SMA length of an EMA, Bauer and Dahlquist 1998)."""
        return 2.0 / self.alpha - 1.0


def _settings(settings: object) -> AdaptiveSettings:
    if settings is None:
        return AdaptiveSettings()
    return check_instance(settings, AdaptiveSettings, "settings", PassError)


def new_history(height: int, width: int, *, available: bool = False) -> np.ndarray:
    """H_0 = 0: an (H, W, 4) float32 history of zeros (format: module docstring).

    ``available=True`` marks it as real history (Xie 2020 Sec. 4.1.3's *cold start*, Fig. 2: every
    pixel starts from (n_bar, mu, sigma^2) = 0 and Eqs. 6-9 run unchanged); ``False`` (default) marks
    it as missing, so the first frame takes the disocclusion initialisation of Eqs. 16-17 (Fig. 3).
    """
    h, w = (int(_SIDE.check(v, name, SettingsError)) for v, name in ((height, "height"), (width, "width")))
    out = np.zeros((h, w, HISTORY_CHANNELS), np.float32)
    if available:
        out[..., AVAILABLE] = 1.0
    return out


def check_history(history: ArrayLike, size: tuple[int | str, int | str] = ("H", "W")) -> NDArray[np.float32]:
    """``history`` as an (H, W, 4) float32 array (``size``: (H, W) when given) with finite, valid entries, else a
    PassError."""
    label = "the adaptive history"
    arr = check_shape(history, label, (*size, HISTORY_CHANNELS), PassError, "f", np.float32)
    # one cheap pass first (a sum is NaN or inf if any entry is); the exact test only when it fails
    if not math.isfinite(float(arr.sum(dtype=np.float64))):
        check_finite(arr, "the adaptive history", PassError)
    if arr.size and (float(arr[..., N_BAR].min()) < 0 or float(arr[..., VAR].min()) < 0):
        HISTORY_MOMENT.check_array(arr[..., [N_BAR, VAR]], f"{label}'s mean counts and variances", PassError)
    return arr


def _mask(mask: ArrayLike | None, shape: tuple[int, ...]) -> NDArray[np.bool_]:
    if mask is None:
        return np.ones(shape, bool)
    return check_shape(mask, "the mask", shape, PassError, "iufb", bool)


def shading_value(rgb: ArrayLike, gamma: float = 2.2) -> NDArray[np.float32]:
    """The per-pixel value S the history records: gamma-corrected luminance Y^(1/gamma) (H, W) float32
    of linear RGB (H, W, 3), Y = 0.2126 R + 0.7152 G + 0.0722 B (ITU-R BT.709), as Xie 2020 Sec. 4.1.2
    records "the moving average of gamma-corrected luminance to consider human perception"."""
    a = check_shape(rgb, "shading_value's RGB image", ("H", "W", 3), PassError, dtype=np.float32)
    return reference_luminance(a, GAMMA.check(gamma, "gamma", SettingsError))


def estimate_counts(history: ArrayLike, settings: AdaptiveSettings | None = None) -> NDArray[np.float64]:
    """n_hat (H, W) float64, the unclamped sample-count estimate for the next frame (Xie 2020 Eqs. 13-15):

        E(n_bar) = sigma^2 / sigma0^2 * n_bar                              (Eq. 13)
        Delta    = (sigma - sigma0) / sigma0^2 * n_bar * (k - 1)          (Eq. 15 as printed, "sigma")
                 = (sigma^2 - sigma0^2) / sigma0^2 * n_bar * (k - 1)      (Eq. 13's term, "variance")
        n_hat    = kappa * Delta + E(n_bar)                                (Eq. 14)

    with (n_bar, sigma^2) the (reprojected) history and k = 2 / alpha - 1. Pixels without history
    (channel 3 = 0) hold zeros, so n_hat = 0 there and the floor beta = b_min applies (Sec. 4.1.4).
    """
    return _estimate(check_history(history), _settings(settings))


#: estimate_counts on a checked float32 history (no checks): step 3 of ssskit.backends.adaptive_plan
_estimate = reference_estimate


def clamp_counts(n_hat: ArrayLike, settings: AdaptiveSettings | None = None,
                 mask: ArrayLike | None = None) -> NDArray[np.int64]:
    """Samples per pixel (H, W) int64: n = clamp(max(ceil(n_hat), beta), b_min, b_max) with beta = b_min
    (Xie 2020 Eq. 7's floor and the budget of Sec. 4.1.3); 0 outside ``mask`` (no SSS there).

    n_hat is rounded up: the count is the smallest that reaches the target variance."""
    s = _settings(settings)
    nh = check_shape(n_hat, "n_hat", ("H", "W"), PassError, dtype=np.float64)
    return _clamp(nh, s, _mask(mask, nh.shape))


#: clamp_counts on checked inputs: step 4 of ssskit.backends.adaptive_plan
_clamp = reference_clamp


def sample_counts(history: ArrayLike, settings: AdaptiveSettings | None = None,
                  mask: ArrayLike | None = None) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """(counts (H, W) int64, n_hat (H, W) float64) for the next frame: :func:`estimate_counts`
    (Eqs. 13-15) clamped to the budget by :func:`clamp_counts`. ``counts`` goes to
    :func:`ssskit.screenspace.burley_sss` as its ``counts`` image."""
    n_hat = estimate_counts(history, settings)
    return clamp_counts(n_hat, settings, mask), n_hat


def update_history(history: ArrayLike, value: ArrayLike, counts: ArrayLike, settings: AdaptiveSettings | None = None,
                   mask: ArrayLike | None = None) -> NDArray[np.float32]:
    """H_i from the (reprojected) H_{i-1}, this frame's value S (H, W) and sample counts n_i (H, W); a new
    (H, W, 4) float32 array (Xie 2020 Sec. 4.1.2, 4.1.4):

        n_bar_i   = (1 - a) n_bar_{i-1} + a n_i                          (Eq. 8)
        mu_i      = (1 - a) C + a S                                       (Eq. 6; C = mu_{i-1})
        sigma_i^2 = (1 - a) sigma_{i-1}^2 + a (1 - a) (S - C)^2           (Eq. 9, Finch 2009)

    with a = M'(alpha0) = alpha0 where the pixel had history and 1 where not (Eq. 16: C_s = 0, the
    history's channel 3), and there sigma_i^2 = sigma0^2 (Eq. 17) instead of Eq. 9's 0. C is the
    history as given (a nearest fetch without rejection, Eq. 18's lower bound: see
    :func:`reproject_history`). Pixels outside ``mask`` (no SSS this frame) get no history.
    """
    s = _settings(settings)
    h = check_history(history)
    shape = h.shape[:2]
    v = check_shape(value, "the shading value", shape, PassError)
    n = check_shape(counts, "the sample counts", shape, PassError)
    m = _mask(mask, shape)
    check_finite(v[m], "the shading value", PassError, "pixels inside the mask")
    return _update(h, v, n, s, m)


#: update_history on checked inputs (float32 arithmetic): step 2 of ssskit.backends.adaptive_plan
_update = reference_update


def reproject_history(history: ArrayLike, motion: ArrayLike | None = None,
                      valid: ArrayLike | None = None) -> np.ndarray:
    """The previous frame's history seen from this frame's pixels, (H, W, 4) float32.

    ``motion`` (H, W, 2): pixels from each pixel to where its surface was in the previous frame, (u, v)
    order, as :func:`ssskit.screenspace.camera.motion_vectors` returns (None: a static camera). The
    fetch is nearest-neighbour without rejection or clamping: C of Eq. 6 chosen as the lower bound of
    Eq. 18 (Xie 2020 Sec. 4.1.5). Off-screen fetches and pixels where ``valid`` (H, W) is False (the
    caller's disocclusion test) come back without history (zeros; Eqs. 16-17 then apply).
    """
    h = check_history(history)
    hh, ww = h.shape[:2]
    ok = None if valid is None else _mask(valid, (hh, ww))
    mv = None
    if motion is not None:
        mv = check_shape(motion, "the motion vectors", (hh, ww, 2), PassError, dtype=np.float64, finite=True)
    return reference_reproject(h, mv, ok)


# ---- the circle scenario (Xie 2020 Sec. 4.1.3, Figs. 2 and 3) --------------------------------------------

#: uniform irradiance inside the unit-square's inscribed circle: its mean over [0, 1)^2 is 1
CIRCLE_IRRADIANCE = 4.0 / math.pi


@dataclass(frozen=True)
class CircleRun:
    """Per-frame series of the circle scenario, each (frames, pixels) float64: ``n_hat`` (the estimate
    of Eq. 14 before clamping), ``n`` (samples used), ``value`` (the frame's estimate S), ``mu`` and
    ``sigma`` (the history after the frame's update: Eq. 6, and the square root of Eq. 9)."""

    settings: AdaptiveSettings
    disocclusion: bool
    n_hat: np.ndarray
    n: np.ndarray
    value: np.ndarray
    mu: np.ndarray
    sigma: np.ndarray

    def peaks(self, threshold: float, start: int = 0) -> tuple[float, float]:
        """The peaks of the sample count (Fig. 2's shape): over frames ``start``... of every pixel, the
        runs of consecutive frames with n > ``threshold``; returns their mean height (max n in the run)
        and mean length in frames, NaN for both when there is no run. A run still open at the last
        frame is not counted (its length is unknown)."""
        heights, lengths = [], []
        for col in self.n[start:].T:
            length = top = 0
            for v in col:
                if v > threshold:
                    length, top = length + 1, max(top, v)
                elif length:
                    heights.append(top)
                    lengths.append(length)
                    length = top = 0
        if not heights:
            return float("nan"), float("nan")
        return float(np.mean(heights)), float(np.mean(lengths))


def circle_scenario(settings: AdaptiveSettings | None = None, frames: int = 150, *, disocclusion: bool = False,
                    pixels: int = 1, seed: int = 0, scale: float = 1.0) -> CircleRun:
    """Xie 2020 Sec. 4.1.3: a pixel integrates uniform irradiance 4/pi inside the circle of radius 0.5
    centred at (0.5, 0.5) with uniform 2D random samples (xi1, xi2) in [0, 1)^2, so its true value is 1
    and one sample's variance is 4/pi - 1. H_0 = 0; every frame takes the counts of
    :func:`sample_counts`, estimates the value with that many samples and runs :func:`update_history`.

    ``disocclusion``: False is the paper's *cold start* (Fig. 2: H_0 = 0 treated as history); True
    marks H_0 as missing, so frame 1 takes Eqs. 16-17 (Fig. 3). ``pixels`` independent pixels run side
    by side (one random stream per frame from ``seed``). The paper's setting: b = [8, 64], alpha = 0.2,
    sigma0^2 = 0.08^2, 150 frames, gamma not applied (the value is the irradiance itself). ``scale``
    multiplies the irradiance (the paper: 1), to study how the sampler depends on the unit of the values.
    """
    s = _settings(settings)
    v = check_fields({"frames": frames, "pixels": pixels, "seed": seed, "scale": scale}, _CIRCLE, error=SettingsError)
    frames, pixels, seed, scale = v["frames"], v["pixels"], v["seed"], float(v["scale"])
    Flag("disocclusion").check(disocclusion, "disocclusion", PassError)
    history = new_history(1, pixels, available=not disocclusion)
    series = {k: np.zeros((frames, pixels)) for k in ("n_hat", "n", "value", "mu", "sigma")}
    slots = np.arange(s.b_max)
    for f in range(frames):
        counts, n_hat = sample_counts(history, s)
        n = counts[0]
        xi = np.random.default_rng([seed, f]).random((pixels, s.b_max, 2))
        inside = ((xi - 0.5) ** 2).sum(axis=-1) < 0.25
        used = slots[None, :] < n[:, None]
        value = scale * CIRCLE_IRRADIANCE * (inside & used).sum(axis=1) / n
        history = update_history(history, value[None, :], counts, s)
        series["n_hat"][f], series["n"][f], series["value"][f] = n_hat[0], n, value
        series["mu"][f] = history[0, :, MU]
        series["sigma"][f] = np.sqrt(history[0, :, VAR])
    return CircleRun(settings=s, disocclusion=disocclusion, **series)


__all__ = ["AVAILABLE", "AdaptiveSettings", "CIRCLE_IRRADIANCE", "CORRECTIONS", "CircleRun", "HISTORY_CHANNELS",
           "LUMA_709", "MU", "N_BAR", "VAR", "check_history", "circle_scenario", "clamp_counts", "estimate_counts",
           "new_history", "reproject_history", "sample_counts", "shading_value", "update_history"]
