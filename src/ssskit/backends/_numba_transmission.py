"""numba kernel of the transmittance pass (:mod:`ssskit.backends.transmission_plan` for the maths): steps 1-5
per pixel of rows [y0, y1), float32, in the plan's order: steps 1-3 per pixel (the map lookup), steps 4-5 as
branch-free loops over the row that LLVM vectorises, the exponentials by
:func:`~ssskit.compute.numba_math.exp2_f32` (relative error 2.5e-7; clamped to 2^-126, a normal float, where the
term underflows). Pixels are independent, so the image does not
depend on the number of threads. Compiled once and cached on disk (``cache=True``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..compute.numba_math import FM32, exp2_f32

_ZERO = np.float32(0.0)
_ONE = np.float32(1.0)
_HALF = np.float32(0.5)


_LOG2E = np.float32(1.4426950408889634)


@njit(cache=True, nogil=True, fastmath=False)
def _row_geometry(slots, uvz, shadow, ndl, wrap, scale, normal, bias, y, u_row, e_row):  # pragma: no cover
    """Steps 1-3 of row y: u = scale t and the back irradiance factor e (0 where no transmission)."""
    hs, ws = shadow.shape
    w = slots.shape[1]
    for x in range(w):
        u_row[x] = _ZERO
        e_row[x] = _ZERO
        s = slots[y, x]
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
        if normal[s] > _ZERO:  # step 2: along the surface normal
            t = t * min(max(-ndl[y, x], _ZERO), _ONE)
        e = wrap[s] - ndl[y, x]  # step 3
        e_row[x] = min(max(e, _ZERO), _ONE)
        u_row[x] = scale[s] * t


@njit(cache=True, nogil=True, fastmath=FM32)
def _row_terms(slots, light, a, b, c, y, u_row, e_row, out):  # pragma: no cover
    """Steps 4-5 of row y: a branch-free loop over the pixels per (channel, term), exp by exp2_f32."""
    w = slots.shape[1]
    k_terms = a.shape[2]
    for ch in range(3):
        for x in range(w):
            out[y, x, ch] = _ZERO
        for k in range(k_terms):
            for x in range(w):
                s = slots[y, x]
                u = u_row[x]
                arg = -(b[s, ch, k] * u + c[s, ch, k] * u * u) * _LOG2E
                out[y, x, ch] += a[s, ch, k] * exp2_f32(arg)
        for x in range(w):
            out[y, x, ch] = out[y, x, ch] * (light[y, x, ch] * e_row[x])


@njit(cache=True, nogil=True)
def transmission_rows(slots, uvz, shadow, ndl, light, a, b, c, scale, wrap, normal, bias, out, y0,
                      y1):  # pragma: no cover
    w = slots.shape[1]
    u_row = np.empty(w, np.float32)
    e_row = np.empty(w, np.float32)
    for y in range(y0, y1):
        _row_geometry(slots, uvz, shadow, ndl, wrap, scale, normal, bias, y, u_row, e_row)
        _row_terms(slots, light, a, b, c, y, u_row, e_row, out)
