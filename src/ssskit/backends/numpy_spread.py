"""The float64 oracle of the transmitted light's lateral spread (:mod:`ssskit.backends.spread_plan` for the
maths: steps 0-2 in its order), vectorised over the pixels; the other backends are checked against it."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .spread_plan import SpreadPlan


def spread_sigma(plan: SpreadPlan, slots: np.ndarray, light_uvz: np.ndarray,
                 shadow_mm: np.ndarray) -> NDArray[np.float64]:
    """Steps 0-1: (H, W, 3) sigma (mm) of every pixel in a slot, 0 elsewhere."""
    from .numpy_backend import shadow_depth

    sl = np.asarray(slots)
    uvz = np.asarray(light_uvz, np.float64)
    out = np.zeros(sl.shape + (3,))
    ys, xs = np.nonzero(sl > 0)
    if ys.size == 0:
        return out
    with np.errstate(invalid="ignore"):
        t = uvz[ys, xs, 2] - shadow_depth(np.asarray(shadow_mm, np.float64), uvz[ys, xs, 0], uvz[ys, xs, 1])
        t = np.where(np.isfinite(t) & (t > plan.bias_mm), t, 0.0)
    s = sl[ys, xs]
    for slot in np.unique(s):
        m = s == slot
        out[ys[m], xs[m]] = plan.sigma(int(slot), t[m])
    return out


def spread_axis(plan: SpreadPlan, v: np.ndarray, depth: np.ndarray, slots: np.ndarray, sigma: np.ndarray,
                horizontal: bool) -> NDArray[np.float64]:
    """Step 2 along one axis (module docstring of :mod:`~ssskit.backends.spread_plan`)."""
    h, w = slots.shape
    out = np.array(v, np.float64, copy=True)
    ys, xs = np.nonzero(slots > 0)
    if ys.size == 0:
        return out
    z = depth[ys, xs].astype(np.float64)
    sig = sigma[ys, xs]  # (N, 3) mm
    f = plan.fx if horizontal else plan.fy
    spx = sig * (f / z)[:, None]
    m = spx.max(axis=1)
    act = m >= plan.min_px
    ys, xs, z, sig, spx, m = ys[act], xs[act], z[act], sig[act], spx[act], m[act]
    if ys.size == 0:
        return out
    step = np.maximum(1, np.ceil(3.0 * m / plan.max_taps)).astype(np.int64)
    k = np.ceil(3.0 * m / step).astype(np.int64)
    inv2 = 1.0 / (2.0 * np.maximum(spx, 1e-30) ** 2)
    total = np.zeros_like(spx)
    for j in range(-int(k.max()), int(k.max()) + 1):
        on = np.abs(j) <= k
        d = (j * step).astype(np.float64)
        total += np.where(on[:, None], np.exp(-(d * d)[:, None] * inv2), 0.0)
    s = slots[ys, xs]
    vp = np.asarray(v, np.float64)[ys, xs]
    acc = np.zeros_like(spx)
    zinv2 = 1.0 / (2.0 * np.maximum(sig, 1e-30) ** 2)
    for j in range(-int(k.max()), int(k.max()) + 1):
        if j == 0:
            continue
        d = j * step
        qy, qx = (ys, xs + d) if horizontal else (ys + d, xs)
        ok = (np.abs(j) <= k) & (qx >= 0) & (qx < w) & (qy >= 0) & (qy < h)
        qyc, qxc = np.clip(qy, 0, h - 1), np.clip(qx, 0, w - 1)
        ok &= slots[qyc, qxc] == s
        dz = depth[qyc, qxc].astype(np.float64) - z
        with np.errstate(invalid="ignore"):
            wgt = np.exp(-(d.astype(np.float64) ** 2)[:, None] * inv2) / total * np.exp(-(dz * dz)[:, None] * zinv2)
        vq = np.asarray(v, np.float64)[qyc, qxc]
        acc += np.where(ok[:, None], wgt * (vq - vp), 0.0)
    out[ys, xs] = vp + acc
    return out


def spread_pass(plan: SpreadPlan, exitance: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
                light_uvz: np.ndarray, shadow_mm: np.ndarray) -> NDArray[np.float64]:
    """Steps 0-2 in float64: the horizontal pass, then the vertical one on its result."""
    sl = np.asarray(slots)
    depth = np.asarray(depth_mm, np.float64)
    sigma = spread_sigma(plan, sl, light_uvz, shadow_mm)
    tmp = spread_axis(plan, np.asarray(exitance, np.float64), depth, sl, sigma, True)
    return spread_axis(plan, tmp, depth, sl, sigma, False)


__all__ = ["spread_axis", "spread_pass", "spread_sigma"]
