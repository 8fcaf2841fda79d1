"""numba kernel of the transmittance pass (:mod:`ssskit.backends.transmission_plan` for the maths): steps 1-5
per pixel of rows [y0, y1), float32, in the plan's order. Pixels are independent, so the image does not
depend on the number of threads. Compiled once and cached on disk (``cache=True``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_ZERO = np.float32(0.0)
_ONE = np.float32(1.0)
_HALF = np.float32(0.5)


@njit(cache=True, nogil=True, fastmath=False)
def transmission_rows(slots, uvz, shadow, ndl, light, a, b, c, scale, wrap, bias, out, y0, y1):  # pragma: no cover
    hs, ws = shadow.shape
    w = slots.shape[1]
    k_terms = a.shape[2]
    for y in range(y0, y1):
        for x in range(w):
            s = slots[y, x]
            out[y, x, 0] = _ZERO
            out[y, x, 1] = _ZERO
            out[y, x, 2] = _ZERO
            if s <= 0:
                continue
            px = uvz[y, x, 0] - _HALF
            py = uvz[y, x, 1] - _HALF
            if not (math.isfinite(px) and math.isfinite(py)):
                continue
            fi = math.floor(px)
            fj = math.floor(py)
            fx = px - np.float32(fi)
            fy = py - np.float32(fj)
            i0 = int(fi)
            j0 = int(fj)
            acc = _ZERO
            wsum = _ZERO
            for q in range(4):  # step 1: (0, 0), (1, 0), (0, 1), (1, 1)
                di = q & 1
                dj = q >> 1
                wx = fx if di else _ONE - fx
                wy = fy if dj else _ONE - fy
                wgt = wx * wy
                ii = i0 + di
                jj = j0 + dj
                if wgt > _ZERO and 0 <= ii < ws and 0 <= jj < hs:
                    d = shadow[jj, ii]
                    if math.isfinite(d):
                        acc += wgt * d
                        wsum += wgt
            if not wsum > _ZERO:
                continue
            t = uvz[y, x, 2] - acc / wsum  # step 2
            if not (math.isfinite(t) and t > bias):
                continue
            e = wrap[s] - ndl[y, x]  # step 3
            e = min(max(e, _ZERO), _ONE)
            u = scale[s] * t
            for ch in range(3):  # step 4-5
                tr = _ZERO
                for k in range(k_terms):
                    tr += a[s, ch, k] * np.float32(math.exp(-b[s, ch, k] * u - c[s, ch, k] * u * u))
                out[y, x, ch] = tr * (light[y, x, ch] * e)
