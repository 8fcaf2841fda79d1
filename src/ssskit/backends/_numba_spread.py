"""numba kernels of the transmitted light's lateral spread (:mod:`ssskit.backends.spread_plan` for the maths):
steps 0-1 per pixel of rows [y0, y1) (:func:`sigma_rows`), then step 2 along one axis (:func:`spread_rows`),
float32, in the plan's order. Pixels are independent within a step, so the image does not depend on the number
of threads. Compiled once and cached on disk (``cache=True``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_ZERO = np.float32(0.0)
_ONE = np.float32(1.0)
_HALF = np.float32(0.5)
_THREE = np.float32(3.0)
_SQRT2PI = np.float32(2.5066282746310002)


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
def spread_rows(src, depth, slots, sig, focal, horizontal, min_px, max_taps, dst, y0, y1):  # pragma: no cover
    """Step 2 along one axis for rows [y0, y1): ``src`` (H, W, 3) -> ``dst``."""
    h, w = slots.shape
    spx = np.empty(3, np.float32)
    acc = np.empty(3, np.float32)
    for y in range(y0, y1):
        for x in range(w):
            s = slots[y, x]
            for c in range(3):
                dst[y, x, c] = src[y, x, c]
            if s <= 0:
                continue
            zp = depth[y, x]
            k_px = focal / zp
            m = _ZERO
            for c in range(3):
                spx[c] = sig[y, x, c] * k_px
                m = max(m, spx[c])
                acc[c] = _ZERO
            if m < min_px:
                continue
            step = max(1, int(math.ceil(_THREE * m / np.float32(max_taps))))
            kk = int(math.ceil(_THREE * m / np.float32(step)))
            fstep = np.float32(step)
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
                kq = focal / zq
                for c in range(3):
                    pair_px = math.sqrt(spx[c] * (sig[qy, qx, c] * kq))
                    if not (pair_px > _ZERO and abs(d) <= _THREE * pair_px):
                        continue
                    pair_mm = math.sqrt(sig[y, x, c] * sig[qy, qx, c])
                    wgt = (fstep * math.exp(-(d * d) / (np.float32(2.0) * pair_px * pair_px)) / (_SQRT2PI * pair_px)
                           * math.exp(-(dz * dz) / (np.float32(2.0) * pair_mm * pair_mm)))
                    acc[c] += wgt * (src[qy, qx, c] - src[y, x, c])
            for c in range(3):
                dst[y, x, c] = src[y, x, c] + acc[c]
