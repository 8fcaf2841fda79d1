"""numba kernels of the separable pass (see :mod:`ssskit.screenspace.separable` for the maths).

Layout and order, chosen for speed on CPUs (benchmarks/bench_separable.py):

* the horizontal pass copies its row into a small (W, 4) RGBZ buffer (cache resident) and writes
  an RGBZ intermediate, so the vertical pass fetches colour and depth of a sample from one cache
  line; the vertical pass walks output rows, so its taps stream along a dozen nearby rows;
* taps come in symmetric pairs +-d: one floor gives the four bilinear corners x+n, x+n+1, x-n,
  x-n-1 with weights (1-t, t, 1-t, t); the centre tap costs nothing (its weight multiplies E(p));
* out = (W - G) E(p) + A with A = sum w g E_j and G = sum w g, g = bilinear weight x depth factor;
* indices are unsigned after the bounds test, so numba emits no negative-index wraparound code,
  and pixels whose whole footprint is inside the image skip the per-corner bounds tests;
* the depth mode is a compile-time constant (one specialisation per mode);
* fastmath without 'nnan'/'ninf': +inf marks pixels outside the region and must compare as such.

Tap table rows: (offset, kind) with kind 0 = symmetric pair at +-offset, 1 = single tap at the
signed offset; jittered taps (rotated axes) are the first ``n_jit`` rows.
"""

from __future__ import annotations

import math

import numpy as np

_FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}
_CACHE: dict[int, tuple] = {}


def kernels(mode: int):
    """(hpass, vpass) compiled for depth mode 0 (gaussian), 1 (follow) or 2 (none)."""
    if mode in _CACHE:
        return _CACHE[mode]
    from numba import njit, prange

    @njit(fastmath=_FASTMATH, inline="always")
    def factor(dz, p):
        if mode == 0:
            return np.float32(math.exp(-dz * dz * p))
        if mode == 1:
            return max(np.float32(0.0), np.float32(1.0) - abs(dz) * p)
        return np.float32(1.0) if abs(dz) < np.float32(np.inf) else np.float32(0.0)

    @njit(fastmath=_FASTMATH, inline="always")
    def mix32(h):
        h = h ^ (h >> np.uint64(16))
        h = (h * np.uint64(0x7FEB352D)) & np.uint64(0xFFFFFFFF)
        h = h ^ (h >> np.uint64(15))
        h = (h * np.uint64(0x846CA68B)) & np.uint64(0xFFFFFFFF)
        return h ^ (h >> np.uint64(16))

    @njit(fastmath=_FASTMATH, inline="always")
    def side_row(buf, i, u, t, z0, p):
        """Bilinear sample between texels i, i+1 (unsigned, inside) of a (W, 4) RGBZ row buffer:
        (f, f*RGB) with f the depth factor of the larger depth difference of the two texels."""
        dz = max(abs(buf[i, 3] - z0), abs(buf[i + 1, 3] - z0))
        f = factor(dz, p)
        fu = f * u
        ft = f * t
        return f, fu * buf[i, 0] + ft * buf[i + 1, 0], fu * buf[i, 1] + ft * buf[i + 1, 1], \
            fu * buf[i, 2] + ft * buf[i + 1, 2]

    @njit(fastmath=_FASTMATH, inline="always")
    def side_col(arr, j, x, u, t, z0, p):
        """The same between rows j, j+1 of column x of an (H, W, 4) RGBZ array."""
        dz = max(abs(arr[j, x, 3] - z0), abs(arr[j + 1, x, 3] - z0))
        f = factor(dz, p)
        fu = f * u
        ft = f * t
        return f, fu * arr[j, x, 0] + ft * arr[j + 1, x, 0], fu * arr[j, x, 1] + ft * arr[j + 1, x, 1], \
            fu * arr[j, x, 2] + ft * arr[j + 1, x, 2]

    @njit(fastmath=_FASTMATH, inline="always")
    def pair_row(buf, x, m, t, z0, p, interior, w):
        """Samples at x + (m + t) and x - (m + t) of a symmetric pair, summed: (f, f*RGB)."""
        u = np.float32(1.0) - t
        g0 = a0 = b0 = c0 = g1 = a1 = b1 = c1 = np.float32(0.0)
        if interior or (x + m + 1 < w):
            g0, a0, b0, c0 = side_row(buf, np.uintp(x + m), u, t, z0, p)
        if interior or (x - m - 1 >= 0):
            g1, a1, b1, c1 = side_row(buf, np.uintp(x - m - 1), t, u, z0, p)
        return g0 + g1, a0 + a1, b0 + b1, c0 + c1

    @njit(fastmath=_FASTMATH, inline="always")
    def pair_col(arr, x, y, m, t, z0, p, interior, h):
        u = np.float32(1.0) - t
        xu = np.uintp(x)
        g0 = a0 = b0 = c0 = g1 = a1 = b1 = c1 = np.float32(0.0)
        if interior or (y + m + 1 < h):
            g0, a0, b0, c0 = side_col(arr, np.uintp(y + m), xu, u, t, z0, p)
        if interior or (y - m - 1 >= 0):
            g1, a1, b1, c1 = side_col(arr, np.uintp(y - m - 1), xu, t, u, z0, p)
        return g0 + g1, a0 + a1, b0 + b1, c0 + c1

    @njit(fastmath=_FASTMATH)
    def bilinear_2d(rgb, zk, arr, rgbz, px, py, z0, p):
        """A jittered 2D bilinear sample at (px, py): (f, f*RGB), f from the largest depth
        difference of its 4 texels, 0 if any texel is outside the image. Reads the (H, W, 4) RGBZ
        array ``arr`` if ``rgbz`` else the (H, W, 3) colour ``rgb`` and (H, W) depth ``zk``."""
        h = arr.shape[0] if rgbz else zk.shape[0]
        w = arr.shape[1] if rgbz else zk.shape[1]
        fx = np.floor(px)
        fy = np.floor(py)
        i0 = int(fx)
        j0 = int(fy)
        if i0 < 0 or j0 < 0 or i0 + 1 >= w or j0 + 1 >= h:
            return np.float32(0.0), np.float32(0.0), np.float32(0.0), np.float32(0.0)
        tx = np.float32(px - fx)
        ty = np.float32(py - fy)
        dz = np.float32(0.0)
        for c in range(4):
            jj = j0 + (c >> 1)
            ii = i0 + (c & 1)
            zc = arr[jj, ii, 3] if rgbz else zk[jj, ii]
            dz = max(dz, abs(zc - z0))
        f = factor(dz, p)
        s0 = s1 = s2 = np.float32(0.0)
        for c in range(4):
            jj = j0 + (c >> 1)
            ii = i0 + (c & 1)
            b = f * (tx if c & 1 else np.float32(1.0) - tx) * (ty if c >> 1 else np.float32(1.0) - ty)
            if rgbz:
                s0 += b * arr[jj, ii, 0]
                s1 += b * arr[jj, ii, 1]
                s2 += b * arr[jj, ii, 2]
            else:
                s0 += b * rgb[jj, ii, 0]
                s1 += b * rgb[jj, ii, 1]
                s2 += b * rgb[jj, ii, 2]
        return f, s0, s1, s2

    @njit(parallel=True, fastmath=_FASTMATH)
    def hpass(src, zk, dst, f_axis, offs, kinds, wts, wsum, n_jit, n_pair, p, base):
        h, w = zk.shape
        n = offs.size
        fa = np.float32(f_axis)
        reach = np.float32(0.0)
        for k in range(n):
            reach = max(reach, abs(offs[k]))
        dummy4 = np.zeros((1, 1, 4), np.float32)
        for y in prange(h):
            buf = np.empty((w, 4), np.float32)
            for x in range(w):
                buf[x, 0] = src[y, x, 0]
                buf[x, 1] = src[y, x, 1]
                buf[x, 2] = src[y, x, 2]
                buf[x, 3] = zk[y, x]
            hy = mix32(base ^ np.uint64(y))
            for x in range(w):
                z0 = buf[x, 3]
                e0 = buf[x, 0]
                e1 = buf[x, 1]
                e2 = buf[x, 2]
                dst[y, x, 3] = z0
                if not (z0 < np.float32(np.inf)):  # stencil: no SSS here
                    dst[y, x, 0] = e0
                    dst[y, x, 1] = e1
                    dst[y, x, 2] = e2
                    continue
                s = fa / z0
                A0 = A1 = A2 = G0 = G1 = G2 = np.float32(0.0)
                if n_jit > 0:  # rotated axes, 2D bilinear fetches (paper section 6)
                    theta = float(mix32(hy ^ np.uint64(x))) * (2.0 * math.pi / 4294967296.0)
                    cth = math.cos(theta)
                    sth = math.sin(theta)
                    for k in range(n_jit):
                        d = offs[k] * s
                        gs, S0, S1, S2 = bilinear_2d(src, zk, dummy4, False, x + d * cth, y + d * sth, z0, p)
                        if kinds[k] == 0:
                            g, a0, a1, a2 = bilinear_2d(src, zk, dummy4, False, x - d * cth, y - d * sth, z0, p)
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
                interior = (x - reach * s - 2.0 >= 0.0) and (x + reach * s + 2.0 < w)
                for k in range(n_jit, n_jit + n_pair):
                    dd = offs[k] * s
                    fl = np.floor(dd)  # float32 floor: math.floor would widen to int64 and float64
                    gs, S0, S1, S2 = pair_row(buf, x, np.intp(fl), dd - fl, z0, p, interior, w)
                    A0 += wts[k, 0] * S0
                    A1 += wts[k, 1] * S1
                    A2 += wts[k, 2] * S2
                    G0 += wts[k, 0] * gs
                    G1 += wts[k, 1] * gs
                    G2 += wts[k, 2] * gs
                for k in range(n_jit + n_pair, n):
                    pos = np.float32(x) + offs[k] * s
                    fl = np.floor(pos)
                    t = pos - fl
                    i0 = np.intp(fl)
                    gs = S0 = S1 = S2 = np.float32(0.0)
                    if i0 >= 0 and i0 + 1 < w:
                        gs, S0, S1, S2 = side_row(buf, np.uintp(i0), np.float32(1.0) - t, t, z0, p)
                    A0 += wts[k, 0] * S0
                    A1 += wts[k, 1] * S1
                    A2 += wts[k, 2] * S2
                    G0 += wts[k, 0] * gs
                    G1 += wts[k, 1] * gs
                    G2 += wts[k, 2] * gs
                dst[y, x, 0] = (wsum[0] - G0) * e0 + A0
                dst[y, x, 1] = (wsum[1] - G1) * e1 + A1
                dst[y, x, 2] = (wsum[2] - G2) * e2 + A2

    @njit(parallel=True, fastmath=_FASTMATH)
    def vpass(src4, dst, f_axis, offs, kinds, wts, wsum, n_jit, n_pair, p, base):
        h, w, _ = src4.shape
        n = offs.size
        fa = np.float32(f_axis)
        reach = np.float32(0.0)
        for k in range(n):
            reach = max(reach, abs(offs[k]))
        dummy3 = np.zeros((1, 1, 3), np.float32)
        dummyz = np.zeros((1, 1), np.float32)
        for y in prange(h):
            hy = mix32(base ^ np.uint64(y))
            for x in range(w):
                z0 = src4[y, x, 3]
                e0 = src4[y, x, 0]
                e1 = src4[y, x, 1]
                e2 = src4[y, x, 2]
                if not (z0 < np.float32(np.inf)):
                    dst[y, x, 0] = e0
                    dst[y, x, 1] = e1
                    dst[y, x, 2] = e2
                    continue
                s = fa / z0
                A0 = A1 = A2 = G0 = G1 = G2 = np.float32(0.0)
                if n_jit > 0:
                    theta = float(mix32(hy ^ np.uint64(x))) * (2.0 * math.pi / 4294967296.0)
                    cth = math.cos(theta)
                    sth = math.sin(theta)
                    for k in range(n_jit):
                        d = offs[k] * s
                        gs, S0, S1, S2 = bilinear_2d(dummy3, dummyz, src4, True, x - d * sth, y + d * cth, z0, p)
                        if kinds[k] == 0:
                            g, a0, a1, a2 = bilinear_2d(dummy3, dummyz, src4, True, x + d * sth, y - d * cth, z0, p)
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
                interior = (y - reach * s - 2.0 >= 0.0) and (y + reach * s + 2.0 < h)
                for k in range(n_jit, n_jit + n_pair):
                    dd = offs[k] * s
                    fl = np.floor(dd)  # float32 floor: math.floor would widen to int64 and float64
                    gs, S0, S1, S2 = pair_col(src4, x, y, np.intp(fl), dd - fl, z0, p, interior, h)
                    A0 += wts[k, 0] * S0
                    A1 += wts[k, 1] * S1
                    A2 += wts[k, 2] * S2
                    G0 += wts[k, 0] * gs
                    G1 += wts[k, 1] * gs
                    G2 += wts[k, 2] * gs
                xu = np.uintp(x)
                for k in range(n_jit + n_pair, n):
                    pos = np.float32(y) + offs[k] * s
                    fl = np.floor(pos)
                    t = pos - fl
                    j0 = np.intp(fl)
                    gs = S0 = S1 = S2 = np.float32(0.0)
                    if j0 >= 0 and j0 + 1 < h:
                        gs, S0, S1, S2 = side_col(src4, np.uintp(j0), xu, np.float32(1.0) - t, t, z0, p)
                    A0 += wts[k, 0] * S0
                    A1 += wts[k, 1] * S1
                    A2 += wts[k, 2] * S2
                    G0 += wts[k, 0] * gs
                    G1 += wts[k, 1] * gs
                    G2 += wts[k, 2] * gs
                dst[y, x, 0] = (wsum[0] - G0) * e0 + A0
                dst[y, x, 1] = (wsum[1] - G1) * e1 + A1
                dst[y, x, 2] = (wsum[2] - G2) * e2 + A2

    _CACHE[mode] = (hpass, vpass)
    return _CACHE[mode]


def tap_table(offsets: np.ndarray, weights: np.ndarray, n_jit: int):
    """Rows for the kernels above: (offs, kinds, wts, n_jit_rows, n_pair_rows).

    ``offsets`` (N,) centre first and sorted by |o| (as SeparableTaps stores them), ``weights`` (N, 3);
    the first ``n_jit`` taps are jittered. A tap at -o with the same weights as the tap at +o becomes
    one pair row (kind 0, offset |o|); others are single rows (kind 1, signed offset). Centre taps
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
            if not used[j] and offsets[j] == -o and np.array_equal(weights[j], weights[i]) and (j < n_jit) == jit:
                partner = j
                break
        if partner >= 0:
            used[partner] = True
            rows.append((abs(o), 0, weights[i], jit))
        else:
            rows.append((o, 1, weights[i], jit))
    rows.sort(key=lambda r: (not r[3], r[1]))  # jittered first, then pairs, then singles
    offs = np.array([r[0] for r in rows], np.float32)
    kinds = np.array([r[1] for r in rows], np.int64)
    wts = np.array([r[2] for r in rows], np.float32).reshape(-1, 3)
    n_jit_rows = sum(1 for r in rows if r[3])
    n_pair_rows = sum(1 for r in rows if not r[3] and r[1] == 0)
    return offs, kinds, wts, n_jit_rows, n_pair_rows
