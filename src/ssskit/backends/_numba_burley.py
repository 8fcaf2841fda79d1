"""numba kernel of the Burley Monte Carlo pass (:mod:`ssskit.backends.burley_plan` for the maths).

One function, :func:`burley_rows`, runs the plan's steps 1-8 for every pixel of rows [y0, y1): the
pixel key, the count, the uniforms, the radius, the nearest-texel fetch, the indicator and the
Eq. 24 weights. Positions, radii and weights are float64, as in the numpy oracle, so both backends
fetch the same texel for every sample; the output is float32. The kernel releases the GIL
(``nogil``) and the backend runs ranges of rows on a thread pool; pixels are independent and every
random number is a pure function of (pixel, sample index, frame, seed), so the image does not depend
on the number of threads. Compiled once and cached on disk (``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._numba_separable import _mix32  # lowbias32, shared with the separable kernels

_M32 = np.uint64(0xFFFFFFFF)

#: sampler and sequence codes of the kernel (index into burley_plan.SAMPLERS / SEQUENCES)
EXACT, XIE, GOLUBEV = 0, 1, 2
R2, RANDOM = 0, 1


@njit(cache=True, inline="always")
def _unit(u):
    """xi = (float(U >> 8) + 0.5) 2^-24 (step 3)."""
    return (np.float64(u >> np.uint64(8)) + 0.5) * (1.0 / 16777216.0)


@njit(cache=True)
def inverse_cdf_unit(xi):
    """Exact inverse of Xie 2020 Eq. 20 for d = 1 (step 4), the same root as
    ssskit.profiles.burley.burley_inverse_cdf to float64 precision, with fewer transcendental calls:

    * xi >= 1e-3: Cardano, u = c - 1/c with c = cbrt(2 eta + sqrt(4 eta^2 + 1)) (= 2 sinh(asinh(2 eta) / 3)),
      c = exp(log(.) / 3), r = -3 log(u);
    * xi < 1e-3: the series r = 2 xi + 4 xi^2 / 3 + 28 xi^3 / 27 (relative error < 1e-9);

    then one Newton step on cdf(r) - xi (xi <= 1/2) or on eta - S(r) (xi > 1/2), with e = exp(-r/3) =
    1 + t, t = expm1(-r/3): cdf = -(t^3 + 3t^2 + 3t)/4 - 3t/4, S = e^3/4 + 3e/4, p = (e^3 + e)/4.
    """
    eta = 1.0 - xi
    if xi < 1e-3:
        r = xi * (2.0 + xi * (4.0 / 3.0 + xi * (28.0 / 27.0)))
    else:
        c = math.exp(math.log(2.0 * eta + math.sqrt(4.0 * eta * eta + 1.0)) / 3.0)
        r = -3.0 * math.log(c - 1.0 / c)
    t = math.expm1(-r / 3.0)
    e = 1.0 + t
    if xi > 0.5:
        resid = eta - (0.25 * e * e * e + 0.75 * e)
    else:
        resid = (-0.25 * (t * (t * (t + 3.0) + 3.0)) - 0.75 * t) - xi
    return r - resid / ((e * e * e + e) * 0.25)


@njit(cache=True, inline="always")
def _bilinear(pyr, off, hh, ww, level, s, px, py, wl, acc):
    """Add wl x the bilinear fetch of level ``level`` of slot s's pyramid at (px, py) (level-0 pixels) to
    acc (4,): premultiplied RGB and coverage (plan step 5b)."""
    scale = 1.0 / (1 << level)
    u = px * scale - 0.5
    v = py * scale - 0.5
    fi = math.floor(u)
    fj = math.floor(v)
    tu = u - fi
    tv = v - fj
    i0 = np.int64(fi)
    j0 = np.int64(fj)
    h = hh[level]
    w = ww[level]
    base = off[level] + s * h * w * 4
    for dj in range(2):
        jj = j0 + dj
        if jj < 0 or jj >= h:
            continue
        bj = tv if dj else 1.0 - tv
        for di in range(2):
            ii = i0 + di
            if ii < 0 or ii >= w:
                continue
            b = wl * bj * (tu if di else 1.0 - tu)
            k = base + (jj * w + ii) * 4
            for c in range(4):
                acc[c] += b * pyr[k + c]


@njit(cache=True, nogil=True)
def burley_rows(src, z, zbits, slots, counts, spp, use_counts, out, y0, y1, d_mm, chan, r997, sampler, sequence,
                c, bleed, fx, fy, base, stable, key2, golden, a1, a2, mips, mip_scale, max_mip, pyr, off, hh, ww,
                ell_max):
    """Steps 1-8 of the plan for rows [y0, y1). src (H, W, 3) float32, z (H, W) float32 (mm),
    zbits (H, W) uint32 (the bits of z, for a stable pattern), slots (H, W) int32, counts (H, W) int64
    (used when use_counts), out (H, W, 3) float32; with ``mips`` the pyramid of step 5b flattened
    into pyr (level L at off[L], (S, hh[L], ww[L], 4)); ell_max (S,) the slots' largest dmfp (mm) of
    step 5b."""
    h, w = slots.shape
    acc = np.zeros(4)
    for y in range(y0, y1):
        hy = _mix32(base ^ np.uint64(y))
        for x in range(w):
            s = slots[y, x]
            if s == 0:
                for ch in range(3):
                    out[y, x, ch] = src[y, x, ch]
                continue
            zp = np.float64(z[y, x])
            sx = fx / zp
            sy = fy / zp
            hk = _mix32(hy ^ np.uint64(x))  # step 1
            if stable:
                hk = _mix32(hk ^ np.uint64(zbits[y, x]))
            h1 = hk
            h2 = _mix32(hk ^ key2)
            n = counts[y, x] if use_counts else spp  # step 2
            k = chan[s]
            d_s = d_mm[s, k]
            if sampler == GOLUBEV and n > 0:
                rr = r997[s]
                cap = np.int64(math.floor(math.pi * rr * rr * sx * sy / 4.0))
                n = max(1, min(n, cap))
            i0 = 1.0 / (3.0 * d_mm[s, 0])  # exp(-r/d) = a^3 with a = exp(-r/(3d))
            i1 = 1.0 / (3.0 * d_mm[s, 1])
            i2 = 1.0 / (3.0 * d_mm[s, 2])
            q0 = d_s / d_mm[s, 0]
            q1 = d_s / d_mm[s, 1]
            q2 = d_s / d_mm[s, 2]
            i_s = 1.0 / (3.0 * d_s)
            n0 = n1 = n2 = 0.0
            e0 = e1 = e2 = 0.0
            for j in range(n):
                jj = np.uint64(j)
                if sampler == GOLUBEV:  # step 3
                    xi1 = (j + 0.5) / n
                    xi2 = _unit((h2 + jj * golden) & _M32)
                elif sequence == R2:
                    xi1 = _unit((h1 + jj * a1) & _M32)
                    xi2 = _unit((h2 + jj * a2) & _M32)
                else:
                    kk = (jj * golden) & _M32
                    xi1 = _unit(_mix32(h1 ^ kk))
                    xi2 = _unit(_mix32(h2 ^ kk))
                if sampler == XIE:  # step 4
                    r = d_s * ((2.0 - c) * xi1 - 2.0) * math.log1p(-xi1)
                else:
                    r = inverse_cdf_unit(xi1) * d_s
                phi = 2.0 * math.pi * xi2
                px = x + 0.5 + r * math.cos(phi) * sx  # step 5
                py = y + 0.5 + r * math.sin(phi) * sy
                qx = math.floor(px)
                qy = math.floor(py)
                if qx < 0 or qx >= w or qy < 0 or qy >= h:
                    continue
                ix = np.int64(qx)
                iy = np.int64(qy)
                qs = slots[iy, ix]
                if qs == s:  # step 6
                    ind = 1.0
                elif qs > 0:
                    ind = bleed
                else:
                    continue
                if ind == 0.0:
                    continue
                dz = np.float64(z[iy, ix]) - zp
                rp = math.sqrt(r * r + dz * dz)
                b = math.exp(-r * i_s)  # step 7
                f = ind / (b * b * b + b)
                a = math.exp(-rp * i0)
                w0 = f * q0 * (a * a * a + a)
                a = math.exp(-rp * i1)
                w1 = f * q1 * (a * a * a + a)
                a = math.exp(-rp * i2)
                w2 = f * q2 * (a * a * a + a)
                if mips:  # step 5b
                    p_r = (b * b * b + b) / (4.0 * d_s)  # Eq. 22 in Xie's units: radial pdf (mm^-1),
                    t = (sx / w) * (sy / h)  # t of Eq. 23 (UV^2 per mm^2), ell_max (mm)
                    arg = mip_scale * n * p_r / (ell_max[s] * ell_max[s] * t)
                    m = 0.5 * max(-math.log2(arg), 0.0) if arg > 0.0 else np.float64(max_mip)
                    m = min(m, np.float64(max_mip))
                    lo = np.int64(math.floor(m))
                    fr = m - lo
                    for cc in range(4):
                        acc[cc] = 0.0
                    if 1.0 - fr > 0.0:
                        _bilinear(pyr, off, hh, ww, lo, qs, px, py, 1.0 - fr, acc)
                    if fr > 0.0:
                        _bilinear(pyr, off, hh, ww, lo + 1, qs, px, py, fr, acc)
                    v0 = acc[0] / acc[3]
                    v1 = acc[1] / acc[3]
                    v2 = acc[2] / acc[3]
                else:
                    v0 = src[iy, ix, 0]
                    v1 = src[iy, ix, 1]
                    v2 = src[iy, ix, 2]
                n0 += w0 * v0
                n1 += w1 * v1
                n2 += w2 * v2
                e0 += w0
                e1 += w1
                e2 += w2
            out[y, x, 0] = n0 / e0 if e0 > 0.0 else src[y, x, 0]  # step 8
            out[y, x, 1] = n1 / e1 if e1 > 0.0 else src[y, x, 1]
            out[y, x, 2] = n2 / e2 if e2 > 0.0 else src[y, x, 2]
