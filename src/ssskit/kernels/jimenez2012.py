"""The separable-SSS kernel engines ship today (Jimenez 2012 demo; Unreal, Godot, legacy Eevee).

Recipe (the 2012 SeparableSSS demo's ``calculateKernel``, as stated in the kernels issue):

* N odd taps; range R = 3 if N > 20 else 2; t_i = -R + i 2R / (N - 1); offsets o_i = sign(t_i) t_i^2 / R
  (quadratic spacing, denser near the centre).
* Per channel the profile P(r) = sum_k c_k exp(-r'^2 / (2 v_k)) / (2 * 3.14 * v_k) with
  r' = r / (0.001 + falloff); (c_k, v_k [mm^2]) = (0.100, 0.0484), (0.118, 0.187), (0.113, 0.567),
  (0.358, 1.99), (0.078, 7.41). The constant 3.14 is the engine's and is kept. (The demo drops a
  sixth, narrowest Gaussian (0.233, 0.0064): it is the "directly bounced light" that the strength
  parameter stands for.)
* Weights w_i = P(|o_i|) (|o_i - o_{i-1}| + |o_i - o_{i+1}|) / 2, one-sided at the ends; the centre
  tap moved first; each channel normalised to sum 1; then w_0 <- (1 - s) + s w_0, w_i <- s w_i.

Offsets are in the profile's length unit (mm); at run time the engine scales them by its
``sssWidth`` and the projection, which is the screen-space pass's business.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import KernelError
from ..quantities import FRACTION, TAPS, Quantity
from .base import TapKernel, per_channel

#: (c_k, v_k [mm^2]) of the demo's skin profile.
JIMENEZ2012_GAUSSIANS = ((0.100, 0.0484), (0.118, 0.187), (0.113, 0.567), (0.358, 1.99), (0.078, 7.41))
JIMENEZ2012_STRENGTH = (0.48, 0.41, 0.28)
JIMENEZ2012_FALLOFF = (1.0, 0.37, 0.3)
_PI_ENGINE = 3.14
#: the engine's falloff per channel (a radius scale; 0 keeps the narrowest Gaussian)
FALLOFF = Quantity("falloff", 0.0, float("inf"), "", "a radius scale per channel", hi_open=True)
#: the engine kernel's taps: odd, a centre and at least one pair
JIMENEZ_TAPS = TAPS.within(lo=3, reason="odd: a centre tap and at least one pair")


def jimenez2012_profile(r: ArrayLike, falloff: ArrayLike = JIMENEZ2012_FALLOFF) -> NDArray[np.float64]:
    """The demo's radial profile P(r) per channel, shape r.shape + (3,) (engine constants kept)."""
    f = per_channel(falloff, "falloff", FALLOFF)
    rr = np.asarray(r, dtype=float)[..., None] / (0.001 + f)
    out = np.zeros(rr.shape)
    for c, v in JIMENEZ2012_GAUSSIANS:
        out += c * np.exp(-(rr**2) / (2.0 * v)) / (2.0 * _PI_ENGINE * v)
    return out


def jimenez2012_offsets(taps: int) -> NDArray[np.float64]:
    """Quadratically spaced tap offsets o_i (mm), in the engine's order before the centre moves first."""
    JIMENEZ_TAPS.check(taps, "jimenez2012 taps", KernelError)
    rng = 3.0 if taps > 20 else 2.0
    t = -rng + np.arange(taps // 2) * (2.0 * rng / (taps - 1))  # the negative half; mirrored exactly
    neg = -(t**2) / rng
    return np.concatenate([neg, [0.0], -neg[::-1]])


def kernel_jimenez2012(taps: int = 11, strength: ArrayLike = JIMENEZ2012_STRENGTH,
                       falloff: ArrayLike = JIMENEZ2012_FALLOFF, source: dict[str, Any] | None = None) -> TapKernel:
    """The engine's tap kernel (module docstring), centre tap first; weights (taps, 3)."""
    s = per_channel(strength, "strength", FRACTION)
    f = per_channel(falloff, "falloff", FALLOFF)
    o = jimenez2012_offsets(taps)
    gaps = np.abs(np.diff(o))
    area = np.zeros(taps)
    area[1:] += gaps
    area[:-1] += gaps
    area /= 2.0
    w = jimenez2012_profile(np.abs(o), f) * area[:, None]
    order = np.r_[taps // 2, np.arange(taps // 2), np.arange(taps // 2 + 1, taps)]
    o, w = o[order], w[order]
    w = w / w.sum(axis=0)
    w[0] = (1.0 - s) + s * w[0]
    w[1:] *= s
    params = {"taps": int(taps), "strength": s.tolist(), "falloff": f.tolist()}
    return TapKernel(o, w, "jimenez2012", params, source or {"source": "Jimenez 2012 SeparableSSS demo kernel"})
