"""numba kernels of the separable pass (see :mod:`ssskit.screenspace.separable` for the maths).

Two formulations compute the same result. :func:`vector_kernels` (symmetric tap pairs, no jitter:
the common case and the benchmark's) is written so that LLVM vectorises it (see the comment above
it). :func:`kernels` handles everything (jittered taps, unpaired taps) in scalar code.

Both share:

* RGBZ data, so a texel's colour and depth come from one cache line (the scalar pass works on
  (H, W, 4) arrays; the vectorised one on planar buffers);
* taps in symmetric pairs +-d: one floor gives the four bilinear texels x+n, x+n+1, x-n, x-n-1
  with weights (1-t, t, 1-t, t); the centre tap costs nothing (its weight multiplies E(p));
* out = (W - G) E(p) + A with A = sum w g E_j and G = sum w g, g = bilinear weight x depth factor;
* unsigned indices after the bounds test, so numba emits no negative-index wraparound code;
* the depth mode as a compile-time constant (one specialisation per mode);
* fastmath without 'nnan'/'ninf': +inf marks pixels outside the region and must compare as such.

Tap table rows: (offset, kind) with kind 0 = symmetric pair at +-offset, 1 = single tap at the
signed offset; jittered taps (rotated axes) are the first ``n_jit`` rows.
"""

from __future__ import annotations

import math

import numpy as np

_FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}
_CACHE: dict[int, object] = {}


def _factor(mode: int):
    """The depth factor f(d_z) of mode 0 (gaussian: exp(-d_z^2 p), p = 1 / (2 tau_max); supplement E),
    1 (follow: max(0, 1 - |d_z| p), p = 1 / width) or 2 (none: 1 unless d_z is infinite), compiled
    with the mode as a constant."""
    from numba import njit

    @njit(fastmath=_FASTMATH, inline="always")
    def factor(dz, p):
        if mode == 0:
            return np.float32(math.exp(-dz * dz * p))
        if mode == 1:
            return max(np.float32(0.0), np.float32(1.0) - abs(dz) * p)
        return np.float32(1.0) if abs(dz) < np.float32(np.inf) else np.float32(0.0)

    return factor


def kernels(mode: int):
    """The scalar pass for depth mode ``mode``: ``spass(src4, dst4, f_axis, horizontal, ...)`` on
    (H, W, 4) RGBZ arrays (colour and depth of a texel in one cache line). Handles every tap table:
    jittered taps (rotated axes, 2D bilinear), symmetric pairs and single taps."""
    if mode in _CACHE:
        return _CACHE[mode]
    from numba import njit, prange

    factor = _factor(mode)

    @njit(fastmath=_FASTMATH, inline="always")
    def mix32(h):
        h = h ^ (h >> np.uint64(16))
        h = (h * np.uint64(0x7FEB352D)) & np.uint64(0xFFFFFFFF)
        h = h ^ (h >> np.uint64(15))
        h = (h * np.uint64(0x846CA68B)) & np.uint64(0xFFFFFFFF)
        return h ^ (h >> np.uint64(16))

    @njit(fastmath=_FASTMATH, inline="always")
    def texel(arr, j, i, b, z0, p):
        """Weighted texel (j, i): (g, g*R, g*G, g*B), g = b * depth factor; zero off the image."""
        h, w, _ = arr.shape
        if b <= 0 or i < 0 or i >= w or j < 0 or j >= h:
            return np.float32(0.0), np.float32(0.0), np.float32(0.0), np.float32(0.0)
        ju = np.uintp(j)
        iu = np.uintp(i)
        g = b * factor(arr[ju, iu, 3] - z0, p)
        return g, g * arr[ju, iu, 0], g * arr[ju, iu, 1], g * arr[ju, iu, 2]

    @njit(fastmath=_FASTMATH)
    def bilinear(arr, px, py, z0, p):
        """A 2D bilinear sample at (px, py), each of its 4 texels with its own depth factor."""
        fx = np.floor(px)
        fy = np.floor(py)
        i0 = int(fx)
        j0 = int(fy)
        tx = np.float32(px - fx)
        ty = np.float32(py - fy)
        gs = s0 = s1 = s2 = np.float32(0.0)
        for c in range(4):
            b = (tx if c & 1 else np.float32(1.0) - tx) * (ty if c >> 1 else np.float32(1.0) - ty)
            g, a0, a1, a2 = texel(arr, j0 + (c >> 1), i0 + (c & 1), b, z0, p)
            gs += g
            s0 += a0
            s1 += a1
            s2 += a2
        return gs, s0, s1, s2

    @njit(parallel=True, fastmath=_FASTMATH)
    def spass(src4, dst4, f_axis, horizontal, offs, kinds, wts, wsum, n_jit, n_pair, p, base):
        h, w, _ = src4.shape
        n = offs.size
        fa = np.float32(f_axis)
        ax = 1 if horizontal else 0  # texel step along the pass axis
        ay = 1 - ax
        for y in prange(h):
            hy = mix32(base ^ np.uint64(y))
            for x in range(w):
                z0 = src4[y, x, 3]
                e0 = src4[y, x, 0]
                e1 = src4[y, x, 1]
                e2 = src4[y, x, 2]
                dst4[y, x, 3] = z0
                if not (z0 < np.float32(np.inf)):  # stencil: no SSS here
                    dst4[y, x, 0] = e0
                    dst4[y, x, 1] = e1
                    dst4[y, x, 2] = e2
                    continue
                s = fa / z0
                A0 = A1 = A2 = G0 = G1 = G2 = np.float32(0.0)
                cth = 1.0
                sth = 0.0
                if n_jit > 0:  # rotated axes (paper section 6): (cos, sin) horizontally, (-sin, cos) vertically
                    theta = float(mix32(hy ^ np.uint64(x))) * (2.0 * math.pi / 4294967296.0)
                    cth = math.cos(theta)
                    sth = math.sin(theta)
                dxj = cth if horizontal else -sth
                dyj = sth if horizontal else cth
                for k in range(n):
                    o = offs[k] * s
                    if k < n_jit:
                        gs, S0, S1, S2 = bilinear(src4, x + o * dxj, y + o * dyj, z0, p)
                        if kinds[k] == 0:
                            g, a0, a1, a2 = bilinear(src4, x - o * dxj, y - o * dyj, z0, p)
                            gs += g
                            S0 += a0
                            S1 += a1
                            S2 += a2
                    else:
                        fl = np.floor(o)  # float32 floor: math.floor would widen to int64 and float64
                        t = o - fl
                        u = np.float32(1.0) - t
                        m = np.intp(fl)
                        gs, S0, S1, S2 = texel(src4, y + ay * m, x + ax * m, u, z0, p)
                        g, a0, a1, a2 = texel(src4, y + ay * (m + 1), x + ax * (m + 1), t, z0, p)
                        gs += g
                        S0 += a0
                        S1 += a1
                        S2 += a2
                        if kinds[k] == 0:  # the mirrored tap at -o: texels -m (weight u) and -m-1 (t)
                            g, a0, a1, a2 = texel(src4, y - ay * m, x - ax * m, u, z0, p)
                            gs += g
                            S0 += a0
                            S1 += a1
                            S2 += a2
                            g, a0, a1, a2 = texel(src4, y - ay * (m + 1), x - ax * (m + 1), t, z0, p)
                            gs += g
                            S0 += a0
                            S1 += a1
                            S2 += a2
                    A0 += wts[k, 0] * S0
                    A1 += wts[k, 1] * S1
                    A2 += wts[k, 2] * S2
                    G0 += wts[k, 0] * gs
                    G1 += wts[k, 1] * gs
                    G2 += wts[k, 2] * gs
                dst4[y, x, 0] = (wsum[0] - G0) * e0 + A0
                dst4[y, x, 1] = (wsum[1] - G1) * e1 + A1
                dst4[y, x, 2] = (wsum[2] - G2) * e2 + A2

    _CACHE[mode] = spass
    return spass


def tap_table(offsets: np.ndarray, weights: np.ndarray, n_jit: int):
    """Rows for the kernels above: (offs, kinds, wts, n_jit_rows, n_pair_rows).

    ``offsets`` (N,) centre first and sorted by |o| (as SeparableTaps stores them), ``weights`` (N, 3);
    the first ``n_jit`` taps are jittered. A tap at -o with the same weights as the tap at +o (to
    rounding) becomes one pair row (kind 0, offset |o|); others are single rows (kind 1, signed offset). Centre taps
    (o = 0) need no row: their weight multiplies E(p). Rows: jittered, then pairs, then singles.
    """
    used = np.zeros(offsets.size, bool)
    rows = []
    for i in range(offsets.size):
        if used[i]:
            continue
        used[i] = True
        o = float(offsets[i])
        if o == 0.0:
            continue
        jit = i < n_jit
        partner = -1
        for j in range(i + 1, offsets.size):
            if (not used[j] and abs(offsets[j] + o) <= 1e-9 * abs(o) and (j < n_jit) == jit
                    and np.allclose(weights[j], weights[i], rtol=1e-7, atol=1e-12)):
                partner = j
                break
        if partner >= 0:
            used[partner] = True
            rows.append((abs(o), 0, 0.5 * (weights[i] + weights[partner]), jit))
        else:
            rows.append((o, 1, weights[i], jit))
    rows.sort(key=lambda r: (not r[3], r[1]))  # jittered first, then pairs, then singles
    offs = np.array([r[0] for r in rows], np.float32)
    kinds = np.array([r[1] for r in rows], np.int64)
    wts = np.array([r[2] for r in rows], np.float32).reshape(-1, 3)
    n_jit_rows = sum(1 for r in rows if r[3])
    n_pair_rows = sum(1 for r in rows if not r[3] and r[1] == 0)
    return offs, kinds, wts, n_jit_rows, n_pair_rows


# ---- vectorised kernels (no jitter, symmetric pairs only) ----------------------------------------------
#
# LLVM vectorises a numba loop only when it is simple: contiguous loads from one array, loads and
# stores of another, no gathers. So both passes work on planar, padded buffers (colour, depth and
# pixels-per-mm planes in one flat array; pads have depth +inf, so no bounds tests), in blocks of
# LANES pixels. For each tap pair, the integer part m of the footprint d*s(x) is usually the same for
# a whole block (it changes by at most 1 across it); then with m0 = min m the three texels m0, m0+1,
# m0+2 weighted by the hat function of d*s - m0 (weights 1-t', 1-|t'-1|, t'-1, clipped at 0) give
# exactly the bilinear sample, for every lane, from contiguous loads. Blocks where m spans more than
# two texels take a per-lane (gathering) loop with the same arithmetic.

LANES = 16
_VCACHE: dict[int, tuple] = {}


def vector_kernels(mode: int):
    """(hpass, vpass) of the vectorised formulation for depth mode ``mode`` (see :func:`kernels`)."""
    if mode in _VCACHE:
        return _VCACHE[mode]
    from numba import njit, prange

    L = LANES

    factor = _factor(mode)

    @njit(fastmath=_FASTMATH)
    def block(buf, zoff, soff, coff, stride, centre, nl, dk, wk0, wk1, wk2, p, acc, cap, svec):
        """Accumulate one tap pair for a block of ``nl`` lanes (module comment above).

        ``buf`` holds the planes (colour c at c * coff, depth at zoff), texels ``stride`` apart along
        the pass axis, the block's centre pixels at ``centre + l``; pixels per mm are read from
        ``svec[soff + l]``. acc: 6 x L (A_R, A_G, A_B, G_R, G_G, G_B). Every index is unsigned so
        numba emits no negative-index wraparound and LLVM sees contiguous loads.
        """
        U = np.uintp
        mmin = np.float32(1e30)
        mmax = np.float32(-1e30)
        so = U(soff)
        for l in range(nl):
            m = np.floor(min(dk * svec[so + U(l)], cap))
            mmin = min(mmin, m)
            mmax = max(mmax, m)
        one = np.float32(1.0)
        zero = np.float32(0.0)
        st = U(stride)
        zc = U(zoff + centre)
        if mmax - mmin <= 1.0:
            mi = int(mmin)
            bp = U(centre + mi * stride)
            bm = U(centre - mi * stride - 2 * stride)  # the - side's farthest texel
            zb = U(zoff)
            o0 = U(0)
            o1 = U(coff)
            o2 = U(2 * coff)
            for l in range(nl):
                lu = U(l)
                z0 = buf[zc + lu]
                tp = min(dk * svec[so + lu], cap) - mmin
                h0 = max(zero, one - tp)
                h1 = max(zero, one - abs(tp - one))
                h2 = max(zero, tp - one)
                g0 = h0 * factor(buf[zb + bp + lu] - z0, p)
                g1 = h1 * factor(buf[zb + bp + st + lu] - z0, p)
                g2 = h2 * factor(buf[zb + bp + st + st + lu] - z0, p)
                n2 = h2 * factor(buf[zb + bm + lu] - z0, p)
                n1 = h1 * factor(buf[zb + bm + st + lu] - z0, p)
                n0 = h0 * factor(buf[zb + bm + st + st + lu] - z0, p)
                gs = g0 + g1 + g2 + n0 + n1 + n2
                s0 = (g0 * buf[o0 + bp + lu] + g1 * buf[o0 + bp + st + lu] + g2 * buf[o0 + bp + st + st + lu]
                      + n2 * buf[o0 + bm + lu] + n1 * buf[o0 + bm + st + lu] + n0 * buf[o0 + bm + st + st + lu])
                s1 = (g0 * buf[o1 + bp + lu] + g1 * buf[o1 + bp + st + lu] + g2 * buf[o1 + bp + st + st + lu]
                      + n2 * buf[o1 + bm + lu] + n1 * buf[o1 + bm + st + lu] + n0 * buf[o1 + bm + st + st + lu])
                s2 = (g0 * buf[o2 + bp + lu] + g1 * buf[o2 + bp + st + lu] + g2 * buf[o2 + bp + st + st + lu]
                      + n2 * buf[o2 + bm + lu] + n1 * buf[o2 + bm + st + lu] + n0 * buf[o2 + bm + st + st + lu])
                acc[lu] += wk0 * s0
                acc[U(L) + lu] += wk1 * s1
                acc[U(2 * L) + lu] += wk2 * s2
                acc[U(3 * L) + lu] += wk0 * gs
                acc[U(4 * L) + lu] += wk1 * gs
                acc[U(5 * L) + lu] += wk2 * gs
        else:
            for l in range(nl):
                lu = U(l)
                z0 = buf[zc + lu]
                dd = min(dk * svec[so + lu], cap)
                fl = np.floor(dd)
                t = dd - fl
                u = one - t
                mi = int(fl)
                a = U(centre + mi * stride + l)
                b = U(centre - mi * stride - stride + l)
                g0 = u * factor(buf[U(zoff) + a] - z0, p)
                g1 = t * factor(buf[U(zoff) + a + st] - z0, p)
                n1 = t * factor(buf[U(zoff) + b] - z0, p)
                n0 = u * factor(buf[U(zoff) + b + st] - z0, p)
                gs = g0 + g1 + n0 + n1
                for c in range(3):
                    o = U(c * coff)
                    sc = g0 * buf[o + a] + g1 * buf[o + a + st] + n1 * buf[o + b] + n0 * buf[o + b + st]
                    wc = wk0 if c == 0 else (wk1 if c == 1 else wk2)
                    acc[U(c * L) + lu] += wc * sc
                    acc[U((3 + c) * L) + lu] += wc * gs

    @njit(parallel=True, fastmath=_FASTMATH)
    def hpass(src, zk, tmp, pad, f_axis, d, wts, wsum, p):
        """Horizontal pass: (H, W, 3) + depth -> planar padded tmp (4 planes of (H + 2 pad) x W + L)."""
        h, w = zk.shape
        rw = w + 2 * pad + L
        plane = tmp.size // 4
        fa = np.float32(f_axis)
        cap = np.float32(pad - 3)
        for y in prange(h):
            buf = np.empty(5 * rw, np.float32)
            for i in range(rw):
                buf[i] = 0.0
                buf[rw + i] = 0.0
                buf[2 * rw + i] = 0.0
                buf[3 * rw + i] = np.inf
                buf[4 * rw + i] = 0.0
            for x in range(w):
                z = zk[y, x]
                buf[pad + x] = src[y, x, 0]
                buf[rw + pad + x] = src[y, x, 1]
                buf[2 * rw + pad + x] = src[y, x, 2]
                buf[3 * rw + pad + x] = z
                buf[4 * rw + pad + x] = fa / z
            acc = np.empty(6 * L, np.float32)
            row = (y + pad) * w
            for x0 in range(0, w, L):
                nl = min(L, w - x0)
                acc[:] = 0.0
                for k in range(d.size):
                    block(buf, 3 * rw, 4 * rw + pad + x0, rw, 1, pad + x0, nl, d[k], wts[k, 0], wts[k, 1], wts[k, 2],
                          p, acc, cap, buf)
                for l in range(nl):
                    x = x0 + l
                    z0 = buf[3 * rw + pad + x]
                    for c in range(3):
                        e = buf[c * rw + pad + x]
                        v = (wsum[c] - acc[(3 + c) * L + l]) * e + acc[c * L + l]
                        tmp[c * plane + row + x] = v if z0 < np.float32(np.inf) else e
                    tmp[3 * plane + row + x] = z0

    @njit(parallel=True, fastmath=_FASTMATH)
    def vpass(tmp, dst, pad, f_axis, d, wts, wsum, p):
        """Vertical pass: planar padded tmp -> (H, W, 3)."""
        h, w, _ = dst.shape
        plane = tmp.size // 4
        fa = np.float32(f_axis)
        cap = np.float32(pad - 3)
        for y in prange(h):
            acc = np.empty(6 * L, np.float32)
            srow = np.empty(w + L, np.float32)
            row = (y + pad) * w
            for x in range(w):
                srow[x] = fa / tmp[3 * plane + row + x]
            for x0 in range(0, w, L):
                nl = min(L, w - x0)
                acc[:] = 0.0
                for k in range(d.size):
                    block(tmp, 3 * plane, x0, plane, w, row + x0, nl, d[k], wts[k, 0], wts[k, 1], wts[k, 2], p, acc,
                          cap, srow)
                for l in range(nl):
                    x = x0 + l
                    z0 = tmp[3 * plane + row + x]
                    for c in range(3):
                        e = tmp[c * plane + row + x]
                        v = (wsum[c] - acc[(3 + c) * L + l]) * e + acc[c * L + l]
                        dst[y, x, c] = v if z0 < np.float32(np.inf) else e

    _VCACHE[mode] = (hpass, vpass)
    return _VCACHE[mode]


def planar_buffer(h: int, w: int, pad: int) -> np.ndarray:
    """The padded planar intermediate: 4 planes (R, G, B, depth) of (h + 2 pad) x w, plus LANES slack;
    pads hold depth +inf and colour 0."""
    plane = (h + 2 * pad) * w + LANES
    buf = np.zeros(4 * plane, np.float32)
    buf[3 * plane:] = np.inf
    return buf
