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
disk (``cache=True``), so a new process compiles nothing it compiled before.
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
    """No depth test (validity comes from the slot test alone)."""
    return np.float32(1.0)


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
    if q == 0:
        return cp, sp
    if q == 1:
        return -sp, cp
    if q == 2:
        return -cp, -sp
    return sp, -cp


@njit(cache=True, inline="always", fastmath=_FM)
def _tex(factor, zs, plane, i, z0, s0, p):
    """Depth factor x slot test of texel i (flat index) for a centre at depth z0 in slot s0."""
    return factor(zs[i] - z0, p) * np.float32(zs[np.uintp(plane) + i] == s0)


@njit(cache=True, inline="always", fastmath=_FM)
def _accumulate(acc, l, w, gp, gm, sp0, sp1, sp2, sm0, sm1, sm2):
    """acc (6 x LANES: A_R, A_G, A_B, G_R, G_G, G_B) += the + and - samples of one row; w = the row's
    weights (w+_R, w+_G, w+_B, w-_R, w-_G, w-_B) as a tuple of scalars."""
    U = np.uintp
    lu = U(l)
    acc[lu] += w[0] * sp0 + w[3] * sm0
    acc[U(_L) + lu] += w[1] * sp1 + w[4] * sm1
    acc[U(2 * _L) + lu] += w[2] * sp2 + w[5] * sm2
    acc[U(3 * _L) + lu] += w[0] * gp + w[3] * gm
    acc[U(4 * _L) + lu] += w[1] * gp + w[4] * gm
    acc[U(5 * _L) + lu] += w[2] * gp + w[5] * gm


@njit(cache=True, inline="always", fastmath=_FM)
def _bilinear(factor, col, zs, plane, wps, c, vx, vy, z0, s0, p):
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
        gt = b * _tex(factor, zs, plane, t, z0, s0, p)
        g += gt
        s0_ += gt * col[t]
        s1 += gt * col[U(plane) + t]
        s2 += gt * col[U(2 * plane) + t]
    return g, s0_, s1, s2


@njit(cache=True, inline="always", fastmath=_FM)
def _lane_row(factor, col, zs, plane, wps, c, rho, ux, uy, z0, s0, p, w, acc, l):
    """One row for one lane by 2D bilinear fetches at +-rho (ux, uy)."""
    gp, a0, a1, a2 = _bilinear(factor, col, zs, plane, wps, c, rho * ux, rho * uy, z0, s0, p)
    gm, b0, b1, b2 = _bilinear(factor, col, zs, plane, wps, c, -rho * ux, -rho * uy, z0, s0, p)
    _accumulate(acc, l, w, gp, gm, a0, a1, a2, b0, b1, b2)


@njit(cache=True, inline="always", fastmath=_FM)
def _row_block(factor, col, zs, plane, c0, st, nl, d, mmin, w, p, cap, ln, acc):
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
    p1 = U(plane)
    p2 = U(2 * plane)
    for l in range(nl):
        lu = U(l)
        z0 = ln[lu]
        q0 = ln[U(_L) + lu]
        tp = min(d * ln[U(2 * _L) + lu], cap) - mmin
        h0 = max(zero, one - tp)
        h1 = max(zero, one - abs(tp - one))
        h2 = max(zero, tp - one)
        a = bp + lu
        b = bm + lu
        g0 = h0 * _tex(factor, zs, plane, a, z0, q0, p)
        g1 = h1 * _tex(factor, zs, plane, a + s1, z0, q0, p)
        g2 = h2 * _tex(factor, zs, plane, a + s2, z0, q0, p)
        n2 = h2 * _tex(factor, zs, plane, b, z0, q0, p)
        n1 = h1 * _tex(factor, zs, plane, b + s1, z0, q0, p)
        n0 = h0 * _tex(factor, zs, plane, b + s2, z0, q0, p)
        _accumulate(acc, l, w, g0 + g1 + g2, n0 + n1 + n2,
                    g0 * col[a] + g1 * col[a + s1] + g2 * col[a + s2],
                    g0 * col[p1 + a] + g1 * col[p1 + a + s1] + g2 * col[p1 + a + s2],
                    g0 * col[p2 + a] + g1 * col[p2 + a + s1] + g2 * col[p2 + a + s2],
                    n2 * col[b] + n1 * col[b + s1] + n0 * col[b + s2],
                    n2 * col[p1 + b] + n1 * col[p1 + b + s1] + n0 * col[p1 + b + s2],
                    n2 * col[p2 + b] + n1 * col[p2 + b + s1] + n0 * col[p2 + b + s2])


@njit(cache=True, inline="always", fastmath=_FM)
def _row_window(factor, col, zs, plane, wps, c0, nl, R, d, w, p, cap, ln, hxy, acc):
    """A jittered row for a block of lanes in one slot by the (2R+1)^2 texel window (module docstring)."""
    U = np.uintp
    one = np.float32(1.0)
    zero = np.float32(0.0)
    w2 = 2 * R + 1
    hy0 = U(_W * _L)  # hxy holds hat(vx - i) for i = -R..R, then hat(vy - j)
    for l in range(nl):
        lu = U(l)
        rho = min(d * ln[U(2 * _L) + lu], cap)
        vx = np.float32(rho * ln[U(3 * _L) + lu])
        vy = np.float32(rho * ln[U(4 * _L) + lu])
        for i in range(w2):
            hxy[U(i * _L) + lu] = max(zero, one - abs(vx - np.float32(i - R)))
            hxy[hy0 + U(i * _L) + lu] = max(zero, one - abs(vy - np.float32(i - R)))
    p1 = U(plane)
    p2 = U(2 * plane)
    for j in range(w2):
        jp = hy0 + U(j * _L)
        jm = hy0 + U((w2 - 1 - j) * _L)
        for i in range(w2):
            ip = U(i * _L)
            im = U((w2 - 1 - i) * _L)
            base = U(c0 + (j - R) * wps + (i - R))
            for l in range(nl):
                lu = U(l)
                t = base + lu
                f = _tex(factor, zs, plane, t, ln[lu], ln[U(_L) + lu], p)
                gp = hxy[ip + lu] * hxy[jp + lu] * f
                gm = hxy[im + lu] * hxy[jm + lu] * f
                c_r = col[t]
                c_g = col[p1 + t]
                c_b = col[p2 + t]
                _accumulate(acc, l, w, gp, gm, gp * c_r, gp * c_g, gp * c_b, gm * c_r, gm * c_g, gm * c_b)


@njit(cache=True, inline="always", fastmath=_FM)
def _sep_body(factor, col, zs, out, ob, ocs, oys, oxs, h, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit,
              n_rows, centre, param, base, cap):
    """One 1D pass of one term over the whole image (module docstring). ``out`` is flat; pixel (x, y)
    channel c goes to out[ob + c ocs + y oys + x oxs] (planar padded or interleaved (H, W, 3)).
    ``wts`` (S, K, 6): each row's w+ (R, G, B) and w- (R, G, B)."""
    U = np.uintp
    st = 1 if axis == 0 else wps
    fa = np.float32(f_axis)
    one = np.float32(1.0)
    zero = np.float32(0.0)
    kmax = offs.shape[1]
    for y in prange(h):
        hrow = _mix32(base ^ np.uint64(y))
        acc = np.empty(6 * _L, np.float32)
        ln = np.empty(5 * _L, np.float32)  # per lane: depth, slot, pixels per mm, jitter axis x, y
        hxy = np.empty(2 * _W * _L, np.float32)
        mlo = np.empty(kmax, np.float32)
        rwin = np.empty(kmax, np.int64)
        row0 = (y + pad) * wps + pad
        for x0 in range(0, w, _L):
            nl = min(_L, w - x0)
            c0 = row0 + x0
            sb = 0
            mixed = False
            for l in range(nl):
                z = zs[U(c0 + l)]
                q = zs[U(plane + c0 + l)]
                ln[l] = z
                ln[_L + l] = q
                ln[2 * _L + l] = fa / z if q > 0 else zero
                ln[3 * _L + l] = zero
                ln[4 * _L + l] = zero
                qi = int(q)
                if qi > 0:
                    if sb == 0:
                        sb = qi
                    elif qi != sb:
                        mixed = True
                    if n_jit[qi] > 0:  # the jitter axis: (cos, sin) horizontally, (-sin, cos) vertically
                        c, s = _unit(_mix32(hrow ^ np.uint64(x0 + l)))
                        ln[3 * _L + l] = np.float32(c) if axis == 0 else np.float32(-s)
                        ln[4 * _L + l] = np.float32(s) if axis == 0 else np.float32(c)
            if sb > 0:
                for i in range(6 * _L):
                    acc[i] = 0.0
                fast = not mixed
                if fast:  # can the block's rows all take the vectorised paths?
                    nj = n_jit[sb]
                    for k in range(n_rows[sb]):
                        d = offs[sb, k]
                        lo = np.float32(1e30)
                        hi = np.float32(-1e30)
                        for l in range(nl):
                            r = min(d * ln[2 * _L + l], cap)
                            lo = min(lo, np.floor(r))
                            hi = max(hi, r)
                        if k < nj:
                            rwin[k] = int(math.ceil(hi))
                            fast = fast and rwin[k] <= RMAX
                        else:
                            mlo[k] = lo
                            fast = fast and np.floor(hi) - lo <= 1.0
                if fast:
                    p = param[sb]
                    for k in range(n_rows[sb]):
                        wk = (wts[sb, k, 0], wts[sb, k, 1], wts[sb, k, 2], wts[sb, k, 3], wts[sb, k, 4], wts[sb, k, 5])
                        if k < n_jit[sb]:
                            _row_window(factor, col, zs, plane, wps, c0, nl, rwin[k], offs[sb, k], wk, p, cap, ln,
                                        hxy, acc)
                        else:
                            _row_block(factor, col, zs, plane, c0, st, nl, offs[sb, k], mlo[k], wk, p, cap, ln, acc)
                else:  # several slots, large jitter windows or varying footprints: per-lane fetches
                    for l in range(nl):
                        qi = int(ln[_L + l])
                        if qi == 0:
                            continue
                        for k in range(n_rows[qi]):
                            jit = k < n_jit[qi]
                            ax = ln[3 * _L + l] if jit else (one if axis == 0 else zero)
                            ay = ln[4 * _L + l] if jit else (zero if axis == 0 else one)
                            wk = (wts[qi, k, 0], wts[qi, k, 1], wts[qi, k, 2], wts[qi, k, 3], wts[qi, k, 4],
                                  wts[qi, k, 5])
                            _lane_row(factor, col, zs, plane, wps, c0 + l, min(offs[qi, k] * ln[2 * _L + l], cap),
                                      ax, ay, ln[l], ln[_L + l], param[qi], wk, acc, l)
            for l in range(nl):
                qi = int(ln[_L + l])
                o = ob + y * oys + (x0 + l) * oxs
                for c in range(3):
                    e = col[U(c * plane + c0 + l)]
                    v = e if qi == 0 else (centre[qi, c] - acc[(3 + c) * _L + l]) * e + acc[c * _L + l]
                    out[U(o + c * ocs)] = v


@njit(cache=True, parallel=True, fastmath=_FM)
def pass_gaussian(col, zs, out, ob, ocs, oys, oxs, h, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit, n_rows, centre,
                  param, base, cap):
    _sep_body(f_gaussian, col, zs, out, ob, ocs, oys, oxs, h, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit, n_rows,
              centre, param, base, cap)


@njit(cache=True, parallel=True, fastmath=_FM)
def pass_follow(col, zs, out, ob, ocs, oys, oxs, h, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit, n_rows, centre,
                param, base, cap):
    _sep_body(f_follow, col, zs, out, ob, ocs, oys, oxs, h, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit, n_rows,
              centre, param, base, cap)


@njit(cache=True, parallel=True, fastmath=_FM)
def pass_none(col, zs, out, ob, ocs, oys, oxs, h, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit, n_rows, centre,
              param, base, cap):
    _sep_body(f_none, col, zs, out, ob, ocs, oys, oxs, h, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit, n_rows,
              centre, param, base, cap)


PASSES = {"gaussian": pass_gaussian, "follow": pass_follow, "none": pass_none}


@njit(cache=True, parallel=True)
def pack(diffuse, depth_mm, slots, col, zs, pad, wps, plane):
    """Copy the frame into the planar padded buffers (pads were set once: colour 0, depth +inf, slot 0)."""
    h, w = slots.shape
    for y in prange(h):
        r = (y + pad) * wps + pad
        for x in range(w):
            i = r + x
            col[i] = diffuse[y, x, 0]
            col[plane + i] = diffuse[y, x, 1]
            col[2 * plane + i] = diffuse[y, x, 2]
            q = slots[y, x]
            zs[i] = depth_mm[y, x] if q > 0 else np.inf
            zs[plane + i] = q
