"""numba kernels of the separable pass (:mod:`ssskit.backends.plan` for the maths; float32).

Layout. Both 1D passes read *planar, padded* buffers: colour planes R, G, B (``col``) and a depth
plane and a slot plane (``zs``), each (H + 2 pad) rows of ``wps`` = W + 2 pad + LANES texels. Pads
hold depth +inf and slot 0, so a texel is valid exactly when its slot equals the centre's: no
bounds tests. Tap distances are clamped to ``cap`` = pad - 3 pixels; pad covers the largest tap
reach or, for taps reaching past the image diagonal, the diagonal (a clamped tap still lands off
the image, where it is invalid anyway).

Work is done in blocks of LANES pixels along a row, written so that LLVM vectorises the lane loops
(contiguous loads, unsigned indices: numba's negative-index wraparound makes every address a
select that blocks vectorisation):

* plain rows (unjittered taps): the integer part m of a tap's footprint o s(x) changes by at most 1
  across a block (depth is smooth), so with m0 = min m the three texels m0, m0+1, m0+2 on each side,
  weighted by the hat function of o s - m0, give every lane's bilinear sample from contiguous loads;
  blocks where m spans more take a per-lane loop;
* jittered rows (paper section 6: axes rotated by a per-pixel angle): every lane's two samples
  p +- v lie in the (2R+1)^2 window of texels around it (R = ceil(max |v|) over the block); the
  window is swept with contiguous loads and each texel weighted by the separable hat weights
  hat(vx - i) hat(vy - j) of the + sample plus hat(vx + i) hat(vy + j) of the - sample, which is
  exactly the two 2D bilinear fetches. Windows wider than R = RMAX use per-lane 2D bilinear fetches;
* blocks that straddle two profile slots take a per-lane loop with each lane's own tap table.

The jitter angle comes from the same counter-based hash as the other backends
(:mod:`ssskit.sampling.hashes`); its cosine and sine are evaluated by a vectorisable polynomial
(error < 1e-11) instead of libm calls.

Every kernel is compiled once per depth mode (the mode's factor function inlined) and cached on
disk (``cache=True``), so a new process compiles nothing it compiled before. The passes release the
GIL and run over ranges of rows; the backend runs the ranges on a thread pool (rows are independent,
so the result does not depend on the number of threads).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

_FM = {"nsz", "arcp", "contract", "afn", "reassoc"}  # no 'nnan'/'ninf': +inf marks empty texels
LANES = 16
RMAX = 2
_L = LANES
_W = 2 * RMAX + 1


@njit(cache=True, inline="always", fastmath=_FM)
def f_gaussian(dz, p):
    """Supplement E: exp(-d_z^2 p), p = 1 / (2 tau_max)."""
    return np.float32(math.exp(-dz * dz * p))


@njit(cache=True, inline="always", fastmath=_FM)
def f_follow(dz, p):
    """Follow-surface test: max(0, 1 - |d_z| p), p = 1 / width."""
    return max(np.float32(0.0), np.float32(1.0) - abs(dz) * p)


@njit(cache=True, inline="always", fastmath=_FM)
def f_none(dz, p):
    """No depth test: 1 unless the texel has no surface (infinite depth)."""
    return np.float32(1.0) if abs(dz) < np.float32(np.inf) else np.float32(0.0)


@njit(cache=True, inline="always")
def _mix32(h):
    """lowbias32 (ssskit.sampling.hashes.mix32) on a uint64 holding 32 bits."""
    h = h ^ (h >> np.uint64(16))
    h = (h * np.uint64(0x7FEB352D)) & np.uint64(0xFFFFFFFF)
    h = h ^ (h >> np.uint64(15))
    h = (h * np.uint64(0x846CA68B)) & np.uint64(0xFFFFFFFF)
    return h ^ (h >> np.uint64(16))


@njit(cache=True, inline="always", fastmath=_FM)
def _unit(h):
    """(cos theta, sin theta) for theta = 2 pi h / 2^32: quadrant q = h >> 30, then the angle
    psi = pi/2 f in the quadrant (f the low 30 bits / 2^30) as pi/4 + phi with |phi| <= pi/4, whose
    sine and cosine are Taylor polynomials to phi^11 / phi^12 (error < 1e-11)."""
    q = h >> np.uint64(30)
    f = float(h & np.uint64(0x3FFFFFFF)) * (1.0 / 1073741824.0)
    phi = (f - 0.5) * (0.5 * math.pi)
    x2 = phi * phi
    s = phi * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0 * (1.0 - x2 / 110.0)))))
    c = 1.0 - x2 / 2.0 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0 * (1.0 - x2 / 56.0 * (1.0 - x2 / 90.0 * (
        1.0 - x2 / 132.0)))))
    r = 0.7071067811865476
    cp = (c - s) * r  # cos(pi/4 + phi)
    sp = (s + c) * r  # sin(pi/4 + phi)
    odd = (q & np.uint64(1)) != np.uint64(0)  # rotate by q quarter turns, without branches
    neg = 1.0 - 2.0 * float((q >> np.uint64(1)) & np.uint64(1))
    return neg * (-sp if odd else cp), neg * (cp if odd else sp)


# With several profile slots a block checks the block-slot map (``block_slots``) over the rows and blocks
# its taps reach: where no other profile is there it skips the per-texel slot test.
# Layout of the frame buffer ``buf`` (planes of (H + 2 pad) x wps texels): input colour R, G, B; depth; slot;
# the horizontal pass's colour R', G', B'. Per-row scratch ``sc``: the accumulators (6 x LANES: A_R, A_G,
# A_B, G_R, G_G, G_B), the lane data (5 x LANES: depth, slot, pixels per mm, jitter axis x, y) and the
# jitter window's hat weights (2 x (2 RMAX + 1) x LANES). Two arrays in every hot loop: LLVM vectorises.
PLANES = 8
Z_PLANE, S_PLANE, TMP_PLANE = 3, 4, 5
_LN = 6 * _L  # lane data offset in sc
_HX = 11 * _L  # hat weights offset in sc
SCRATCH = 11 * _L + 2 * _W * _L


@njit(cache=True, inline="always", fastmath=_FM)
def _tex(factor, buf, zo, so, i, z0, s0, p, multi):
    """Depth factor x slot test of texel i (flat index) for a centre at depth z0 in slot s0. With a
    single slot (``multi`` False, a constant at every call site) the test is the depth's finiteness,
    which every factor already applies."""
    f = factor(buf[zo + i] - z0, p)
    return f * np.float32(buf[so + i] == s0) if multi else f


@njit(cache=True, inline="always", fastmath=_FM)
def _accumulate(sc, lu, w, gp, gm, sp0, sp1, sp2, sm0, sm1, sm2, sym):
    """Accumulators += the + and - samples of one row; w = the row's weights (w+_R, w+_G, w+_B, w-_R,
    w-_G, w-_B), scalars; ``sym`` (a constant at every call site): w+ == w- (a symmetric pair)."""
    U = np.uintp
    if sym:
        gs = gp + gm
        sc[lu] += w[0] * (sp0 + sm0)
        sc[U(_L) + lu] += w[1] * (sp1 + sm1)
        sc[U(2 * _L) + lu] += w[2] * (sp2 + sm2)
        sc[U(3 * _L) + lu] += w[0] * gs
        sc[U(4 * _L) + lu] += w[1] * gs
        sc[U(5 * _L) + lu] += w[2] * gs
        return
    sc[lu] += w[0] * sp0 + w[3] * sm0
    sc[U(_L) + lu] += w[1] * sp1 + w[4] * sm1
    sc[U(2 * _L) + lu] += w[2] * sp2 + w[5] * sm2
    sc[U(3 * _L) + lu] += w[0] * gp + w[3] * gm
    sc[U(4 * _L) + lu] += w[1] * gp + w[4] * gm
    sc[U(5 * _L) + lu] += w[2] * gp + w[5] * gm


@njit(cache=True, inline="always", fastmath=_FM)
def _bilinear(factor, buf, co, zo, so, plane, wps, c, vx, vy, z0, s0, p, multi):
    """2D bilinear sample at (vx, vy) pixels from flat index c: (g, S_R, S_G, S_B), each texel with
    its own depth factor and slot test."""
    U = np.uintp
    fx = np.floor(vx)
    fy = np.floor(vy)
    tx = np.float32(vx - fx)
    ty = np.float32(vy - fy)
    i = U(c + int(fy) * wps + int(fx))
    one = np.float32(1.0)
    g = s0_ = s1 = s2 = np.float32(0.0)
    for k in range(4):
        di = U(k & 1)
        dj = U(k >> 1)
        b = (tx if di else one - tx) * (ty if dj else one - ty)
        t = i + di + dj * U(wps)
        gt = b * _tex(factor, buf, zo, so, t, z0, s0, p, multi)
        g += gt
        s0_ += gt * buf[co + t]
        s1 += gt * buf[co + U(plane) + t]
        s2 += gt * buf[co + U(2 * plane) + t]
    return g, s0_, s1, s2


@njit(cache=True, inline="always", fastmath=_FM)
def _lane_row(factor, buf, sc, co, zo, so, plane, wps, c, rho, ux, uy, z0, s0, p, w, l):
    """One row for one lane by 2D bilinear fetches at +-rho (ux, uy) (slot test always on)."""
    gp, a0, a1, a2 = _bilinear(factor, buf, co, zo, so, plane, wps, c, rho * ux, rho * uy, z0, s0, p, True)
    gm, b0, b1, b2 = _bilinear(factor, buf, co, zo, so, plane, wps, c, -rho * ux, -rho * uy, z0, s0, p, True)
    _accumulate(sc, np.uintp(l), w, gp, gm, a0, a1, a2, b0, b1, b2, False)


@njit(cache=True, inline="always", fastmath=_FM)
def _row_block(factor, buf, sc, co, zo, so, plane, c0, st, nl, d, mmin, w, p, cap, multi, sym):
    """A plain row for a block of lanes in one slot whose footprints' integer parts lie in
    [mmin, mmin + 1] (module docstring)."""
    U = np.uintp
    one = np.float32(1.0)
    zero = np.float32(0.0)
    mi = int(mmin)
    bp = U(c0 + mi * st)  # + side: texels m0, m0 + 1, m0 + 2
    bm = U(c0 - mi * st - 2 * st)  # - side: texels -m0 - 2, -m0 - 1, -m0
    s1 = U(st)
    s2 = U(2 * st)
    c1 = co + U(plane)
    c2 = co + U(2 * plane)
    for l in range(nl):
        lu = U(l)
        z0 = sc[U(_LN) + lu]
        q0 = sc[U(_LN + _L) + lu]
        tp = min(d * sc[U(_LN + 2 * _L) + lu], cap) - mmin
        h0 = max(zero, one - tp)
        h1 = max(zero, one - abs(tp - one))
        h2 = max(zero, tp - one)
        a = bp + lu
        b = bm + lu
        g0 = h0 * _tex(factor, buf, zo, so, a, z0, q0, p, multi)
        g1 = h1 * _tex(factor, buf, zo, so, a + s1, z0, q0, p, multi)
        g2 = h2 * _tex(factor, buf, zo, so, a + s2, z0, q0, p, multi)
        n2 = h2 * _tex(factor, buf, zo, so, b, z0, q0, p, multi)
        n1 = h1 * _tex(factor, buf, zo, so, b + s1, z0, q0, p, multi)
        n0 = h0 * _tex(factor, buf, zo, so, b + s2, z0, q0, p, multi)
        _accumulate(sc, lu, w, g0 + g1 + g2, n0 + n1 + n2,
                    g0 * buf[co + a] + g1 * buf[co + a + s1] + g2 * buf[co + a + s2],
                    g0 * buf[c1 + a] + g1 * buf[c1 + a + s1] + g2 * buf[c1 + a + s2],
                    g0 * buf[c2 + a] + g1 * buf[c2 + a + s1] + g2 * buf[c2 + a + s2],
                    n2 * buf[co + b] + n1 * buf[co + b + s1] + n0 * buf[co + b + s2],
                    n2 * buf[c1 + b] + n1 * buf[c1 + b + s1] + n0 * buf[c1 + b + s2],
                    n2 * buf[c2 + b] + n1 * buf[c2 + b + s1] + n0 * buf[c2 + b + s2], sym)


@njit(cache=True, inline="always", fastmath=_FM)
def _row_window(factor, buf, sc, co, zo, so, plane, wps, c0, nl, R, d, w, p, cap, multi, sym):
    """A jittered row for a block of lanes in one slot by the (2R+1)^2 texel window (module docstring)."""
    U = np.uintp
    one = np.float32(1.0)
    zero = np.float32(0.0)
    w2 = 2 * R + 1
    hx0 = U(_HX)
    hy0 = U(_HX + _W * _L)  # hat(vx - i) for i = -R..R, then hat(vy - j)
    for l in range(nl):
        lu = U(l)
        rho = min(d * sc[U(_LN + 2 * _L) + lu], cap)
        vx = np.float32(rho * sc[U(_LN + 3 * _L) + lu])
        vy = np.float32(rho * sc[U(_LN + 4 * _L) + lu])
        for i in range(w2):
            sc[hx0 + U(i * _L) + lu] = max(zero, one - abs(vx - np.float32(i - R)))
            sc[hy0 + U(i * _L) + lu] = max(zero, one - abs(vy - np.float32(i - R)))
    z0s = sc[_LN:_LN + _L]
    q0s = sc[_LN + _L:_LN + 2 * _L]
    acc = sc[:6 * _L]
    for j in range(w2):
        hyp = sc[hy0 + U(j * _L):]
        hym = sc[hy0 + U((w2 - 1 - j) * _L):]
        for i in range(w2):
            hxp = sc[hx0 + U(i * _L):]
            hxm = sc[hx0 + U((w2 - 1 - i) * _L):]
            base = U(c0 + (j - R) * wps + (i - R))
            # views starting at the window texel: the lane loop indexes them with l alone (simple for LLVM)
            zt = buf[zo + base:]
            st_ = buf[so + base:]
            cr = buf[co + base:]
            cg = buf[co + U(plane) + base:]
            cb = buf[co + U(2 * plane) + base:]
            for l in range(nl):
                lu = U(l)
                f = factor(zt[lu] - z0s[lu], p)
                if multi:
                    f *= np.float32(st_[lu] == q0s[lu])
                c_r = cr[lu]
                c_g = cg[lu]
                c_b = cb[lu]
                if sym:  # one weight for both samples: g = (hat+ + hat-) f
                    g = (hxp[lu] * hyp[lu] + hxm[lu] * hym[lu]) * f
                    _accumulate(acc, lu, w, g, zero, g * c_r, g * c_g, g * c_b, zero, zero, zero, True)
                else:
                    gp = hxp[lu] * hyp[lu] * f
                    gm = hxm[lu] * hym[lu] * f
                    _accumulate(acc, lu, w, gp, gm, gp * c_r, gp * c_g, gp * c_b, gm * c_r, gm * c_g, gm * c_b, False)


@njit(cache=True, inline="always", fastmath=_FM)
def _sep_body(factor, buf, out, co, ob, ocs, oys, oxs, y0, y1, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit,
              n_rows, centre, param, base, cap, bmap):
    """One 1D pass of one term over the whole image (module docstring), reading colour planes at ``co``
    of ``buf``. ``out`` is flat; pixel (x, y) channel c goes to out[ob + c ocs + y oys + x oxs] (the
    horizontal pass writes buf's TMP planes, the vertical one the (H, W, 3) result).
    ``wts`` (S, K, 6): each row's w+ (R, G, B) and w- (R, G, B)."""
    U = np.uintp
    st = 1 if axis == 0 else wps
    fa = np.float32(f_axis)
    one = np.float32(1.0)
    zero = np.float32(0.0)
    zo = U(Z_PLANE * plane)
    so = U(S_PLANE * plane)
    cu = U(co)
    kmax = offs.shape[1]
    h_img, nbx = bmap.shape
    n_jits = 0
    for i in range(n_jit.size):
        n_jits += n_jit[i]
    multi = n_jit.size > 2  # more than one profile slot: texels must pass the slot test
    sym = np.empty(offs.shape, np.bool_)  # rows whose + and - weights are equal (symmetric pairs)
    for i in range(offs.shape[0]):
        for k in range(kmax):
            sym[i, k] = (wts[i, k, 0] == wts[i, k, 3] and wts[i, k, 1] == wts[i, k, 4]
                         and wts[i, k, 2] == wts[i, k, 5])
    for y in range(y0, y1):
        hrow = _mix32(base ^ np.uint64(y))
        sc = np.empty(SCRATCH, np.float32)
        mlo = np.empty(kmax, np.float32)
        rwin = np.empty(kmax, np.int64)
        row0 = (y + pad) * wps + pad
        for x0 in range(0, w, _L):
            nl = min(_L, w - x0)
            c0 = row0 + x0
            qlo = np.float32(1e30)
            qhi = np.float32(0.0)
            for l in range(_L):  # lane data (lanes past the image read pad texels: slot 0); slot range
                lu = U(l)
                z = buf[zo + U(c0) + lu]
                q = buf[so + U(c0) + lu]
                sc[U(_LN) + lu] = z
                sc[U(_LN + _L) + lu] = q
                sc[U(_LN + 2 * _L) + lu] = fa / z if q > zero else zero
                qhi = max(qhi, q)
                qlo = min(qlo, q if q > zero else np.float32(1e30))
            sb = int(qhi)
            mixed = qlo != qhi
            if sb > 0 and n_jits > 0:
                for l in range(_L):  # the jitter axis: (cos, sin) horizontally, (-sin, cos) vertically
                    c, s = _unit(_mix32(hrow ^ np.uint64(x0 + l)))
                    sc[_LN + 3 * _L + l] = np.float32(c) if axis == 0 else np.float32(-s)
                    sc[_LN + 4 * _L + l] = np.float32(s) if axis == 0 else np.float32(c)
            if sb > 0:
                for i in range(6 * _L):
                    sc[i] = 0.0
                # the vectorised paths take symmetric pairs whose footprints vary little across the block
                # and jitter windows of radius <= RMAX, on one profile (several: plain rows only); anything
                # else sends the whole block to per-lane fetches (one code path, small compiled code)
                fast = not mixed
                alone = not multi  # no other profile within the block's reach: no slot test needed
                if fast:
                    nj = n_jit[sb]
                    reach = 0
                    for k in range(n_rows[sb]):
                        d = offs[sb, k]
                        lo = np.float32(1e30)
                        hi = np.float32(-1e30)
                        for l in range(_L):
                            r = min(d * sc[_LN + 2 * _L + l], cap)
                            lo = min(lo, np.floor(r))
                            hi = max(hi, r)
                        fast = fast and sym[sb, k]
                        if k < nj:
                            rwin[k] = int(math.ceil(hi))
                            fast = fast and rwin[k] <= RMAX
                        else:
                            mlo[k] = lo
                            fast = fast and np.floor(hi) - lo <= 1.0
                            reach = max(reach, int(np.floor(hi)) + 2)
                    if fast and multi:  # scan the texels the block can reach for another profile
                        rj = RMAX + 1 if nj > 0 else 0
                        rx = max(reach, rj) if axis == 0 else rj  # jitter windows reach rj along both axes
                        ry = rj if axis == 0 else max(reach, rj)
                        # in the block-slot map: one entry per row and 16-pixel block (module docstring)
                        others = 0
                        bx0 = max(0, (x0 - rx) // _L)
                        bx1 = min(nbx - 1, (x0 + _L - 1 + rx) // _L)
                        for j in range(max(0, y - ry), min(h_img, y + ry + 1)):
                            for bx in range(bx0, bx1 + 1):
                                q = bmap[j, bx]
                                others += 1 if (q != 0 and q != sb) else 0
                        alone = others == 0
                        fast = alone or nj == 0  # jitter windows only where no other profile is near
                if fast:
                    p = param[sb]
                    for k in range(n_rows[sb]):
                        wk = (wts[sb, k, 0], wts[sb, k, 1], wts[sb, k, 2], wts[sb, k, 3], wts[sb, k, 4], wts[sb, k, 5])
                        # constant lane counts and window radii (all LANES lanes are computed: the buffer's
                        # right slack makes lanes past the image pad texels) let LLVM vectorise fully
                        if k < n_jit[sb] and rwin[k] <= 1:
                            _row_window(factor, buf, sc, cu, zo, so, plane, wps, c0, _L, 1, offs[sb, k], wk, p, cap,
                                        False, True)
                        elif k < n_jit[sb]:
                            _row_window(factor, buf, sc, cu, zo, so, plane, wps, c0, _L, RMAX, offs[sb, k], wk, p, cap,
                                        False, True)
                        elif not alone:
                            _row_block(factor, buf, sc, cu, zo, so, plane, c0, st, _L, offs[sb, k], mlo[k], wk, p, cap,
                                       True, True)
                        else:  # the common case: one profile, symmetric pairs
                            _row_block(factor, buf, sc, cu, zo, so, plane, c0, st, _L, offs[sb, k], mlo[k], wk, p, cap,
                                       False, True)
                else:  # several slots, asymmetric taps, wide jitter windows or varying footprints
                    for l in range(nl):
                        qi = int(sc[_LN + _L + l])
                        if qi == 0:
                            continue
                        for k in range(n_rows[qi]):
                            jit = k < n_jit[qi]
                            ax = sc[_LN + 3 * _L + l] if jit else (one if axis == 0 else zero)
                            ay = sc[_LN + 4 * _L + l] if jit else (zero if axis == 0 else one)
                            wk = (wts[qi, k, 0], wts[qi, k, 1], wts[qi, k, 2], wts[qi, k, 3], wts[qi, k, 4],
                                  wts[qi, k, 5])
                            _lane_row(factor, buf, sc, cu, zo, so, plane, wps, c0 + l,
                                      min(offs[qi, k] * sc[_LN + 2 * _L + l], cap), ax, ay, sc[_LN + l],
                                      sc[_LN + _L + l], param[qi], wk, l)
            for c in range(3):
                o = ob + y * oys + x0 * oxs + c * ocs
                ci = cu + U(c * plane + c0)
                if sb > 0 and not mixed:
                    wc = centre[sb, c]
                    for l in range(nl):
                        lu = U(l)
                        e = buf[ci + lu]
                        v = (wc - sc[U((3 + c) * _L) + lu]) * e + sc[U(c * _L) + lu]
                        out[U(o + l * oxs)] = v if sc[U(_LN + _L) + lu] > zero else e
                else:
                    for l in range(nl):
                        e = buf[ci + U(l)]
                        qi = int(sc[_LN + _L + l])
                        out[U(o + l * oxs)] = e if qi == 0 else (centre[qi, c] - sc[(3 + c) * _L + l]) * e + sc[c * _L + l]


@njit(cache=True, nogil=True, fastmath=_FM)
def pass_gaussian(buf, out, co, ob, ocs, oys, oxs, y0, y1, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit, n_rows,
                  centre, param, base, cap, bmap):
    _sep_body(f_gaussian, buf, out, co, ob, ocs, oys, oxs, y0, y1, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit,
              n_rows, centre, param, base, cap, bmap)


@njit(cache=True, nogil=True, fastmath=_FM)
def pass_follow(buf, out, co, ob, ocs, oys, oxs, y0, y1, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit, n_rows,
                centre, param, base, cap, bmap):
    _sep_body(f_follow, buf, out, co, ob, ocs, oys, oxs, y0, y1, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit,
              n_rows, centre, param, base, cap, bmap)


@njit(cache=True, nogil=True, fastmath=_FM)
def pass_none(buf, out, co, ob, ocs, oys, oxs, y0, y1, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit, n_rows,
              centre, param, base, cap, bmap):
    _sep_body(f_none, buf, out, co, ob, ocs, oys, oxs, y0, y1, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit,
              n_rows, centre, param, base, cap, bmap)


PASSES = {"gaussian": pass_gaussian, "follow": pass_follow, "none": pass_none}


@njit(cache=True, parallel=True)
def pack(diffuse, depth_mm, slots, buf, pad, wps, plane):
    """Copy the frame into buf's input planes (pads were set once: colour 0, depth +inf, slot 0)."""
    h, w = slots.shape
    for y in prange(h):
        r = (y + pad) * wps + pad
        for x in range(w):
            i = r + x
            buf[i] = diffuse[y, x, 0]
            buf[plane + i] = diffuse[y, x, 1]
            buf[2 * plane + i] = diffuse[y, x, 2]
            q = slots[y, x]
            buf[Z_PLANE * plane + i] = depth_mm[y, x] if q > 0 else np.inf
            buf[S_PLANE * plane + i] = q


@njit(cache=True, parallel=True)
def depth_range(depth_mm, slots):
    """(nearest depth, number of bad depths) over the pixels with SSS, in one pass: a depth is bad if it
    is not a positive finite number."""
    h, w = slots.shape
    zmin = np.full(h, np.inf)
    bad = np.zeros(h, np.int64)
    for y in prange(h):
        for x in range(w):
            if slots[y, x] > 0:
                z = depth_mm[y, x]
                if not (z > 0 and z < np.inf):
                    bad[y] += 1
                elif z < zmin[y]:
                    zmin[y] = z
    return zmin.min(), bad.sum()


@njit(cache=True, parallel=True)
def block_slots(slots):
    """The block-slot map (H, ceil(W / LANES)) int32: for each row and block of LANES pixels, the one
    nonzero slot its pixels have (0 if none, -1 if several): with several profiles, a block of the pass
    reads it to learn whether any other profile lies within its taps' reach."""
    h, w = slots.shape
    nbx = (w + _L - 1) // _L
    out = np.zeros((h, nbx), np.int32)
    for y in prange(h):
        for bx in range(nbx):
            v = 0
            for x in range(bx * _L, min(w, bx * _L + _L)):
                q = slots[y, x]
                if q > 0:
                    v = q if v == 0 or v == q else -1
            out[y, bx] = v
    return out
