"""numba kernels of the Burley Monte Carlo pass (:mod:`ssskit.backends.burley_plan` for the maths).

:func:`burley_rows` runs the plan's steps 1-8 for every pixel of rows [y0, y1): the pixel key, the
count, the uniforms, the radius, the texel fetch, the indicator and the Eq. 24 weights.

Without mips (:func:`_vec_rows`) it takes LANES = 8 neighbouring pixels at a time and draws sample j
of all of them in one branch-free lane loop that LLVM compiles to 8-wide AVX2 float32 code (gathers
for the texels): uniforms from 32-bit integer hashes, the exact inverse of Eq. 20 or Eq. 21, the
angle's sine and cosine, the four exponentials of the weights, all by the vectorisable functions of
:mod:`ssskit.compute.numba_math` instead of libm calls. Only loads and stores of 32-bit values
occur in that loop (LLVM picks its vector width from the widest), and its scratch lives on the stack
(:func:`~ssskit.compute.numba_math.stack_empty`), so no alias check stops the vectoriser. The
texel of a sample must be the oracle's (the parity tests compare the images within 2e-5): a float32
position within GUARD (sx (r + d_s) + 1) of a texel edge (50 times the float32 error bound measured
in ``tests/compute/test_numba_math.py``; about 1 sample in 1000) is found again in float64 exactly
as the oracle does (:func:`_exact_texel`), every other one lies on the oracle's texel. The weights
are float32 (error ~1e-7 relative), summed in float32 over CHUNK samples, then in float64.

With mips (plan step 5b, Xie 2020 Eqs. 22-23) the same lanes compute the level's argument
a n p(r) / (ell^2 t) in float32; where it is >= 1 (level 0: with Xie's a = 1/16 all but the far tail of
the profile, docs/burley-mips.md) they fetch level 0 bilinearly and coverage-normalised from the frame
itself (four texels of ``src`` and ``slots``; the nearest texel carries a bilinear weight >= 1/4, so the
normalisation never divides by less, and the fetch is continuous in the position: float32 positions move
it by float32 rounding only). A sample above level 0, or near a texel edge, is drawn again whole in
float64 as the oracle does (:func:`_sample_f64`, the trilinear fetch of the float32 pyramid that
:func:`mip_level1` and :func:`mip_coarse` build). Profiled before (issue 35): the float64 one-sample-at-a-
time kernel took 4.2 s of the 4.5 s 1080p frame at 8 spp, the numpy pyramid 0.3 s.

The kernels release the GIL (``nogil``) and the backend runs ranges of rows on a thread pool; pixels
are independent and every random number is a pure function of (pixel, sample index, frame, seed), so
the image does not depend on the number of threads. Compiled once and cached on disk (``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..compute.numba_math import (FM32, burley_rho_f32, exp2_f32, i32, i32_madd, load_at, log_f32, mix32_u32,
                                  sincos_u24, stack_empty, u24_f32, u32_madd, u32_xor)
from ._numba_separable import _mix32  # lowbias32, shared with the separable kernels

_M32 = np.uint64(0xFFFFFFFF)
#: pixels per step of the vectorised kernel (8 float32 lanes of an AVX2 register)
LANES = 8
_L2, _L3, _L4, _L6 = 2 * LANES, 3 * LANES, 4 * LANES, 6 * LANES
#: a float32 sample position within GUARD x (sx (r + d_s) + 1) of a texel edge takes the float64 path; the
#: float32 error is below 1e-6 of that (tests/compute/test_numba_math.py)
GUARD = np.float32(2.0**-15)
#: samples summed in float32 before the float64 totals
CHUNK = 32
_ONE32 = np.float32(1.0)
_ZERO32 = np.float32(0.0)
_HALF32 = np.float32(0.5)
_TWO32 = np.float32(2.0)
_QUARTER32 = np.float32(0.25)
_U24 = np.float32(2.0**-24)
_TOP24 = np.float32(2.0**24 - 1.0)
_LOG2E = 1.4426950408889634

#: sampler and sequence codes of the kernel (index into burley_plan.SAMPLERS / SEQUENCES)
EXACT, XIE, GOLUBEV = 0, 1, 2
R2, RANDOM = 0, 1


@njit(cache=True)
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


@njit(cache=True)
def _bilinear(src, slots, pyr, off, hh, ww, level, s, px, py):
    """The bilinear fetch of level ``level`` of slot s's pyramid at (px, py) (level-0 pixels), float64
    (plan step 5b): (sum b C_R, sum b C_G, sum b C_B, sum b K) of the premultiplied colour C and coverage K.
    Level 0 is read from the frame itself ((E [slots = s], [slots = s]) per texel), levels >= 1 from
    :func:`mip_level1` / :func:`mip_coarse`'s float32 planes (slot s at plane s - 1)."""
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
    base = off[level] + (s - 1) * h * w * 4
    c0 = c1 = c2 = k = 0.0
    for dj in range(2):
        jj = j0 + dj
        if jj < 0 or jj >= h:
            continue
        bj = tv if dj else 1.0 - tv
        for di in range(2):
            ii = i0 + di
            if ii < 0 or ii >= w:
                continue
            b = bj * (tu if di else 1.0 - tu)
            if level == 0:
                if slots[jj, ii] == s:
                    c0 += b * src[jj, ii, 0]
                    c1 += b * src[jj, ii, 1]
                    c2 += b * src[jj, ii, 2]
                    k += b
            else:
                q = base + (jj * w + ii) * 4
                c0 += b * pyr[q]
                c1 += b * pyr[q + 1]
                c2 += b * pyr[q + 2]
                k += b * pyr[q + 3]
    return c0, c1, c2, k


@njit(cache=True, nogil=True)
def mip_level1(src, slots, pyr, off1, h1, w1, y0, y1):
    """Rows [y0, y1) of level 1 of every slot's pyramid (plan step 5b, :func:`~ssskit.backends.burley_plan.
    mip_pyramid`): the mean over the 2 x 2 children (off the image: 0) of (E [slots = s], [slots = s]), into
    the zeroed float32 planes at pyr[off1:] ((S - 1, h1, w1, 4), slot s at plane s - 1)."""
    h, w = slots.shape
    plane = h1 * w1 * 4
    for j in range(y0, y1):
        for i in range(w1):
            for dj in range(2):
                yy = 2 * j + dj
                if yy >= h:
                    continue
                for di in range(2):
                    xx = 2 * i + di
                    if xx >= w:
                        continue
                    s = slots[yy, xx]
                    if s <= 0:
                        continue
                    q = off1 + (s - 1) * plane + (j * w1 + i) * 4
                    pyr[q] += 0.25 * src[yy, xx, 0]
                    pyr[q + 1] += 0.25 * src[yy, xx, 1]
                    pyr[q + 2] += 0.25 * src[yy, xx, 2]
                    pyr[q + 3] += 0.25


@njit(cache=True, nogil=True)
def mip_coarse(pyr, off, hh, ww, planes, max_mip):
    """Levels 2 .. max_mip of the pyramid from level 1: each the mean of the 2 x 2 children of the level
    below (children off that level count 0), float32 planes as :func:`mip_level1`'s."""
    for lv in range(2, max_mip + 1):
        ch, cw = hh[lv - 1], ww[lv - 1]
        h, w = hh[lv], ww[lv]
        for p in range(planes):
            src = off[lv - 1] + p * ch * cw * 4
            dst = off[lv] + p * h * w * 4
            for j in range(h):
                for i in range(w):
                    for c in range(4):
                        t = 0.0
                        for dj in range(2):
                            yy = 2 * j + dj
                            if yy >= ch:
                                continue
                            for di in range(2):
                                xx = 2 * i + di
                                if xx < cw:
                                    t += pyr[src + (yy * cw + xx) * 4 + c]
                        pyr[dst + (j * w + i) * 4 + c] = 0.25 * t


# ---- the vectorised kernel (no mips): LANES pixels side by side, float32, one sample of each per step ------


@njit(cache=True, inline="always", fastmath=FM32, error_model="numpy")
def _tap(sf, srcf, s, bx, by, fw, fh, w, b):
    """One texel of step 5b's level-0 bilinear fetch in the lanes: texel (bx, by) (integer-valued float32)
    weighted b when on the image and of slot s, else 0: (b E_R, b E_G, b E_B, b) (level 0 of slot s's
    pyramid is (E [slots = s], [slots = s]))."""
    inb = (bx >= _ZERO32) & (bx < fw) & (by >= _ZERO32) & (by < fh)
    q = i32_madd(i32(by), w, i32(bx)) if inb else i32(0)
    bw = b if (inb & (load_at(sf, q) == s)) else _ZERO32
    return (bw * load_at(srcf, i32_madd(q, 3, 0)), bw * load_at(srcf, i32_madd(q, 3, 1)),
            bw * load_at(srcf, i32_madd(q, 3, 2)), bw)


@njit(cache=True, inline="always", fastmath=FM32, error_model="numpy")
def _weights(r, rp, k_s, k0, k1, k2, q0, q1, q2):
    """Step 7's weights in float32 without underflow: with b = exp(-r/(3 d_s)) and, per channel,
    g = exp(r/(3 d_s) - r'/(3 d_c)) = a / b (a = exp(-r'/(3 d_c))), w_c = (d_s/d_c) (a^3 + a) / (b^3 + b)
    = q_c g (a^2 + 1) / (b^2 + 1). The exponent of g is <= 0 (r' >= r, d_c <= d_s). The exponentials
    are powers of 2: k = log2(e) / (3 d) per channel (the slot table). Also returns b (b^3 + b = 4 d_s p(r),
    the radial pdf of Eq. 22)."""
    t = r * k_s
    b = exp2_f32(-t)
    inv = _ONE32 / (b * b + _ONE32)
    g0 = exp2_f32(t - rp * k0)
    g1 = exp2_f32(t - rp * k1)
    g2 = exp2_f32(t - rp * k2)
    a0 = g0 * b
    a1 = g1 * b
    a2 = g2 * b
    return (q0 * g0 * (a0 * a0 + _ONE32) * inv, q1 * g1 * (a1 * a1 + _ONE32) * inv,
            q2 * g2 * (a2 * a2 + _ONE32) * inv, b)


@njit(cache=True)
def _uniforms(j, n, h1, h2, sampler, sequence, golden, a1, a2):
    """The two uniforms of sample j of a pixel with hashes (h1, h2) (steps 3 of the plan): Golubev's
    stratified radius uniform and a golden-ratio angle, else the R2 sequence, else hashed white noise."""
    jj = np.uint64(j)
    if sampler == GOLUBEV:
        return (j + 0.5) / n, _unit((h2 + jj * golden) & _M32)
    if sequence == R2:
        return _unit((h1 + jj * a1) & _M32), _unit((h2 + jj * a2) & _M32)
    kk = (jj * golden) & _M32
    return _unit(_mix32(h1 ^ kk)), _unit(_mix32(h2 ^ kk))


@njit(cache=True)
def _exact_texel(x, y, j, n, h1, h2, ds, sx, sy, c, sampler, sequence, golden, a1, a2):
    """The texel of sample j of pixel (x, y) exactly as the float64 oracle finds it (steps 3-5): the
    fallback of the float32 lanes for samples within their error bound of a texel edge. Returns (r, ix,
    iy) with r in mm (float64)."""
    xi1, xi2 = _uniforms(j, n, h1, h2, sampler, sequence, golden, a1, a2)
    if sampler == XIE:
        r = ds * ((2.0 - c) * xi1 - 2.0) * math.log1p(-xi1)
    else:
        r = inverse_cdf_unit(xi1) * ds
    phi = 2.0 * math.pi * xi2
    px = x + 0.5 + r * math.cos(phi) * sx
    py = y + 0.5 + r * math.sin(phi) * sy
    return r, np.int64(math.floor(px)), np.int64(math.floor(py))


@njit(cache=True, inline="always", fastmath=FM32, error_model="numpy")
def _vec_rows(src, z, zbits, slots, counts, spp, use_counts, out, y0, y1, d_mm, chan, r997, sampler, sequence,
              c, bleed, fx, fy, base, stable, key2, golden, a1, a2, xie, mips, mp):
    """Steps 1-8 for rows [y0, y1), LANES pixels at a time (module docstring); ``xie`` and ``mips`` (constants
    at each call site) select the radius of Eq. 21 instead of the exact inverse, and step 5b's prefiltered
    fetch (level 0 in the lanes, any level above 0 by :func:`_sample_f64`) instead of the nearest texel;
    mp = (mip_scale, max_mip, pyr, off, hh, ww, ell_max) (:func:`burley_rows`)."""
    mip_scale, max_mip, pyr, off, hh, ww, ell_max = mp
    U = np.uintp
    h, w = slots.shape
    srcf = src.reshape(-1)
    zf = z.reshape(-1)
    sf = slots.reshape(-1)
    lz = stack_empty(LANES, np.float32)  # lane data: depth, pixels per mm, d_s, 1/(3 d), d_s/d_c
    lsx = stack_empty(LANES, np.float32)
    lsy = stack_empty(LANES, np.float32)
    lds = stack_empty(LANES, np.float32)
    li3 = stack_empty(_L4, np.float32)
    lq = stack_empty(_L3, np.float32)
    lmc = stack_empty(LANES, np.float32)  # Eq. 22's a n / (4 d_s ell^2 t): the level is 0 where lmc (b^3 + b) >= 1
    ls = stack_empty(LANES, np.int32)  # slot
    ln = stack_empty(LANES, np.int32)  # sample count
    lh = stack_empty(_L2, np.uint32)  # h1, h2
    acc = stack_empty(_L6, np.float32)  # sum w_c V_c, sum w_c over a chunk of samples
    tot = stack_empty(_L6, np.float64)  # ... over all samples
    flag = stack_empty(LANES, np.int32)
    fc = np.float32(c)
    fb = np.float32(bleed)
    fw = np.float32(w)
    fh = np.float32(h)
    ns = d_mm.shape[0]
    tab = np.empty((ns, 8), np.float32)  # per slot: d_s, log2(e) / (3 d_s), log2(e) / (3 d_c), d_s / d_c
    for si in range(ns):
        d_s = d_mm[si, chan[si]]
        tab[si, 0] = d_s
        tab[si, 1] = _LOG2E / (3.0 * d_s)
        for ch in range(3):
            tab[si, 2 + ch] = _LOG2E / (3.0 * d_mm[si, ch])
            tab[si, 5 + ch] = d_s / d_mm[si, ch]
    for y in range(y0, y1):
        hy = np.uint32(_mix32(base ^ np.uint64(y)))
        fy0 = np.float32(y)
        for x0 in range(0, w, LANES):
            nmax = 0
            for l in range(LANES):  # lane set-up (steps 1-2)
                lu = U(l)
                x = x0 + l
                act = x < w
                xc = min(x, w - 1)
                p = U(y * w + xc)
                s = sf[p] if act else np.int32(0)
                n = (counts[y, xc] if use_counts else spp) if s > 0 else 0
                zp = zf[p]
                hk = mix32_u32(u32_xor(hy, x))
                hk = mix32_u32(u32_xor(hk, zbits[y, xc])) if stable else hk
                lh[lu] = hk
                lh[U(LANES) + lu] = mix32_u32(u32_xor(hk, key2))
                su = U(s)
                ln[lu] = np.int32(n)
                ls[lu] = s
                lz[lu] = zp
                lsx[lu] = np.float32(fx / np.float64(zp))
                lsy[lu] = np.float32(fy / np.float64(zp))
                lds[lu] = tab[su, 0]
                for k in range(4):
                    li3[U(k * LANES) + lu] = tab[su, 1 + k]
                for ch in range(3):
                    lq[U(ch * LANES) + lu] = tab[su, 5 + ch]
            if sampler == GOLUBEV:  # golubev caps the count by the footprint (float64, as the oracle)
                for l in range(LANES):
                    n = int(ln[l])
                    if n > 0:
                        zp = np.float64(lz[l])
                        rr = r997[ls[l]]
                        cap = int(math.floor(math.pi * rr * rr * (fx / zp) * (fy / zp) / 4.0))
                        ln[l] = np.int32(max(1, min(n, cap)))
            for l in range(LANES):
                nmax = max(nmax, int(ln[l]))
            if mips:  # Eq. 22-23 in Xie's units (plan step 5b) with the pixel's (capped) count, float64 then float32
                for l in range(LANES):
                    n = int(ln[l])
                    cm = 0.0
                    if n > 0:
                        zp = np.float64(lz[l])
                        t_uv = (fx / zp / w) * (fy / zp / h)
                        ell = ell_max[ls[l]]
                        cm = min(mip_scale * n / (4.0 * np.float64(lds[l]) * ell * ell * t_uv), 1e30)
                    lmc[l] = np.float32(cm)
            for i in range(_L6):
                tot[i] = 0.0
            for j in range(nmax):
                if j % CHUNK == 0:
                    for i in range(_L6):
                        acc[i] = _ZERO32
                jj = np.uint64(j)
                fj = np.float32(j)
                for l in range(LANES):  # one sample per lane (steps 3-8), no branches, 32-bit loads and stores
                    lu = U(l)
                    x = x0 + l
                    n = ln[lu]
                    act = j < n
                    h1 = lh[lu]
                    h2 = lh[U(LANES) + lu]
                    if sampler == GOLUBEV:  # step 3
                        fn = np.float32(max(n, 1))
                        xi = (fj + _HALF32) / fn
                        eta = (fn - fj - _HALF32) / fn
                        u2 = u32_madd(h2, j, golden)
                    else:
                        if sequence == R2:
                            u1 = u32_madd(h1, j, a1)
                            u2 = u32_madd(h2, j, a2)
                        else:
                            kk = u32_madd(0, j, golden)
                            u1 = mix32_u32(u32_xor(h1, kk))
                            u2 = mix32_u32(u32_xor(h2, kk))
                        m1 = u24_f32(u1)
                        xi = (m1 + _HALF32) * _U24
                        eta = ((_TOP24 - m1) + _HALF32) * _U24
                    eta = max(eta, _U24)  # lanes past their count
                    ds = lds[lu]
                    if xie:  # step 4
                        r = ds * ((_TWO32 - fc) * xi - _TWO32) * log_f32(eta)
                    else:
                        r = ds * burley_rho_f32(eta)
                    cs, sn = sincos_u24(u24_f32(u2))
                    sx = lsx[lu]
                    sy = lsy[lu]
                    dx = r * cs * sx  # step 5, relative to the pixel's corner
                    dy = r * sn * sy
                    tx = _HALF32 + dx
                    ty = _HALF32 + dy
                    flx = np.floor(tx)
                    fly = np.floor(ty)
                    frx = tx - flx
                    fry = ty - fly
                    ex = GUARD * (sx * (r + ds) + _ONE32)  # > the float32 error of dx (and of dy below)
                    ey = GUARD * (sy * (r + ds) + _ONE32)
                    near = (frx < ex) | (frx > _ONE32 - ex) | (fry < ey) | (fry > _ONE32 - ey)
                    ix = flx + np.float32(x)  # the texel, in float32 (exact: |ix|, |iy| < 2^24)
                    iy = fly + fy0
                    inb = (ix >= _ZERO32) & (ix < fw) & (iy >= _ZERO32) & (iy < fh)
                    ok = act & inb & (not near)
                    fl = act & near
                    q = i32_madd(i32(iy), w, i32(ix)) if ok else i32(y * w + min(x, w - 1))
                    s = ls[lu]
                    qs = load_at(sf, q)  # step 6
                    ind = _ONE32 if qs == s else (fb if qs > 0 else _ZERO32)
                    ind = ind if ok else _ZERO32
                    dz = load_at(zf, q) - lz[lu]
                    rp = math.sqrt(r * r + dz * dz)
                    w0, w1, w2, bb = _weights(r, rp, li3[lu], li3[U(LANES) + lu], li3[U(2 * LANES) + lu],
                                              li3[U(3 * LANES) + lu], lq[lu], lq[U(LANES) + lu], lq[U(2 * LANES) + lu])
                    valid = ind > _ZERO32
                    if mips:  # step 5b: level 0 here (bilinear, coverage-normalised), above 0 in float64
                        up = (bb * bb * bb + bb) * lmc[lu] < _ONE32
                        fl = fl | (valid & up)
                        valid = valid & (not up)
                        fdx = np.floor(dx)  # u = px - 1/2 = x + dx, relative to the pixel
                        fdy = np.floor(dy)
                        tu = dx - fdx
                        tv = dy - fdy
                        bx = fdx + np.float32(x)
                        by = fdy + fy0
                        p0, p1, p2, k0 = _tap(sf, srcf, qs, bx, by, fw, fh, w, (_ONE32 - tu) * (_ONE32 - tv))
                        t0, t1, t2, kt = _tap(sf, srcf, qs, bx + _ONE32, by, fw, fh, w, tu * (_ONE32 - tv))
                        p0 += t0
                        p1 += t1
                        p2 += t2
                        k0 += kt
                        t0, t1, t2, kt = _tap(sf, srcf, qs, bx, by + _ONE32, fw, fh, w, (_ONE32 - tu) * tv)
                        p0 += t0
                        p1 += t1
                        p2 += t2
                        k0 += kt
                        t0, t1, t2, kt = _tap(sf, srcf, qs, bx + _ONE32, by + _ONE32, fw, fh, w, tu * tv)
                        inv_k = _ONE32 / max(k0 + kt, _QUARTER32)  # >= 1/4 where valid: the nearest texel's weight
                        v0 = (p0 + t0) * inv_k
                        v1 = (p1 + t1) * inv_k
                        v2 = (p2 + t2) * inv_k
                    else:
                        v0 = load_at(srcf, i32_madd(q, 3, 0))
                        v1 = load_at(srcf, i32_madd(q, 3, 1))
                        v2 = load_at(srcf, i32_madd(q, 3, 2))
                    flag[lu] = np.int32(1) if fl else np.int32(0)
                    w0 = w0 * ind if valid else _ZERO32
                    w1 = w1 * ind if valid else _ZERO32
                    w2 = w2 * ind if valid else _ZERO32
                    acc[lu] += w0 * v0 if valid else _ZERO32  # step 8's sums
                    acc[U(LANES) + lu] += w1 * v1 if valid else _ZERO32
                    acc[U(2 * LANES) + lu] += w2 * v2 if valid else _ZERO32
                    acc[U(3 * LANES) + lu] += w0
                    acc[U(4 * LANES) + lu] += w1
                    acc[U(5 * LANES) + lu] += w2
                nfl = 0
                for l in range(LANES):
                    nfl |= flag[l]
                if nfl != 0:  # the rare samples near a texel edge: their texel in float64, as the oracle
                    for l in range(LANES):
                        lu = U(l)
                        if flag[lu] == 0:
                            continue
                        x = x0 + l
                        if mips:  # the whole sample in float64, as the oracle
                            n0, n1, n2, e0, e1, e2 = _sample_f64(x, y, j, np.int64(ln[lu]), np.uint64(lh[lu]),
                                                                 np.uint64(lh[U(LANES) + lu]), ls[lu], src, z, slots,
                                                                 d_mm, chan, sampler, sequence, c, bleed, fx, fy,
                                                                 golden, a1, a2, mip_scale, max_mip, pyr, off, hh, ww,
                                                                 ell_max)
                            acc[lu] += np.float32(n0)
                            acc[U(LANES) + lu] += np.float32(n1)
                            acc[U(2 * LANES) + lu] += np.float32(n2)
                            acc[U(3 * LANES) + lu] += np.float32(e0)
                            acc[U(4 * LANES) + lu] += np.float32(e1)
                            acc[U(5 * LANES) + lu] += np.float32(e2)
                            continue
                        rr, ix, iy = _exact_texel(x, y, j, ln[lu], np.uint64(lh[lu]), np.uint64(lh[U(LANES) + lu]),
                                                  np.float64(lds[lu]),
                                                  fx / np.float64(lz[lu]), fy / np.float64(lz[lu]), c, sampler,
                                                  sequence, golden, a1, a2)
                        if ix < 0 or ix >= w or iy < 0 or iy >= h:
                            continue
                        q = U(iy * w + ix)
                        qs = sf[q]
                        ind = _ONE32 if qs == ls[lu] else (fb if qs > 0 else _ZERO32)
                        if ind == _ZERO32:
                            continue
                        r = np.float32(rr)
                        dz = zf[q] - lz[lu]
                        rp = math.sqrt(r * r + dz * dz)
                        w0, w1, w2, _ = _weights(r, rp, li3[lu], li3[U(LANES) + lu], li3[U(2 * LANES) + lu],
                                                 li3[U(3 * LANES) + lu], lq[lu], lq[U(LANES) + lu],
                                                 lq[U(2 * LANES) + lu])
                        w0 *= ind
                        w1 *= ind
                        w2 *= ind
                        acc[lu] += w0 * srcf[U(3) * q]
                        acc[U(LANES) + lu] += w1 * srcf[U(3) * q + U(1)]
                        acc[U(2 * LANES) + lu] += w2 * srcf[U(3) * q + U(2)]
                        acc[U(3 * LANES) + lu] += w0
                        acc[U(4 * LANES) + lu] += w1
                        acc[U(5 * LANES) + lu] += w2
                if j % CHUNK == CHUNK - 1 or j == nmax - 1:  # float32 sums over at most CHUNK samples
                    for i in range(_L6):
                        tot[i] += np.float64(acc[i])
            for l in range(min(LANES, w - x0)):  # step 8
                lu = U(l)
                x = x0 + l
                for ch in range(3):
                    e = src[y, x, ch]
                    den = tot[U((3 + ch) * LANES) + lu]
                    out[y, x, ch] = np.float32(tot[U(ch * LANES) + lu] / den) if (ln[lu] > 0 and den > 0.0) else e


@njit(cache=True, nogil=True, fastmath=FM32, error_model="numpy")
def burley_rows(src, z, zbits, slots, counts, spp, use_counts, out, y0, y1, d_mm, chan, r997, sampler, sequence,
                c, bleed, fx, fy, base, stable, key2, golden, a1, a2, mips, mip_scale, max_mip, pyr, off, hh, ww,
                ell_max):
    """Steps 1-8 of the plan for rows [y0, y1). src (H, W, 3) float32, z (H, W) float32 (mm),
    zbits (H, W) uint32 (the bits of z, for a stable pattern), slots (H, W) int32, counts (H, W) int64
    (used when use_counts), out (H, W, 3) float32; with ``mips`` the levels >= 1 of step 5b's pyramid
    flattened into pyr (float32; level L at off[L], (S - 1, hh[L], ww[L], 4), slot s at plane s - 1:
    :func:`mip_level1`, :func:`mip_coarse`; level 0 is read from src and slots); ell_max (S,) the slots'
    largest dmfp (mm) of step 5b. The vectorised kernel, one copy per (sampler Eq. 21 or exact, mips)."""
    mp = (mip_scale, max_mip, pyr, off, hh, ww, ell_max)
    if mips:
        if sampler == XIE:
            _vec_rows(src, z, zbits, slots, counts, spp, use_counts, out, y0, y1, d_mm, chan, r997, sampler, sequence,
                      c, bleed, fx, fy, base, stable, key2, golden, a1, a2, True, True, mp)
        else:
            _vec_rows(src, z, zbits, slots, counts, spp, use_counts, out, y0, y1, d_mm, chan, r997, sampler, sequence,
                      c, bleed, fx, fy, base, stable, key2, golden, a1, a2, False, True, mp)
    elif sampler == XIE:
        _vec_rows(src, z, zbits, slots, counts, spp, use_counts, out, y0, y1, d_mm, chan, r997, sampler, sequence,
                  c, bleed, fx, fy, base, stable, key2, golden, a1, a2, True, False, mp)
    else:
        _vec_rows(src, z, zbits, slots, counts, spp, use_counts, out, y0, y1, d_mm, chan, r997, sampler, sequence,
                  c, bleed, fx, fy, base, stable, key2, golden, a1, a2, False, False, mp)


@njit(cache=True)
def _sample_f64(x, y, j, n, h1, h2, s, src, z, slots, d_mm, chan, sampler, sequence, c, bleed, fx, fy, golden, a1,
                a2, mip_scale, max_mip, pyr, off, hh, ww, ell_max):
    """Sample j of pixel (x, y) (slot s > 0, count n, keys h1, h2) with mips, all in float64 as the oracle
    (plan steps 3-7 and 5b): (w_R V_R, w_G V_G, w_B V_B, w_R, w_G, w_B), zeros for a rejected sample. The
    lanes' fallback for a sample near a texel edge or above mip level 0."""
    h, w = slots.shape
    zp = np.float64(z[y, x])
    sx = fx / zp
    sy = fy / zp
    d_s = d_mm[s, chan[s]]
    xi1, xi2 = _uniforms(j, n, h1, h2, sampler, sequence, golden, a1, a2)  # step 3
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
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    ix = np.int64(qx)
    iy = np.int64(qy)
    qs = slots[iy, ix]
    ind = 1.0 if qs == s else (bleed if qs > 0 else 0.0)  # step 6
    if ind == 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    dz = np.float64(z[iy, ix]) - zp
    rp = math.sqrt(r * r + dz * dz)
    b = math.exp(-r / (3.0 * d_s))  # step 7: exp(-r/d) = b^3
    f = ind / (b * b * b + b)
    a = math.exp(-rp / (3.0 * d_mm[s, 0]))
    w0 = f * (d_s / d_mm[s, 0]) * (a * a * a + a)
    a = math.exp(-rp / (3.0 * d_mm[s, 1]))
    w1 = f * (d_s / d_mm[s, 1]) * (a * a * a + a)
    a = math.exp(-rp / (3.0 * d_mm[s, 2]))
    w2 = f * (d_s / d_mm[s, 2]) * (a * a * a + a)
    p_r = (b * b * b + b) / (4.0 * d_s)  # step 5b, Eq. 22 in Xie's units: radial pdf (mm^-1),
    t = (sx / w) * (sy / h)  # t of Eq. 23 (UV^2 per mm^2), ell_max (mm)
    arg = mip_scale * n * p_r / (ell_max[s] * ell_max[s] * t)
    m = 0.5 * max(-math.log2(arg), 0.0) if arg > 0.0 else np.float64(max_mip)
    m = min(m, np.float64(max_mip))
    lo = np.int64(math.floor(m))
    fr = m - lo
    c0 = c1 = c2 = k = 0.0
    if 1.0 - fr > 0.0:
        u0, u1, u2, uk = _bilinear(src, slots, pyr, off, hh, ww, lo, qs, px, py)
        c0, c1, c2, k = (1.0 - fr) * u0, (1.0 - fr) * u1, (1.0 - fr) * u2, (1.0 - fr) * uk
    if fr > 0.0:
        u0, u1, u2, uk = _bilinear(src, slots, pyr, off, hh, ww, lo + 1, qs, px, py)
        c0 += fr * u0
        c1 += fr * u1
        c2 += fr * u2
        k += fr * uk
    return w0 * c0 / k, w1 * c1 / k, w2 * c2 / k, w0, w1, w2
