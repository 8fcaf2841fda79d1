"""The lateral spread of the transmitted light (docs/transmission.md, "Lateral spread"): the light that enters the
back of a thin part at one point leaves its front spread around it, MCML's Tt(r; t) [WJZ95]; the transmittance
pass (:mod:`ssskit.backends.transmission_plan`) puts it all at the point behind, and this step spreads it in
screen space where the spread is wider than a pixel: a separable, depth-aware Gaussian whose width follows each
pixel's thickness.

The width: per profile slot and channel, sigma(t) (mm) at thickness knots t_0 < ... < t_n-1, the sigma of the
Gaussian with the same median radius as MCML's scattered Tt(r; t)
(:func:`ssskit.profiles.montecarlo.transmission.diffuse_spread`), linear between the knots, the end values
beyond them.

Frame inputs (pixel-aligned (H, W) unless noted): ``exitance`` (H, W, 3) the transmittance pass's output;
``depth_mm`` the camera depth (finite where ``slots`` > 0); ``slots`` int32 (0 = no SSS: copied unchanged);
``light_uvz`` (H, W, 3) and ``shadow_mm`` (Hs, Ws) the light layers as the pass takes them.

Per pixel p in slot s > 0 (every backend in this order):

0. t = the pass's steps 1-2 (the map's bilinear depth D at p's light-space position, t = z - D); where there is
   none (no finite texel, t not finite, t <= ``bias_mm``) t = 0: the pixel still gathers its neighbours' light.
1. sigma_c = sigma_s,c(t) (mm); the pixel's scale k = f / depth_p (pixels per mm: ``fx`` for the horizontal
   pass, ``fy`` for the vertical), sigma_px,c = k sigma_c, m = max_c sigma_px,c.
2. One 1D pass along the axis (horizontal on ``exitance``, then vertical on its result): if m < ``min_px``
   the pixel keeps its value. Else taps at d = j step, j = -K..K, j != 0, with step = ceil(3 m / max_taps)
   pixels and K = ceil(3 m / step) (at most ``max_taps``); the texel q = p + d (along the axis) counts if it
   lies in the image and in slot s. Its weight is the pair's, the same seen from p and from q: with the
   geometric means S_c = sqrt(sigma_px,c(p) sigma_px,c(q)) (pixels, each at its own depth) and s_c =
   sqrt(sigma_c(p) sigma_c(q)) (mm), w_c = step exp(-d^2 / (2 S_c^2)) / (sqrt(2 pi) S_c) exp(-(z_q - z_p)^2 /
   (2 s_c^2)) (the Gaussian of the 3D distance) where |d| <= 3 S_c, 0 beyond (and where S_c = 0); out_c(p) =
   v_c(p) + sum_q w_c (v_c(q) - v_c(p)). What p gives q, q gives back in the same measure, so the light is
   moved, not made or lost: exactly where the two see each other with the same step (a smooth width); when
   each pixel's width is drawn at random between 0.8 and 4.8 pixels, 0.6 % of it is lost (a width taken from
   the receiver alone lost 7 % of a 0.5 mm slab's red light to the G-buffer's noisy thickness, draining the
   thicker, brighter pixels). Taps off the image, off the slot or lost to the depth factor leave their share
   at p (as the separable pass, :mod:`ssskit.backends.plan`): a uniform exitance stays uniform, and nothing
   crosses profile ids.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import PassError
from ..quantities import TYPE, Quantity, check_fields, fail
from .plan import FOCAL_PX, LIGHT_VIEW, SEPARABLE_FRAME, Array, check_arrays, check_plan_ids
from .transmission_plan import BIAS_MM

#: the most taps on each side of a pixel per 1D pass (a wider Gaussian is sampled with a stride)
MAX_TAPS = 16
#: below this width in pixels (the widest channel's sigma) a pixel is left as it is
MIN_PX = 0.5
#: the most thickness knots of one slot's width table
MAX_KNOTS = 64
KNOTS = Quantity("knots", 0, MAX_KNOTS, "", "thicknesses of one slot's width table", integer=True)
#: the step's quantities: its taps per side, its widths and thicknesses (mm)
MAX_TAPS_Q = Quantity("max_taps", 1, 64, "", "taps on each side of a pixel per 1D pass", integer=True)
WIDTH_MM = Quantity("knots_mm", 0.0, math.inf, "mm", "a thickness or a width", hi_open=True)
#: the plan's scalar arguments (:func:`build_spread_plan`)
_PLAN_FIELDS = {"bias_mm": BIAS_MM, "min_px": FOCAL_PX.within(reason="a width in pixels"), "max_taps": MAX_TAPS_Q}
#: a :class:`SlotSpread`'s arrays: N thickness knots and their widths (mm), one N for both
SPREAD_ARRAYS = {"knots_mm": Array(("N",), "the spread's knots_mm", values=WIDTH_MM),
                 "sigma_mm": Array((3, "N"), "the spread's sigma_mm", values=WIDTH_MM)}
#: the step's frame (module docstring): the light's view, the transmittance pass's ``exitance`` and the camera
#: depth (positive and finite on every pixel with SSS)
SPREAD_FRAME = {**LIGHT_VIEW, "exitance": Array(("H", "W", 3), "exitance"), "depth_mm": SEPARABLE_FRAME["depth_mm"]}


@dataclass(frozen=True)
class SlotSpread:
    """One profile id's spread width: ``knots_mm`` (N,) ascending thicknesses and ``sigma_mm`` (3, N) >= 0."""

    knots_mm: np.ndarray
    sigma_mm: np.ndarray


@dataclass(frozen=True, eq=False)
class SpreadPlan:
    """What a backend needs besides the frame's images (module docstring): per slot (slot 0 empty) the knots
    (S, N) padded with their last value, the widths (S, 3, N), ``n_knots`` (S,); the focal lengths in pixels,
    the zero-thickness bias, ``min_px`` and ``max_taps``."""

    ids: tuple[int, ...]
    knots_mm: NDArray[np.float64]
    sigma_mm: NDArray[np.float64]
    n_knots: NDArray[np.int64]
    fx: float
    fy: float
    bias_mm: float = 1e-3
    min_px: float = MIN_PX
    max_taps: int = MAX_TAPS

    @property
    def slots(self) -> int:
        return len(self.ids) + 1

    def sigma(self, slot: int, thickness_mm: np.ndarray) -> NDArray[np.float64]:
        """(..., 3) step 1's sigma (mm) of one slot at thicknesses (mm), in float64."""
        n = int(self.n_knots[slot])
        t = np.asarray(thickness_mm, float)
        return np.stack([np.interp(t, self.knots_mm[slot, :n], self.sigma_mm[slot, c, :n]) for c in range(3)], axis=-1)


def build_spread_plan(spreads: dict[int, SlotSpread], fx: float, fy: float, bias_mm: float = 1e-3,
                      min_px: float = MIN_PX, max_taps: int = MAX_TAPS) -> SpreadPlan:
    """The plan of profile ids -> their :class:`SlotSpread` for a camera of focal lengths ``fx``, ``fy``
    (pixels), or a PassError naming what is wrong."""
    ids = check_plan_ids(spreads, SlotSpread, fx, fy)
    v = check_fields({"bias_mm": bias_mm, "min_px": min_px, "max_taps": max_taps}, _PLAN_FIELDS, error=PassError)
    n = max((np.size(spreads[i].knots_mm) for i in ids), default=1)
    KNOTS.check(n, "a spread table's thicknesses", PassError)
    s = len(ids) + 1
    knots, sigma = np.zeros((s, n)), np.zeros((s, 3, n))
    counts = np.ones(s, np.int64)
    for slot, pid in enumerate(ids, start=1):
        label = f"profile id {pid}"
        t, w = check_arrays(SPREAD_ARRAYS, vars(spreads[pid]), where=label).values()
        if t.size < 1 or np.any(np.diff(t) <= 0):
            raise fail(PassError, TYPE, name=f"{label}: the spread's knots_mm", kind="ascending thicknesses", actual=t.tolist())
        k = t.size
        knots[slot, :k], knots[slot, k:] = t, t[-1]
        sigma[slot, :, :k], sigma[slot, :, k:] = w, w[:, -1:]
        counts[slot] = k
    return SpreadPlan(ids, knots, sigma, counts, float(fx), float(fy), float(v["bias_mm"]),
                      float(v["min_px"]), int(v["max_taps"]))


def taps(m: float, max_taps: int) -> tuple[int, int]:
    """(step, K) of step 2 for the widest channel's width ``m`` (pixels)."""
    step = max(1, math.ceil(3.0 * m / max_taps))
    return step, math.ceil(3.0 * m / step)


__all__ = ["MAX_KNOTS", "MAX_TAPS", "MIN_PX", "SPREAD_FRAME", "SlotSpread", "SpreadPlan", "build_spread_plan",
           "taps"]
