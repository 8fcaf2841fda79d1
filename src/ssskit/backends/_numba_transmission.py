"""numba kernel of the transmittance pass (:mod:`ssskit.backends.transmission_plan` for the maths): steps 1-5
per pixel of a range of the flattened frame, float32, in the plan's order, LANES contiguous pixels at a time
in lane loops that LLVM vectorises (no branches: every test of the plan is a select; the map's texels are
read at clamped 32-bit indices, two neighbours per 64-bit load
(:func:`~ssskit.compute.numba_math.load_pair_at`), and dropped by their weight; scratch on the stack,
:func:`~ssskit.compute.numba_math.stack_empty`, so no alias check stops the vectoriser; unsigned indices,
so numba adds no negative-index wraparound):

* lane set-up (steps 1-3): u = scale t and the back irradiance factor e per lane, both 0 where the plan
  gives no transmission (slot 0, off the map, t <= bias or not finite);
* steps 4-5 per channel and term, the exponentials by :func:`~ssskit.compute.numba_math.exp2_f32`
  (relative error 2.5e-7; clamped to 2^-126, a normal float, where the term underflows); a block whose
  lit lanes share one slot (the usual case) takes one sweep with that slot's coefficients, a block that
  straddles slots one sweep per slot present, each lane keeping its own slot's terms;
* an ``unreal`` slot (step 4's table): the table coordinate per lane, then per channel the two entries around it
  (32-bit gathers) and their linear filter;
* out = T(t) light e where the plan lights the pixel, else exactly 0.

Pixels are independent, so the image does not depend on the number of threads. Compiled once and cached
on disk (``cache=True``)."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..compute.numba_math import FM32, exp2_f32, i32, i32_madd, load_at, load_pair_at, stack_empty
from .transmission_plan import LUT_SIZE, UE_MAX_OPTICAL_DEPTH

#: pixels per lane loop
LANES = 32

_ZERO = np.float32(0.0)
_ONE = np.float32(1.0)
_HALF = np.float32(0.5)
_INF = np.float32(np.inf)
_LOG2E = np.float32(1.4426950408889634)
_L3 = 3 * LANES
_OD_MIN = np.float32(0.15)  # UE's CalculateOpticalDepth clamp and offset
_OD_MAX = np.float32(UE_MAX_OPTICAL_DEPTH)
_OD_ADD = np.float32(0.25)
_LUT_LAST = np.float32(LUT_SIZE - 1)

#: exp2_f32 inlined by numba into the kernel (LLVM's inliner leaves a call, which stops the vectoriser, once the
#: kernel is large)
_exp2 = njit(inline="always", fastmath=FM32)(exp2_f32.py_func)


@njit(cache=True, inline="always", fastmath=FM32)
def _finite(v):  # pragma: no cover
    """v is neither NaN nor infinite, as a select (|v| < inf is False for NaN)."""
    return abs(v) < _INF


@njit(cache=True, inline="always", fastmath=FM32, error_model="numpy")
def _slot_terms(lu_, ls, lt, lx, lf, sb, masked, ca, cb, cc, k_terms, kind, lut, odp, odo):  # pragma: no cover
    """Step 4 of slot ``sb`` into the lanes' T per channel ``lt`` (lanes of other slots untouched where ``masked``):
    the exponential sum, or an ``unreal`` slot's table lookup (UE's optical depth, its shadow-mask encoding, the
    linear filter)."""
    U = np.uintp
    if kind[sb] == 0:
        for ch in range(3):
            for k in range(k_terms):
                i = U((sb * 3 + ch) * k_terms + k)
                ak, bk, ck = ca[i], cb[i], cc[i]
                for l in range(LANES):
                    lu = U(l)
                    u = lu_[lu]
                    v = ak * _exp2((bk + ck * u) * u)
                    lt[U(ch * LANES) + lu] += (v if ls[lu] == sb else _ZERO) if masked else v
        return
    p, o = odp[sb], odo[sb]
    for l in range(LANES):  # the table coordinate x = (1 - e^2) (N - 1), e = 1 - OD / 5
        lu = U(l)
        d = min(max(p * lu_[lu] + o, _OD_MIN), _OD_MAX) + _OD_ADD
        e = _ONE - d / _OD_MAX
        x = (_ONE - e * e) * _LUT_LAST
        fi = min(np.floor(x), _LUT_LAST - _ONE)
        lx[lu] = i32(fi)
        lf[lu] = x - fi
    for ch in range(3):
        base = (sb * 3 + ch) * LUT_SIZE
        for l in range(LANES):
            lu = U(l)
            l0, l1 = load_pair_at(lut, i32(lx[lu] + base))
            f = lf[lu]
            v = (_ONE - f) * l0 + f * l1
            lt[U(ch * LANES) + lu] += (v if ls[lu] == sb else _ZERO) if masked else v


@njit(cache=True, nogil=True, fastmath=FM32, error_model="numpy")
def transmission_pixels(slots, uvz, shadow, ndl, light, a, b, c, scale, wrap, normal, bias, kind, lut, odp, odo, out,
                        p0, p1):  # pragma: no cover
    """Steps 1-5 for the pixels [p0, p1) of the flattened frame (module docstring), p1 - p0 >= LANES: blocks
    of LANES contiguous pixels, the last one moved back to end at p1 (its first pixels computed twice, to
    the same values). ``slots``, ``ndl`` (N,), ``uvz``, ``light``, ``out`` (3 N,) pixel-interleaved, ``shadow``
    (Hs, Ws >= 2), ``a``, ``b``, ``c`` (S, 3, K); ``normal`` (S,) 1 where step 2 takes the thickness along the
    surface normal; ``kind`` (S,) int32 1 for an ``unreal`` slot, whose table is
    ``lut`` (S 3 LUT_SIZE,) and optical depth ``odp`` t + ``odo``."""
    U = np.uintp
    hs, ws = shadow.shape
    k_terms = a.shape[2]
    mf = shadow.reshape(-1)
    # per slot, channel and term: a, -b log2(e), -c log2(e) (the exponent in base 2)
    ns = a.shape[0]
    ca = np.empty(ns * 3 * k_terms, np.float32)
    cb = np.empty(ns * 3 * k_terms, np.float32)
    cc = np.empty(ns * 3 * k_terms, np.float32)
    for si in range(ns):
        for ch in range(3):
            for k in range(k_terms):
                i = (si * 3 + ch) * k_terms + k
                ca[i] = a[si, ch, k]
                cb[i] = -b[si, ch, k] * _LOG2E
                cc[i] = -c[si, ch, k] * _LOG2E
    lu_ = stack_empty(LANES, np.float32)  # lane data: u = scale t, e, the slot (0: not lit)
    le = stack_empty(LANES, np.float32)
    ls = stack_empty(LANES, np.int32)
    lt = stack_empty(_L3, np.float32)  # T per channel
    lx = stack_empty(LANES, np.int32)  # an unreal slot's table index and fraction per lane
    lf = stack_empty(LANES, np.float32)
    fws = np.float32(ws)
    fhs = np.float32(hs)
    fws2 = np.float32(ws - 2)
    fhs1 = np.float32(hs - 1)
    for b0 in range(p0, p1, LANES):
        q0 = U(min(b0, p1 - LANES))
        smax = np.int32(0)
        smin = np.int32(1 << 30)
        for l in range(LANES):  # steps 1-3
            lu = U(l)
            p = q0 + lu
            s = slots[p]
            px = uvz[U(3) * p] - _HALF
            py = uvz[U(3) * p + U(1)] - _HALF
            ok = _finite(px) & _finite(py) & (s > 0)
            px = px if ok else _ZERO
            py = py if ok else _ZERO
            fi = np.floor(px)
            fj = np.floor(py)
            fx = px - fi
            fy = py - fj
            # the four texels as two pairs (row j0, j0 + 1; columns ci, ci + 1 = the map's, ci = i0 clamped to
            # [0, Ws - 2]): texel i0 is the pair's first where i0 = ci, else its second; texel i0 + 1 its second
            # where i0 = ci, else its first (texels off the map: dropped below)
            fci = min(max(fi, _ZERO), fws2)
            ci = i32(fci)
            first0 = fi == fci
            acc = _ZERO
            wsum = _ZERO
            for dj in range(2):
                jj = fj + np.float32(dj)
                wy = fy if dj else _ONE - fy
                in_row = (jj >= _ZERO) & (jj < fhs)
                m0, m1 = load_pair_at(mf, i32_madd(i32(min(max(jj, _ZERO), fhs1)), ws, ci))
                for di in range(2):
                    ii = fi + np.float32(di)
                    wgt = (fx if di else _ONE - fx) * wy
                    d = (m1 if di else m0) if first0 else (m0 if di else m1)
                    use = in_row & (ii >= _ZERO) & (ii < fws) & (wgt > _ZERO) & _finite(d)
                    acc += wgt * d if use else _ZERO
                    wsum += wgt if use else _ZERO
            t = uvz[U(3) * p + U(2)] - acc / wsum  # step 2 (NaN where wsum = 0: not lit)
            lit = ok & (wsum > _ZERO) & _finite(t) & (t > bias)
            tn = t * min(max(-ndl[p], _ZERO), _ONE)  # step 2: along the surface normal where the slot asks
            t = tn if load_at(normal, s) > _ZERO else t
            e = min(max(load_at(wrap, s) - ndl[p], _ZERO), _ONE)  # step 3
            lu_[lu] = load_at(scale, s) * t if lit else _ZERO
            le[lu] = e if lit else _ZERO
            sl = s if lit else np.int32(0)
            ls[lu] = sl
            smax = max(smax, sl)
            smin = min(smin, s if lit else np.int32(1 << 30))
        if smax == 0:  # no lit pixel in the block
            for l in range(_L3):
                out[U(3) * q0 + U(l)] = _ZERO
            continue
        for ch in range(3):
            for l in range(LANES):
                lt[U(ch * LANES + l)] = _ZERO
        if smin == smax:  # one slot for every lit lane (the unlit lanes' terms are masked in step 5)
            _slot_terms(lu_, ls, lt, lx, lf, smax, False, ca, cb, cc, k_terms, kind, lut, odp, odo)
        else:
            for sb in range(smin, smax + 1):  # a block that straddles slots: each slot present, its own lanes
                present = False
                for l in range(LANES):
                    present |= ls[U(l)] == sb
                if present:
                    _slot_terms(lu_, ls, lt, lx, lf, sb, True, ca, cb, cc, k_terms, kind, lut, odp, odo)
        for l in range(LANES):  # step 5
            lu = U(l)
            q3 = U(3) * (q0 + lu)
            e = le[lu]
            lit = ls[lu] > 0
            v0 = lt[lu] * (light[q3] * e)
            v1 = lt[U(LANES) + lu] * (light[q3 + U(1)] * e)
            v2 = lt[U(2 * LANES) + lu] * (light[q3 + U(2)] * e)
            out[q3] = v0 if lit else _ZERO
            out[q3 + U(1)] = v1 if lit else _ZERO
            out[q3 + U(2)] = v2 if lit else _ZERO
