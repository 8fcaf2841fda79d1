"""The guiding phase of the variance-guided adaptive sampler (Xie et al. 2020, Sec. 4.1, Fig. 8) as a
backend pass: its plan and EXACTLY what every backend computes.

The pass works on one history texture H (an (H, W, 4) float32 image; RGBA32F on the gl backend)

    [..., 0]  n_bar    EMA of the sample count (Eq. 8)
    [..., 1]  mu       EMA of the gamma-corrected luminance (Eq. 6)
    [..., 2]  sigma^2  exponential moving variance of it (Eq. 9, Finch 2009)
    [..., 3]  m        1 where the pixel holds history (C_s of Sec. 4.1.4), 0 where not

and has two entry points, both per pixel p = (x, y) with the frame's SSS mask M(p) (slot > 0):

* **estimate** (start of a frame, before the Burley pass): steps 1, 3 and 4 on the previous history,
  giving the frame's sample counts n;
* **update** (after the Burley pass): steps 1 and 2 with this frame's result and counts, then steps 3
  and 4 on the new history, giving the next frame's counts for the same pixels (what a static camera
  uses; a moving camera runs *estimate* at the next frame instead).

Steps (the numpy oracle: the ``reference_*`` functions below, float32 history and float32 update
arithmetic, float64 count estimate; numba: the same operations in the same order; GLSL: float32
throughout, so a count whose estimate lies within float32 rounding of an integer may differ by one):

1. **Reprojection** (Xie 2020 Sec. 4.1.5: C of Eq. 6 is a nearest fetch without rejection, the lower
   bound of Eq. 18). Without motion h = H(p). With motion vectors (u, v) (pixels, from p to where its
   surface was in the previous frame) q = (floor(x + 0.5 + u), floor(y + 0.5 + v)) (the coordinate
   sums in float64 on the CPU, float32 in GLSL); h = H(q) if q lies on the image and the caller's
   ``valid`` (disocclusion test) holds at p, else h = 0 (no history).
2. **Update** (Eqs. 8, 6, 9 with M = alpha0; Eqs. 16-17 where h has no history), float32: the value
   S = max(0, 0.2126 R + 0.7152 G + 0.0722 B)^(1 / gamma) of the pass's result (BT.709 luminance,
   gamma-corrected as Sec. 4.1.2 records it); outside M, S = 0; a = alpha0 if h.m > 0 else 1 (Eq. 16),
   b = 1 - a, d = S - h.mu::

       n_bar' = b h.n_bar + a n          (Eq. 8)
       mu'    = a d + h.mu               (Eq. 6: (1 - a) mu + a S)
       var'   = b (a d d + h.var)        (Eq. 9: (1 - a) var + a (1 - a) d^2), = sigma0^2 where h.m = 0 (Eq. 17)

   and H'(p) = (n_bar', mu', var', 1) inside M, 0 outside (no SSS: no history).
3. **Estimate** (Eqs. 13-15, float64 on the CPU) on h (step 1) or H' (step 2), with n_bar = h.n_bar
   h.m (0 without history) and k = 2 / alpha0 - 1::

       spread = var - sigma0^2           ("variance", Eq. 13's correction term; the default)
              = sqrt(var) - sigma0       ("sigma", Eq. 15 as printed)
       n_hat  = n_bar (var + kappa (k - 1) spread) / sigma0^2      (Eq. 14: kappa Delta + E(n_bar))

   In float32 (GLSL) a history holding Eq. 17's variance (var = float32(sigma0^2)) gives n_hat = n_bar
   exactly, while the float64 estimate of the float32-stored value gives n_bar (1 + delta), delta of the
   sign of float32(sigma0^2) - sigma0^2; n_bar is an integer there after a disocclusion (Eq. 16: M' = 1),
   so the ceiling differs by one. The shader takes that case from the sign (S0_ROUNDS_UP) and so
   agrees with the CPU backends.
4. **Clamp** (Eq. 7's floor beta = b_min and the budget): n = clamp(ceil(n_hat), b_min, b_max) (NaN:
   b_max) inside M, 0 outside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..metrics import BT709_LUMA
from .burley_plan import COUNT_IMAGE
from .plan import FINITE_VALUE, Array

#: history channels
N_BAR, MU, VAR, AVAILABLE = 0, 1, 2, 3
HISTORY_CHANNELS = 4
#: Eq. 15 as printed (standard deviations) or with variances (Eq. 13's correction term)
CORRECTIONS = ("variance", "sigma")
#: ITU-R BT.709 luminance weights of linear RGB
LUMA_709 = BT709_LUMA


@dataclass(frozen=True)
class AdaptivePlan:
    """What the guiding phase needs (built from ``ssskit.screenspace.adaptive.AdaptiveSettings``, whose
    checks it relies on): alpha0, sigma0^2, kappa, the budget [b_min, b_max], the Eq. 15 form and gamma."""

    sigma0_sq: float
    kappa: float
    b_min: int
    b_max: int
    alpha: float
    correction: str
    gamma: float

    @property
    def k(self) -> float:
        """k = 2 / alpha - 1 (Xie 2020 Sec. 4.1.2)."""
        return 2.0 / self.alpha - 1.0


class GuideSettings(Protocol):
    """What :func:`as_plan` reads: the fields of an AdaptivePlan (``ssskit.screenspace.AdaptiveSettings``)."""

    @property
    def sigma0_sq(self) -> float: ...
    @property
    def kappa(self) -> float: ...
    @property
    def b_min(self) -> int: ...
    @property
    def b_max(self) -> int: ...
    @property
    def alpha(self) -> float: ...
    @property
    def correction(self) -> str: ...
    @property
    def gamma(self) -> float: ...


class GuideParams(GuideSettings, Protocol):
    """What the reference steps read: an :class:`AdaptivePlan` or ``AdaptiveSettings``, with k."""

    @property
    def k(self) -> float: ...


def as_plan(settings: GuideSettings) -> AdaptivePlan:
    """An :class:`AdaptivePlan` of anything with the same fields (AdaptiveSettings)."""
    if isinstance(settings, AdaptivePlan):
        return settings
    return AdaptivePlan(sigma0_sq=float(settings.sigma0_sq), kappa=float(settings.kappa), b_min=int(settings.b_min),
                        b_max=int(settings.b_max), alpha=float(settings.alpha), correction=str(settings.correction),
                        gamma=float(settings.gamma))


class GuideFrame(NamedTuple):
    """The guiding phase's checked inputs (:data:`GUIDE_FRAME`): history (H, W, 4) float32, mask (H, W)
    bool, motion (H, W, 2) float64, valid (H, W) bool, rgb (H, W, 3) float32, counts (H, W) int64 (each
    optional one None where not given)."""

    history: NDArray[np.float32]
    mask: NDArray[np.bool_]
    motion: NDArray[np.float64] | None = None
    valid: NDArray[np.bool_] | None = None
    rgb: NDArray[np.float32] | None = None
    counts: NDArray[np.int64] | None = None


#: the guiding phase's inputs as arrays of the kernels' types (:class:`GuideFrame`): the rule
#: :meth:`~ssskit.backends.base.Backend.adaptive_counts` and ``adaptive_update`` state for every backend (the counts
#: are those the frame's Burley pass used, whose values that pass checked: here only their shape and type)
GUIDE_FRAME = {"history": Array(("H", "W", HISTORY_CHANNELS), "the adaptive history", "f", np.float32),
               "mask": Array(("H", "W"), "the mask", "iufb", bool),
               "motion": Array(("H", "W", 2), "the motion vectors", "iuf", np.float64, FINITE_VALUE, "pixels",
                               optional=True),
               "valid": Array(("H", "W"), "valid", "iufb", bool, optional=True),
               "rgb": Array(("H", "W", 3), "the pass's result", "iuf", np.float32),
               "counts": replace(COUNT_IMAGE, values=None)}


# ---- the numpy reference (the oracle; ssskit.screenspace.adaptive's public functions call these) -------

def reference_luminance(rgb: np.ndarray, gamma: float) -> np.ndarray:
    """S = max(0, Y)^(1/gamma), Y the BT.709 luminance of float32 RGB (step 2), (H, W) float32."""
    a = np.asarray(rgb, dtype=np.float32)
    y = np.maximum(a @ np.asarray(LUMA_709, np.float32), np.float32(0.0))
    return y if gamma == 1.0 else y ** np.float32(1.0 / gamma)


def reference_reproject(h: np.ndarray, motion: np.ndarray | None, ok: np.ndarray | None) -> np.ndarray:
    """Step 1 on a float32 history: a new (H, W, 4) float32 array."""
    hh, ww = h.shape[:2]
    ok = np.ones((hh, ww), bool) if ok is None else ok.copy()
    if motion is None:
        out = h.copy()
    else:
        v, u = np.mgrid[0:hh, 0:ww] + 0.5
        px = np.floor(u + motion[..., 0]).astype(np.int64)  # nearest pixel of the previous position
        py = np.floor(v + motion[..., 1]).astype(np.int64)
        inside = (px >= 0) & (px < ww) & (py >= 0) & (py < hh)
        out = h[np.clip(py, 0, hh - 1), np.clip(px, 0, ww - 1)]
        ok &= inside
    out[~ok] = 0.0
    return out


def reference_estimate(h: np.ndarray, s: GuideParams) -> NDArray[np.float64]:
    """Step 3: n_hat (H, W) float64 of a float32 history (Eqs. 13-15)."""
    n_bar = h[..., N_BAR].astype(np.float64) * h[..., AVAILABLE]  # pixels without history: n_bar = 0, n_hat = 0
    var = h[..., VAR].astype(np.float64)
    s0_sq = s.sigma0_sq
    if s.correction == "sigma":
        spread = np.sqrt(var) - math.sqrt(s0_sq)  # Eq. 15 as printed
    else:
        spread = var - s0_sq  # Eq. 13's correction term
    # Eq. 14: n_hat = kappa * Delta + E(n_bar), Delta = spread / s0^2 * n_bar * (k - 1) (Eq. 15),
    # E(n_bar) = var / s0^2 * n_bar (Eq. 13)
    spread *= s.kappa * (s.k - 1.0)
    spread += var
    spread *= n_bar
    spread /= s0_sq
    return spread


def reference_clamp(nh: np.ndarray, s: GuideParams, m: np.ndarray) -> NDArray[np.int64]:
    """Step 4: counts (H, W) int64 (NaN counts as b_max: the clip keeps it, so map it first)."""
    n = np.ceil(nh)
    n[np.isnan(n)] = s.b_max
    np.clip(n, s.b_min, s.b_max, out=n)
    n[~m] = 0
    return n.astype(np.int64)


def reference_update(h: np.ndarray, v: np.ndarray, n: np.ndarray, s: GuideParams, m: np.ndarray) -> NDArray[np.float32]:
    """Step 2 on a reprojected float32 history h, values v (H, W), counts n (H, W): a new (H, W, 4) float32
    history (float32 arithmetic, as the history is stored)."""
    f32 = np.float32
    had = h[..., AVAILABLE] > 0
    a = np.where(had, f32(s.alpha), f32(1.0))  # Eq. 16: M' = 1 without history
    b = f32(1.0) - a
    c = h[..., MU]
    diff = np.where(m, v, 0).astype(f32)
    diff -= c  # S - C
    n_bar = b * h[..., N_BAR]
    n_bar += a * n.astype(f32)  # Eq. 8
    mu = a * diff
    mu += c  # Eq. 6: (1 - a) C + a S
    var = a * diff
    var *= diff
    var += h[..., VAR]
    var *= b  # Eq. 9: (1 - a) sigma^2 + a (1 - a) (S - C)^2
    var[~had] = s.sigma0_sq  # Eq. 17
    mf = m.astype(f32)  # no SSS this frame: no history
    return np.stack([n_bar * mf, mu * mf, var * mf, mf], axis=-1)


def reference_counts(plan: AdaptivePlan, frame: GuideFrame) -> NDArray[np.int64]:
    """The *estimate* entry point (steps 1, 3, 4) in numpy on a checked frame: counts (H, W) int64."""
    return reference_clamp(reference_estimate(reference_reproject(frame.history, frame.motion, frame.valid), plan),
                           plan, frame.mask)


def reference_update_pass(plan: AdaptivePlan, frame: GuideFrame) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
    """The *update* entry point (steps 1-4) in numpy on a checked frame with its ``rgb`` and ``counts``: (new
    history (H, W, 4) float32, next counts int64)."""
    assert frame.rgb is not None and frame.counts is not None  # Backend.adaptive_update requires both
    new = reference_update(reference_reproject(frame.history, frame.motion, frame.valid),
                           reference_luminance(frame.rgb, plan.gamma), frame.counts, plan, frame.mask)
    return new, reference_clamp(reference_estimate(new, plan), plan, frame.mask)
