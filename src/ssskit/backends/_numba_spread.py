"""numba kernels of the transmitted light's lateral spread (:mod:`ssskit.backends.spread_plan` for the maths),
float32, in the plan's order, LANES contiguous pixels of a row at a time in lane loops that LLVM vectorises (no
branches: the plan's tests are selects; unsigned indices, so numba adds no negative-index wraparound; scratch on
the stack, :func:`~ssskit.compute.numba_math.stack_empty`).

Layout: one float32 array of planar (H, W) planes (``PLANES``, :func:`plane_stride` apart): the depth, the slot
(as a float), per channel a_c = 1 / sigma_c and g_c = sqrt(z / sigma_c) (both 0 where sigma_c = 0), the widest
sigma and the horizontal pass's result (the vertical pass reads them); the horizontal pass reads the same planes
and the frame's exitance from a padded copy of its row. With them the pair's terms need no root and no division
per tap: S_c = f / (g_p g_q) and

    w_c = step g_p g_q / (sqrt(2 pi) f) 2^(-log2(e) a_p a_q (d^2 z_p z_q / f^2 + dz^2) / 2),

the support |d| <= 3 S_c as |d| g_p g_q <= 3 f, one exponential (:func:`~ssskit.compute.numba_math.exp2_f32`,
relative error 2.5e-7, inlined so that the lane loops vectorise) per tap and channel.

* :func:`spread_h`, per row: steps 0-1 (:func:`_row_terms`: the map's bilinear depth as the transmittance pass
  reads it, :func:`~ssskit.backends._numba_transmission.transmission_pixels`' steps 1-2, the thickness, the
  widths interpolated in the slot's table, the planes; the row's smallest g_c > 0 and largest sigma_max / z),
  written both into the planes and into a scratch copy of the row padded by W on each side (pad texels are
  slot 0, so no bounds tests), then step 2 along x from that copy while it is in cache, the blocks' taps as
  contiguous loads;
* :func:`spread_v` (step 2 along y): out[y, x0:x0+LANES] from rows y + d of the planes, contiguous loads, the
  frame in column strips of ``STRIP`` pixels so that a strip's rows within the taps' reach stay in cache.

A block (:func:`_block`) groups its lanes by their tap step (a smooth width gives one group; each lane keeps
its own K) and sweeps each group's taps j = -K..K, one lane loop for the tap's common terms (validity, the
exponent's factor) and one per channel whose taps reach that far: channel c's weight is 0 beyond |d| = 3 f /
(g_c,min(block) g_c,min(frame)), which bounds the pair's S_c, so those taps are skipped without changing a value.
Each pixel's sum runs over its taps in the plan's order whatever the block, so the image does not depend on the
number of threads. Compiled once and cached on disk (``cache=True``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..compute.numba_math import FM32, bits_f32, exp2_f32, f32_bits, i32, i32_madd, load_at, load_pair_at, stack_empty

#: pixels per lane loop
LANES = 32
#: column strip of the vertical pass (pixels, a multiple of LANES)
STRIP = 128
#: plane indices: depth, slot, a_c (3), g_c (3), the widest sigma, the values (3: the exitance in the horizontal
#: pass's row copy, its result in the planes the vertical pass reads)
Z, SL, A, G, SM, V = 0, 1, 2, 5, 8, 9
PLANES = 12


def plane_stride(h: int, w: int) -> int:
    """The planes' stride (floats): H W rounded up to 4 KiB, plus one cache line, so that a pixel's planes fall
    in different sets of the L1 cache (at a multiple of 4 KiB apart the vertical pass's 11 loads per tap all
    land in one set and evict each other)."""
    return -(-h * w // 1024) * 1024 + 16


_L3 = 3 * LANES
_L4 = 4 * LANES
_L8 = 8 * LANES
_LV = V * LANES

_ZERO = np.float32(0.0)
_ONE = np.float32(1.0)
_HALF = np.float32(0.5)
_THREE = np.float32(3.0)
_INF = np.float32(np.inf)
_SQRT2PI = 2.5066282746310002
_NLOG2E_2 = np.float32(-0.5 * 1.4426950408889634)  # -log2(e) / 2
_STEP_MAX = np.float32(2.0**24)  # a wider step reaches off any image: the lane has no tap
_INF_BITS = 0x7F800000
_EXP_MIN = np.float32(-100.0)  # 2^-100: the weights stay normal numbers (a subnormal product costs ~40 %)
_NO_STEP = np.int32(1 << 30)

#: exp2_f32 inlined by numba into the lane loops (LLVM leaves a call, which stops the vectoriser)
_exp2 = njit(inline="always", fastmath=FM32)(exp2_f32.py_func)


@njit(cache=True, inline="always", fastmath=FM32)
def _finite(v):  # pragma: no cover
    return abs(v) < _INF


@njit(cache=True, inline="always")
def _knot_below(knots, base, n, t):  # pragma: no cover
    """The plan's k for thickness t: the number of knots 1 .. n - 2 below t (the segment [k, k + 1] holds t)."""
    k = 0
    while k < n - 2 and knots[base + k + 1] < t:
        k += 1
    return k


@njit(cache=True, nogil=True, fastmath=FM32, error_model="numpy")
def _widths(s, t, knots, table, n_knots, nk, lw, lu):  # pragma: no cover
    """Step 1 for one pixel of slot s at thickness t into lw[c LANES + lu] (0 for slot 0)."""
    n = n_knots[s]
    base = s * nk
    k = _knot_below(knots, base, n, t)
    k0 = knots[base + k]
    fr = (t - k0) / (knots[base + min(k + 1, n - 1)] - k0) if n > 1 else _ZERO
    for c in range(3):
        row = (s * 3 + c) * nk
        if s <= 0:
            v = _ZERO
        elif n == 1 or t <= knots[base]:
            v = table[row]
        elif t >= knots[base + n - 1]:
            v = table[row + n - 1]
        else:
            v = table[row + k] + fr * (table[row + k + 1] - table[row + k])
        lw[np.uintp(c * LANES) + lu] = v


@njit(cache=True, nogil=True, fastmath=FM32, error_model="numpy")
def _row_terms(slots, uvz, shadow, hs, ws, src, depth, knots, table, n_knots, nk, bias, rs, rw, pad, pl, stats, w,
               lanes, y):  # pragma: no cover
    """Steps 0-1 for row y: its planes 0 .. V + 2 into the row copy ``rs`` (plane stride ``rw``, pixel x at pad +
    x), planes 0 .. SM into ``pl`` (PLANES planes), and ``stats`` (4 H,): the row's smallest g_c > 0 (+inf if
    none) and largest sigma_max / z over the slots' pixels (0 if none). Flat inputs: ``slots`` (H W,) int32,
    ``uvz``, ``src`` (3 H W,), ``depth`` (H W,), ``shadow`` (Hs Ws,), Ws >= 2; ``knots`` (S NK + 1,), ``table``
    (3 S NK + 1,) (one element of padding), ``n_knots`` (S,) int32; W >= LANES."""
    U = np.uintp
    ps = U(pl.size // PLANES)
    fws, fhs = np.float32(ws), np.float32(hs)
    fws2, fhs1 = np.float32(ws - 2), np.float32(hs - 1)
    lt = stack_empty(LANES, np.float32)
    ls = stack_empty(LANES, np.int32)
    lb = stack_empty(_L8, np.float32)  # per lane the bracketing knots and widths
    lw = stack_empty(_L3, np.float32)  # per lane sigma_c
    lv = stack_empty(_L3, np.float32)
    lz = stack_empty(LANES, np.float32)
    lg = stack_empty(_L4, np.int32)  # per lane: the bits of g_c (inf if 0) and of sigma_max / z
    lo = stack_empty(_LV, np.float32)  # per lane the planes 0 .. V - 1
    gmin0 = gmin1 = gmin2 = np.int32(_INF_BITS)
    mmax = np.int32(0)
    for x0 in range(0, w, LANES):
        bx = min(x0, w - LANES)
        b0 = U(y * w + bx)
        r0_ = U(pad + bx)
        smin = np.int32(1 << 30)
        smax = np.int32(-1)
        for l in range(LANES):  # step 0: the thickness
            lu = U(l)
            p = b0 + lu
            s = slots[p]
            px = uvz[U(3) * p] - _HALF
            py = uvz[U(3) * p + U(1)] - _HALF
            ok = _finite(px) & _finite(py) & (s > 0)
            px = px if ok else _ZERO
            py = py if ok else _ZERO
            # the transmittance pass's steps 1-2 (_numba_transmission.transmission_pixels), the same lines: shared as
            # an inline function (numba 0.68) they made that pass 2-3 times slower, so each kernel has its copy
            fi = np.floor(px)
            fj = np.floor(py)
            fx = px - fi
            fy = py - fj
            fci = min(max(fi, _ZERO), fws2)
            ci = i32(fci)
            first0 = fi == fci
            acc = _ZERO
            wsum = _ZERO
            for dj in range(2):
                jj = fj + np.float32(dj)
                wy = fy if dj else _ONE - fy
                in_row = (jj >= _ZERO) & (jj < fhs)
                m0, m1 = load_pair_at(shadow, i32_madd(i32(min(max(jj, _ZERO), fhs1)), ws, ci))
                for di in range(2):
                    ii = fi + np.float32(di)
                    wgt = (fx if di else _ONE - fx) * wy
                    d = (m1 if di else m0) if first0 else (m0 if di else m1)
                    use = in_row & (ii >= _ZERO) & (ii < fws) & (wgt > _ZERO) & _finite(d)
                    acc += wgt * d if use else _ZERO
                    wsum += wgt if use else _ZERO
            t = uvz[U(3) * p + U(2)] - acc / wsum
            use = ok & (wsum > _ZERO) & _finite(t) & (t > bias)
            lt[lu] = t if use else _ZERO
            ls[lu] = s
            smin = min(smin, s)
            smax = max(smax, s)
        if smin == smax and smin > 0:  # one slot: the bracketing knots by a sweep over the block's range of t
            base = smin * nk
            n = n_knots[smin]
            r0, r1, r2 = base * 3, base * 3 + nk, base * 3 + 2 * nk
            tlo = np.int32(_INF_BITS)
            thi = np.int32(0)
            for l in range(lanes):  # t >= 0: its bits order as its values
                tb = f32_bits(lt[U(l)])
                tlo = min(tlo, tb)
                thi = max(thi, tb)
            k0 = _knot_below(knots, base, n, bits_f32(tlo))
            k1 = _knot_below(knots, base, n, bits_f32(thi))
            i1 = min(k0 + 1, n - 1)
            for l in range(lanes):
                lu = U(l)
                lb[lu] = knots[base + k0]
                lb[U(LANES) + lu] = knots[base + i1]
                lb[U(2 * LANES) + lu] = table[r0 + k0]
                lb[U(3 * LANES) + lu] = table[r0 + i1]
                lb[U(4 * LANES) + lu] = table[r1 + k0]
                lb[U(5 * LANES) + lu] = table[r1 + i1]
                lb[U(6 * LANES) + lu] = table[r2 + k0]
                lb[U(7 * LANES) + lu] = table[r2 + i1]
            for i in range(k0 + 1, k1 + 1):
                kv, kv1 = knots[base + i], knots[base + i + 1]
                a0, a1, b0_, b1, c0, c1 = (table[r0 + i], table[r0 + i + 1], table[r1 + i], table[r1 + i + 1],
                                           table[r2 + i], table[r2 + i + 1])
                for l in range(lanes):
                    lu = U(l)
                    up = kv < lt[lu]
                    lb[lu] = kv if up else lb[lu]
                    lb[U(LANES) + lu] = kv1 if up else lb[U(LANES) + lu]
                    lb[U(2 * LANES) + lu] = a0 if up else lb[U(2 * LANES) + lu]
                    lb[U(3 * LANES) + lu] = a1 if up else lb[U(3 * LANES) + lu]
                    lb[U(4 * LANES) + lu] = b0_ if up else lb[U(4 * LANES) + lu]
                    lb[U(5 * LANES) + lu] = b1 if up else lb[U(5 * LANES) + lu]
                    lb[U(6 * LANES) + lu] = c0 if up else lb[U(6 * LANES) + lu]
                    lb[U(7 * LANES) + lu] = c1 if up else lb[U(7 * LANES) + lu]
            kfirst, klast = knots[base], knots[base + n - 1]
            for l in range(LANES):
                lu = U(l)
                t = lt[lu]
                k0 = lb[lu]
                fr = (t - k0) / (lb[U(LANES) + lu] - k0)
                first = (n == 1) | (t <= kfirst)
                last = t >= klast
                for c in range(3):
                    v0 = lb[U((2 + 2 * c) * LANES) + lu]
                    v = v0 + fr * (lb[U((3 + 2 * c) * LANES) + lu] - v0)
                    v = table[base * 3 + c * nk + n - 1] if last else v
                    lw[U(c * LANES) + lu] = table[base * 3 + c * nk] if first else v
        else:  # a block that straddles slots (or none): each lane on its own
            for l in range(LANES):
                lu = U(l)
                _widths(ls[lu], lt[lu], knots, table, n_knots, nk, lw, lu)
        for l in range(LANES):  # the frame's values into the stack (the next loop reads no argument)
            lu = U(l)
            p = b0 + lu
            lz[lu] = depth[p]
            for c in range(3):
                lv[U(c * LANES) + lu] = src[U(3) * p + U(c)]
        for l in range(LANES):  # the planes: into the stack, then copied
            lu = U(l)
            s = ls[lu]
            z = lz[lu] if s > 0 else _ONE
            sm = _ZERO
            for c in range(3):
                v = lw[U(c * LANES) + lu]
                a = _ONE / v if v > _ZERO else _ZERO
                g = math.sqrt(z * a)
                lo[U((A + c) * LANES) + lu] = a
                lo[U((G + c) * LANES) + lu] = g
                sm = max(sm, v)
                lg[U(c * LANES) + lu] = f32_bits(g) if g > _ZERO else np.int32(_INF_BITS)
            lo[lu] = z if s > 0 else _ZERO
            lo[U(SL * LANES) + lu] = np.float32(s)
            lo[U(SM * LANES) + lu] = sm
            lg[U(3 * LANES) + lu] = f32_bits(sm / z)
        for k in range(V):
            ok_ = U(k * LANES)
            orow = U(k * rw) + r0_
            opl = ps * U(k) + b0
            for l in range(LANES):
                v = lo[ok_ + U(l)]
                rs[orow + U(l)] = v
                pl[opl + U(l)] = v
        for c in range(3):
            oc = U(c * LANES)
            orow = U((V + c) * rw) + r0_
            for l in range(LANES):
                rs[orow + U(l)] = lv[oc + U(l)]
        for l in range(LANES):
            lu = U(l)
            gmin0 = min(gmin0, lg[lu])
            gmin1 = min(gmin1, lg[U(LANES) + lu])
            gmin2 = min(gmin2, lg[U(2 * LANES) + lu])
            mmax = max(mmax, lg[U(3 * LANES) + lu])
    o = U(4 * y)
    stats[o] = bits_f32(gmin0)
    stats[o + U(1)] = bits_f32(gmin1)
    stats[o + U(2)] = bits_f32(gmin2)
    stats[o + U(3)] = bits_f32(mmax)


@njit(cache=True, inline="always")
def _last_tap(kk, focal, gb, gm, st):  # pragma: no cover
    """min(kk, the last j whose |j st| <= 3 f / (g_block g_frame) with a margin of 1e-4), 0 where either g is none
    (the bits of +inf)."""
    if gb >= np.int32(_INF_BITS) or not gm < _INF:
        return 0
    return min(int(kk), int(3.0 * focal / (float(bits_f32(gb)) * float(gm)) * 1.0001 / st))


@njit(cache=True, nogil=True, fastmath=FM32, error_model="numpy")
def _block(arr, ps, vb, p, dstride, dlo, dhi, focal, min_px, max_taps, gmf, res, lanes):  # pragma: no cover
    """Step 2 for the LANES pixels at offsets p .. p + LANES - 1 of the planes in ``arr`` (plane stride ``ps``;
    the values in planes vb .. vb + 2): the tap at distance d lies at offset + d ``dstride`` and is read only for
    dlo <= d <= dhi (beyond: off the image). ``gmf`` (3,) the frame's smallest g_c > 0. The results (3 LANES,
    planar) into ``res``."""
    U = np.uintp
    lz = stack_empty(LANES, np.float32)
    lsl = stack_empty(LANES, np.float32)
    lhz = stack_empty(LANES, np.float32)
    lst = stack_empty(LANES, np.int32)  # the lane's step, _NO_STEP where it has no taps
    lkk = stack_empty(LANES, np.int32)  # its K (-1: no taps)
    lgb = stack_empty(_L3, np.int32)  # the bits of g_c > 0 (of +inf where 0)
    lkg = stack_empty(LANES, np.float32)  # its K within the group swept, -1 outside it
    la = stack_empty(_L3, np.float32)
    lg = stack_empty(_L3, np.float32)
    lv = stack_empty(_L3, np.float32)
    acc = stack_empty(_L3, np.float32)
    lnum = stack_empty(LANES, np.float32)  # a tap's exponent factor and validity per lane
    lthr = stack_empty(LANES, np.float32)
    lgc = stack_empty(_L3, np.float32)
    fl = np.float32(focal)
    kz = _NLOG2E_2 / (fl * fl)
    ftaps = np.float32(max_taps)
    pu = U(p)
    stmin = _NO_STEP
    stmax = np.int32(0)
    kall = np.int32(-1)
    gall0 = gall1 = gall2 = np.int32(_INF_BITS)
    for l in range(lanes):  # the lanes' terms, and over the lanes with taps: the steps' range, the largest K and
        # the smallest g_c
        lu = U(l)
        q = pu + lu
        z = arr[q]
        s = arr[ps * U(SL) + q]
        m = arr[ps * U(SM) + q] * (fl / z)
        stf = max(_ONE, np.ceil(_THREE * m / ftaps))
        act = (s > _ZERO) & (m >= min_px) & (stf < _STEP_MAX)
        stf = stf if act else _ONE
        lz[lu] = z
        lsl[lu] = s
        lhz[lu] = kz * z
        sti = i32(stf) if act else _NO_STEP
        ki = i32(np.ceil(_THREE * m / stf)) if act else np.int32(-1)
        lst[lu] = sti
        lkk[lu] = ki
        lkg[lu] = np.float32(ki)
        stmin = min(stmin, sti)
        stmax = max(stmax, sti if act else np.int32(0))
        kall = max(kall, ki)
        for c in range(3):
            o = U(c * LANES) + lu
            la[o] = arr[ps * U(A + c) + q]
            g = arr[ps * U(G + c) + q]
            lg[o] = g
            gb = f32_bits(g) if (g > _ZERO) & act else np.int32(_INF_BITS)
            lgb[o] = gb
            if c == 0:
                gall0 = min(gall0, gb)
            elif c == 1:
                gall1 = min(gall1, gb)
            else:
                gall2 = min(gall2, gb)
            lv[o] = arr[ps * U(vb + c) + q]
            acc[o] = _ZERO
    single = stmin == stmax  # every lane with taps has the same step (the usual case): one group, found above
    st = stmin
    while st < _NO_STEP:  # each step present, smallest first
        if single:
            kk, gb0, gb1, gb2, nxt = kall, gall0, gall1, gall2, _NO_STEP
        else:
            kk = np.int32(-1)
            gb0 = gb1 = gb2 = np.int32(_INF_BITS)
            nxt = _NO_STEP
            for l in range(lanes):  # the group's lanes: their K (-1 for the others), the largest K, smallest g_c
                lu = U(l)
                sl_ = lst[lu]
                ing = sl_ == st
                k = lkk[lu] if ing else np.int32(-1)
                lkg[lu] = np.float32(k)
                kk = max(kk, k)
                gb0 = min(gb0, lgb[lu] if ing else np.int32(_INF_BITS))
                gb1 = min(gb1, lgb[U(LANES) + lu] if ing else np.int32(_INF_BITS))
                gb2 = min(gb2, lgb[U(2 * LANES) + lu] if ing else np.int32(_INF_BITS))
                nxt = min(nxt, sl_ if sl_ > st else _NO_STEP)
        # per channel the last tap whose weight can be > 0: |d| <= 3 S_c = 3 f / (g_p g_q) (a margin of 1e-4 over
        # float32's roundings)
        kc0 = _last_tap(kk, focal, gb0, gmf[0], st)
        kc1 = _last_tap(kk, focal, gb1, gmf[1], st)
        kc2 = _last_tap(kk, focal, gb2, gmf[2], st)
        kc = max(kc0, max(kc1, kc2))
        cst = np.float32(st / (_SQRT2PI * focal))
        for c in range(3):  # g_p step / (sqrt(2 pi) f)
            oc = U(c * LANES)
            for l in range(lanes):
                lgc[oc + U(l)] = cst * lg[oc + U(l)]
        for j in range(-kc, kc + 1):
            d = j * st
            if j == 0 or d < dlo or d > dhi:
                continue
            qo = U(p + d * dstride)
            fd = np.float32(d)
            d2 = fd * fd
            thr = (_THREE * fl) * cst / abs(fd)  # |d| <= 3 S_c as the weight's factor cst g_p g_q <= thr
            aj = np.float32(abs(j))
            for l in range(LANES):  # the tap's common terms: the exponent's factor, the bound (-1: no tap)
                lu = U(l)
                q = qo + lu
                zq = arr[q]
                dz = zq - lz[lu]
                lnum[lu] = (d2 * lhz[lu]) * zq + _NLOG2E_2 * (dz * dz)
                ok = (arr[ps * U(SL) + q] == lsl[lu]) & (aj <= lkg[lu])
                lthr[lu] = thr if ok else -_ONE
            for c in range(3):
                if abs(j) > (kc0 if c == 0 else (kc1 if c == 1 else kc2)):
                    continue
                oa = ps * U(A + c) + qo
                og = ps * U(G + c) + qo
                ov = ps * U(vb + c) + qo
                oc = U(c * LANES)
                for l in range(LANES):
                    lu = U(l)
                    gg = lgc[oc + lu] * arr[og + lu]
                    ex = _exp2(max(lnum[lu] * (la[oc + lu] * arr[oa + lu]), _EXP_MIN))
                    wgt = gg * ex if gg <= lthr[lu] else _ZERO
                    acc[oc + lu] += wgt * (arr[ov + lu] - lv[oc + lu])
        st = nxt
    for c in range(3):
        oc = U(c * LANES)
        for l in range(lanes):
            lu = U(l)
            res[oc + lu] = lv[oc + lu] + acc[oc + lu]


@njit(cache=True, nogil=True, fastmath=FM32, error_model="numpy")
def spread_h(slots, uvz, shadow, hs, ws, src, depth, knots, table, n_knots, nk, bias, pl, stats, w, focal, min_px,
             max_taps, lanes, y0, y1):  # pragma: no cover
    """Steps 0-1 (:func:`_row_terms`) and step 2 along x for rows [y0, y1): the row's planes into a row copy
    padded by W on both sides (pad texels are slot 0: no bounds tests), the taps from it, the result into the
    planes V .. V + 2 of ``pl``; the planes the vertical pass reads and ``stats`` as :func:`_row_terms` writes
    them."""
    U = np.uintp
    ps = pl.size // PLANES
    pad = w
    rw = w + 2 * pad
    rs = np.zeros((V + 3) * rw, np.float32)  # planes 0 .. V + 2 of one row, padded
    res = stack_empty(_L3, np.float32)
    gmr = np.empty(3, np.float32)
    for y in range(y0, y1):
        _row_terms(slots, uvz, shadow, hs, ws, src, depth, knots, table, n_knots, nk, bias, rs, rw, pad, pl, stats, w,
                   lanes, y)
        if stats[4 * y + 3] == _ZERO:  # no pixel wide enough (or none in a slot): the row keeps its values
            for c in range(3):
                orow = U((V + c) * rw + pad)
                ot = U(ps * (V + c) + y * w)
                for x in range(w):
                    pl[ot + U(x)] = rs[orow + U(x)]
            continue
        for c in range(3):  # the taps' partners lie in this row: its smallest g_c bounds their widths
            gmr[c] = stats[4 * y + c]
        for x0 in range(0, w, LANES):
            bx = min(x0, w - LANES)
            _block(rs, U(rw), V, pad + bx, 1, 1 - w, w - 1, focal, min_px, max_taps, gmr, res, lanes)
            for c in range(3):
                ot = U(ps * (V + c) + y * w + bx)
                oc = U(c * LANES)
                for l in range(LANES):
                    pl[ot + U(l)] = res[oc + U(l)]


@njit(cache=True, nogil=True, fastmath=FM32, error_model="numpy")
def spread_v(pl, stats, gmf, w, focal, min_px, max_taps, out, lanes, y0, y1):  # pragma: no cover
    """Step 2 along y for rows [y0, y1): the horizontal pass's planes -> ``out`` (3 H W,), pixel-interleaved."""
    U = np.uintp
    h = stats.size // 4
    ps = U(pl.size // PLANES)
    res = stack_empty(_L3, np.float32)
    for xs in range(0, w, STRIP):
        for y in range(y0, y1):
            row = y * w
            if stats[4 * y + 3] == _ZERO:  # no pixel of the row in a slot: it keeps its values
                for x in range(xs, min(xs + STRIP, w)):
                    for c in range(3):
                        out[U(3 * (row + x) + c)] = pl[ps * U(V + c) + U(row + x)]
                continue
            for x0 in range(xs, min(xs + STRIP, w), LANES):
                bx = min(x0, w - LANES)
                _block(pl, ps, V, row + bx, w, -y, h - 1 - y, focal, min_px, max_taps, gmf, res, lanes)
                for l in range(LANES):
                    o = U(3 * (row + bx + l))
                    for c in range(3):
                        out[o + U(c)] = res[U(c * LANES + l)]
