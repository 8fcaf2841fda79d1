"""numba kernels of the transmitted light's lateral spread (:mod:`ssskit.backends.spread_plan` for the maths):
steps 0-1 per pixel of rows [y0, y1) (:func:`sigma_rows`), then step 2 along one axis (:func:`spread_rows`),
float32, in the plan's order, the exponentials by :func:`~ssskit.compute.numba_math.exp2_f32` (relative error
2.5e-7). Pixels are independent within a step, so the image does not depend on the number of threads.
Compiled once and cached on disk (``cache=True``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..compute.numba_math import exp2_f32

_ZERO = np.float32(0.0)
_ONE = np.float32(1.0)
_HALF = np.float32(0.5)
_THREE = np.float32(3.0)
_SQRT2PI = np.float32(2.5066282746310002)
_NINE = np.float32(9.0)
_LOG2E = np.float32(1.4426950408889634)


@njit(cache=True, nogil=True)
def _map_depth(shadow, px, py):  # pragma: no cover
    """The light-space map's bilinear depth at texel coordinates (px, py) over its finite texels (the
    transmittance pass's step 1), NaN where none has a positive weight."""
    hs, ws = shadow.shape
    x = px - _HALF
    y = py - _HALF
    if not (math.isfinite(x) and math.isfinite(y)):
        return np.float32(np.nan)
    fi = math.floor(x)
    fj = math.floor(y)
    fx = x - np.float32(fi)
    fy = y - np.float32(fj)
    i0 = int(fi)
    j0 = int(fj)
    acc = _ZERO
    wsum = _ZERO
    for q in range(4):
        di = q & 1
        dj = q >> 1
        wgt = (fx if di else _ONE - fx) * (fy if dj else _ONE - fy)
        ii = i0 + di
        jj = j0 + dj
        if wgt > _ZERO and 0 <= ii < ws and 0 <= jj < hs:
            d = shadow[jj, ii]
            if math.isfinite(d):
                acc += wgt * d
                wsum += wgt
    if not wsum > _ZERO:
        return np.float32(np.nan)
    return acc / wsum


@njit(cache=True, nogil=True)
def sigma_rows(slots, uvz, shadow, knots, table, n_knots, bias, out, y0, y1):  # pragma: no cover
    """Steps 0-1 of rows [y0, y1): sigma (mm) per channel into ``out`` (H, W, 3), 0 outside the slots."""
    w = slots.shape[1]
    for y in range(y0, y1):
        for x in range(w):
            s = slots[y, x]
            for c in range(3):
                out[y, x, c] = _ZERO
            if s <= 0:
                continue
            t = uvz[y, x, 2] - _map_depth(shadow, uvz[y, x, 0], uvz[y, x, 1])
            if not (math.isfinite(t) and t > bias):
                t = _ZERO
            n = n_knots[s]
            k = 0
            while k < n - 1 and knots[s, k + 1] < t:
                k += 1
            for c in range(3):
                if n == 1 or t <= knots[s, 0]:
                    v = table[s, c, 0]
                elif t >= knots[s, n - 1]:
                    v = table[s, c, n - 1]
                else:
                    f = (t - knots[s, k]) / (knots[s, k + 1] - knots[s, k])
                    v = table[s, c, k] + f * (table[s, c, k + 1] - table[s, c, k])
                out[y, x, c] = v


@njit(cache=True, nogil=True)
def root_rows(sig, depth, slots, root, y0, y1):  # pragma: no cover
    """sqrt(sigma_c / z) per pixel of rows [y0, y1) (a pair's width in pixels is f root_p root_q)."""
    w = slots.shape[1]
    for y in range(y0, y1):
        for x in range(w):
            for c in range(3):
                root[y, x, c] = math.sqrt(sig[y, x, c] / depth[y, x]) if slots[y, x] > 0 else _ZERO


@njit(cache=True, nogil=True)
def spread_rows(src, depth, slots, sig, root, focal, horizontal, min_px, max_taps, dst, y0, y1):  # pragma: no cover
    """Step 2 along one axis for rows [y0, y1): ``src`` (H, W, 3) -> ``dst``. The pair's terms rewritten without
    a root per tap: S_c = f root_p root_q and d^2 / (2 S_c^2) + dz^2 / (2 s_c^2) = (d^2 z_p z_q / f^2 + dz^2) /
    (2 sigma_p sigma_q)."""
    h, w = slots.shape
    inv_f2 = _ONE / (focal * focal)
    acc = np.empty(3, np.float32)
    for y in range(y0, y1):
        for x in range(w):
            s = slots[y, x]
            for c in range(3):
                dst[y, x, c] = src[y, x, c]
            if s <= 0:
                continue
            zp = depth[y, x]
            m = max(sig[y, x, 0], max(sig[y, x, 1], sig[y, x, 2])) * (focal / zp)
            if m < min_px:
                continue
            for c in range(3):
                acc[c] = _ZERO
            step = max(1, int(math.ceil(_THREE * m / np.float32(max_taps))))
            kk = int(math.ceil(_THREE * m / np.float32(step)))
            fstep = np.float32(step) / _SQRT2PI
            for j in range(-kk, kk + 1):
                if j == 0:
                    continue
                qx = x + j * step if horizontal else x
                qy = y if horizontal else y + j * step
                if qx < 0 or qx >= w or qy < 0 or qy >= h or slots[qy, qx] != s:
                    continue
                d = np.float32(j * step)
                zq = depth[qy, qx]
                dz = zq - zp
                num = _HALF * (d * d * zp * zq * inv_f2 + dz * dz)
                for c in range(3):
                    pair = focal * root[y, x, c] * root[qy, qx, c]  # S_c (pixels)
                    if not (pair > _ZERO and d * d <= _NINE * pair * pair):
                        continue
                    wgt = fstep * exp2_f32(-num * _LOG2E / (sig[y, x, c] * sig[qy, qx, c])) / pair
                    acc[c] += wgt * (src[qy, qx, c] - src[y, x, c])
            for c in range(3):
                dst[y, x, c] = src[y, x, c] + acc[c]
