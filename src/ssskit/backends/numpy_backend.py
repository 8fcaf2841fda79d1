"""The numpy backend: float64, vectorised over pixels, one array operation per tap row and texel.

It is the oracle of the parity tests, written to be read next to :mod:`ssskit.backends.plan`:
every tap sample is a 2D bilinear fetch of its four texels (for an unjittered tap along the x axis
the two texels of the next row have weight 0), each texel with its own depth factor and slot test.

The Burley pass (:meth:`NumpyBackend.burley`) follows the numbered steps of
:mod:`ssskit.backends.burley_plan`, one helper per step, vectorised over the pixels with SSS and
looped over the sample index.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..sampling.hashes import jitter_angles
from ..profiles.burley import burley_inverse_cdf
from ..sampling.hashes import frame_base, mix32
from .adaptive_plan import AdaptivePlan, GuideFrame, reference_counts, reference_update_pass
from .base import Backend
from .burley_plan import GOLDEN32, KEY2, MAX_MIP, R2_A1, R2_A2, BurleyPlan, MipPyramid, SampleCounts, mip_pyramid
from .plan import SeparablePlan, TermTable
from .spread_plan import SpreadPlan
from .transmission_plan import LUT_SIZE, TransmissionPlan, unreal_lut_coordinate


def depth_factor(dz: np.ndarray, mode: str, param: np.ndarray) -> np.ndarray:
    """f(d_z): ``gaussian`` exp(-d_z^2 p) (separable-SSS supplement E, p = 1 / (2 tau_max)),
    ``follow`` max(0, 1 - |d_z| p) (p = 1 / width), ``none`` 1."""
    with np.errstate(invalid="ignore", over="ignore"):
        if mode == "gaussian":
            return np.exp(-dz * dz * param)
        if mode == "follow":
            return np.maximum(0.0, 1.0 - np.abs(dz) * param)
        return np.ones_like(dz)


def one_pass(src: np.ndarray, z_mm: np.ndarray, slots: np.ndarray, f_axis: float, horizontal: bool,
             term: TermTable, plan: SeparablePlan, angles: np.ndarray | None) -> np.ndarray:
    """One 1D pass of one term (plan module docstring); float64 (H, W, 3)."""
    h, w = slots.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    inside = slots > 0
    with np.errstate(divide="ignore"):
        s = np.where(inside, f_axis / np.where(inside, z_mm, 1.0), 0.0)  # pixels per mm
    param = plan.depth_param[slots]
    out = src * term.centre[slots]
    ax, ay = (1.0, 0.0) if horizontal else (0.0, 1.0)  # the pass axis
    ux, uy = ax, ay
    if angles is not None:
        cth, sth = np.cos(angles), np.sin(angles)
        # rotated axes (paper section 6): (cos, sin) horizontally, (-sin, cos) vertically
        ux, uy = (cth, sth) if horizontal else (-sth, cth)
    for k in range(term.max_rows):
        active = inside & (k < term.n_rows[slots])
        if not active.any():
            continue
        reach = term.offsets_mm[slots, k] * s
        jit = k < term.n_jit[slots]
        for side, weights in ((1.0, term.w_plus[slots, k]), (-1.0, term.w_minus[slots, k])):
            d = side * reach
            dx, dy = d * np.where(jit, ux, ax), d * np.where(jit, uy, ay)
            px, py = xx + dx, yy + dy
            i0, j0 = np.floor(px), np.floor(py)
            tx, ty = px - i0, py - j0
            i0, j0 = i0.astype(np.int64), j0.astype(np.int64)
            for di, dj in ((0, 0), (1, 0), (0, 1), (1, 1)):
                b = (tx if di else 1.0 - tx) * (ty if dj else 1.0 - ty)
                ii, jj = i0 + di, j0 + dj
                ic, jc = np.clip(ii, 0, w - 1), np.clip(jj, 0, h - 1)
                valid = active & (b > 0) & (ii == ic) & (jj == jc) & (slots[jc, ic] == slots)
                with np.errstate(invalid="ignore"):
                    f = np.where(valid, depth_factor(z_mm[jc, ic] - z_mm, plan.depth_mode, param), 0.0)
                out += (b * f)[..., None] * weights * (src[jc, ic] - src)
    out[~inside] = src[~inside]
    return out


_M32 = np.uint64(0xFFFFFFFF)


def burley_keys(plan: BurleyPlan, ys: np.ndarray, xs: np.ndarray,
                z_mm: np.ndarray) -> tuple[NDArray[np.uint64], NDArray[np.uint64]]:
    """Step 1: the pixel keys (h1, h2) (uint64 holding 32 bits) of pixels (ys, xs) with depth z_mm."""
    base = np.uint64(frame_base(0 if plan.stable else plan.frame, plan.seed))
    h = mix32(mix32(base ^ ys.astype(np.uint64)) ^ xs.astype(np.uint64))
    if plan.stable:
        h = mix32(h ^ np.asarray(z_mm, np.float32).view(np.uint32).astype(np.uint64))
    return h, mix32(h ^ np.uint64(KEY2))


def _unit(u: np.ndarray) -> np.ndarray:
    """xi = (float(U >> 8) + 0.5) 2^-24 in (0, 1) (step 3)."""
    return ((u >> np.uint64(8)).astype(np.float64) + 0.5) * 2.0**-24


def burley_uniforms(plan: BurleyPlan, h1: np.ndarray, h2: np.ndarray, j: int,
                    n: np.ndarray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Step 3: (xi1, xi2) of sample j for pixels with keys h1, h2 and counts n."""
    jj = np.uint64(j)
    if plan.sampler == "golubev":
        xi1 = (j + 0.5) / n
        u2 = (h2 + jj * np.uint64(GOLDEN32)) & _M32
        return xi1, _unit(u2)
    if plan.sequence == "r2":
        u1 = (h1 + jj * np.uint64(R2_A1)) & _M32
        u2 = (h2 + jj * np.uint64(R2_A2)) & _M32
    else:
        k = np.uint64((j * GOLDEN32) & 0xFFFFFFFF)
        u1, u2 = mix32(h1 ^ k), mix32(h2 ^ k)
    return _unit(u1), _unit(u2)


def burley_radius(plan: BurleyPlan, xi: np.ndarray, d_s: np.ndarray) -> np.ndarray:
    """Step 4: the radius (mm) in the sampling channel: the exact inverse of Xie 2020 Eq. 20, or Eq. 21."""
    if plan.sampler == "xie":
        return d_s * ((2.0 - plan.c) * xi - 2.0) * np.log1p(-xi)  # Eq. 21
    return burley_inverse_cdf(xi, 1.0) * d_s  # Eq. 20 inverted (cdf depends on r / d only)


def burley_weights(r: np.ndarray, r_prime: np.ndarray, d_s: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Step 7 (Xie 2020 Eq. 24): w_c = r' R_c(r') / p(r) without the constant A_c / (2 pi); (N, 3)."""
    pdf = np.exp(-r / d_s) + np.exp(-r / (3.0 * d_s))
    rp = r_prime[:, None]
    return (d_s[:, None] / d) * (np.exp(-rp / d) + np.exp(-rp / (3.0 * d))) / pdf[:, None]


def burley_mip_level(plan: BurleyPlan, r: np.ndarray, d_s: np.ndarray, n: np.ndarray, zp: np.ndarray,
                     slot: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Step 5b (Xie 2020 Eqs. 22-23 in the paper's units): m = min(MAX_MIP, max(-log2(a n p(r) /
    (ell_max^2 t)), 0) / 2) with p(r) the radial pdf (mm^-1), ell_max the slot's largest dmfp (mm) and
    t = (sx / W)(sy / H) (UV^2 per mm^2); ``size`` = (H, W)."""
    h, w = size
    p_r = (np.exp(-r / d_s) + np.exp(-r / (3.0 * d_s))) / (4.0 * d_s)  # Eq. 20's derivative, per mm
    t = (plan.fx / zp / w) * (plan.fy / zp / h)  # Eq. 23: (w/D)^2 x aspect, UV^2 per mm^2
    ell = plan.dmfp_max_mm[slot]
    m = 0.5 * np.maximum(-np.log2(plan.mip_scale * n * p_r / (ell * ell * t)), 0.0)
    return np.minimum(m, float(MAX_MIP))


def burley_mip_fetch(pyr: MipPyramid, slot: np.ndarray, px: np.ndarray, py: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Step 5b: the trilinear, coverage-normalised fetch of each sample's slot pyramid at (px, py) (level-0
    pixels), level m; (N, 3)."""
    lo = np.floor(m).astype(np.int64)
    f = m - lo
    acc = np.zeros((px.size, 4))
    for level in range(MAX_MIP + 1):
        for which, wl in ((lo == level, 1.0 - f), (lo + 1 == level, f)):
            k = np.flatnonzero(which & (wl > 0))
            if k.size == 0:
                continue
            img = pyr[level]
            hh, ww = img.shape[1:3]
            u = px[k] / 2.0**level - 0.5
            v = py[k] / 2.0**level - 0.5
            i0, j0 = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
            tu, tv = u - i0, v - j0
            for di, dj in ((0, 0), (1, 0), (0, 1), (1, 1)):
                b = (tu if di else 1.0 - tu) * (tv if dj else 1.0 - tv) * wl[k]
                ii, jj = i0 + di, j0 + dj
                on = (ii >= 0) & (ii < ww) & (jj >= 0) & (jj < hh)
                val = img[slot[k], np.clip(jj, 0, hh - 1), np.clip(ii, 0, ww - 1)]
                acc[k] += np.where(on, b, 0.0)[:, None] * val
    return acc[:, :3] / acc[:, 3:4]


def burley_counts(plan: BurleyPlan, spp: SampleCounts, ys: np.ndarray, xs: np.ndarray, sx: np.ndarray, sy: np.ndarray,
                  slot: np.ndarray) -> np.ndarray:
    """Step 2: samples of each pixel (golubev: capped by pi r997^2 sx sy / 4, at least 1)."""
    n = np.full(ys.shape, spp, np.int64) if np.isscalar(spp) else np.asarray(spp, np.int64)[ys, xs]
    if plan.sampler == "golubev":
        r = plan.r997_mm[slot]
        cap = np.floor(np.pi * r * r * sx * sy / 4.0).astype(np.int64)
        n = np.where(n > 0, np.maximum(1, np.minimum(n, cap)), 0)
    return n


def burley_pass(plan: BurleyPlan, src: np.ndarray, z: np.ndarray, slots: np.ndarray, spp: SampleCounts,
                pyramid: MipPyramid | None = None) -> np.ndarray:
    """The Burley pass in float64 (:mod:`ssskit.backends.burley_plan`, steps 1-8); ``pyramid``: the
    frame's :func:`mip_pyramid` if already built."""
    h, w = slots.shape
    out = src.copy()
    ys, xs = np.nonzero(slots > 0)
    if ys.size == 0:
        return out
    slot = slots[ys, xs]
    zp = z[ys, xs]
    sx, sy = plan.fx / zp, plan.fy / zp  # pixels per mm (step 5)
    h1, h2 = burley_keys(plan, ys, xs, zp)
    n = burley_counts(plan, spp, ys, xs, sx, sy, slot)
    d = plan.d_mm[slot]  # (N, 3)
    d_s = plan.d_sample[slot]
    pyr = (mip_pyramid(src, slots, plan.slots) if pyramid is None else pyramid) if plan.mips else None
    num = np.zeros((ys.size, 3))
    den = np.zeros((ys.size, 3))
    for j in range(int(n.max(initial=0))):
        k = np.flatnonzero(n > j)  # the pixels that draw sample j
        xi1, xi2 = burley_uniforms(plan, h1[k], h2[k], j, n[k])
        r = burley_radius(plan, xi1, d_s[k])
        phi = 2.0 * np.pi * xi2
        px = xs[k] + 0.5 + r * np.cos(phi) * sx[k]  # step 5
        py = ys[k] + 0.5 + r * np.sin(phi) * sy[k]
        qx, qy = np.floor(px).astype(np.int64), np.floor(py).astype(np.int64)
        on = (qx >= 0) & (qx < w) & (qy >= 0) & (qy < h)
        qx, qy = np.clip(qx, 0, w - 1), np.clip(qy, 0, h - 1)
        qs = np.where(on, slots[qy, qx], 0)
        ind = np.where(qs == slot[k], 1.0, np.where(qs > 0, plan.bleed, 0.0))  # step 6
        dz = np.where(ind > 0, z[qy, qx] - zp[k], 0.0)
        wgt = ind[:, None] * burley_weights(r, np.sqrt(r * r + dz * dz), d_s[k], d[k])  # step 7
        if pyr is None:
            value = src[qy, qx]  # nearest texel
        else:
            value = np.zeros((k.size, 3))
            hit = ind > 0
            level = burley_mip_level(plan, r[hit], d_s[k][hit], n[k][hit], zp[k][hit], slot[k][hit], (h, w))
            value[hit] = burley_mip_fetch(pyr, qs[hit], px[hit], py[hit], level)
        num[k] += wgt * value
        den[k] += wgt
    ok = den > 0
    out[ys, xs] = np.where(ok, num / np.where(ok, den, 1.0), src[ys, xs])  # step 8
    return out


class NumpyBackend(Backend):
    name = "numpy"
    description = "numpy, float64: the reference every other backend is tested against (slow)"
    dtype = np.float64
    passes = frozenset({"separable", "burley", "adaptive", "transmission", "spread"})

    def availability(self) -> tuple[bool, str]:
        return True, "float64 reference (the oracle)"

    def _separable(self, plan: SeparablePlan, diffuse: np.ndarray, depth_mm: np.ndarray,
                   slots: np.ndarray) -> NDArray[np.float64]:
        src = np.asarray(diffuse, dtype=np.float64)
        z = np.asarray(depth_mm, dtype=np.float64)
        slots = np.asarray(slots, dtype=np.int64)
        h, w = slots.shape
        angles = jitter_angles(h, w, plan.frame, plan.seed) if plan.jittered else None
        out = np.zeros_like(src)
        for term in plan.terms:
            tmp = one_pass(src, z, slots, plan.fx, True, term, plan, angles)
            out += term.sign[slots] * one_pass(tmp, z, slots, plan.fy, False, term, plan, angles)
        inside = (slots > 0)[..., None]
        return np.where(inside, out, src)

    def _transmission(self, plan: TransmissionPlan, slots: np.ndarray, light_uvz: np.ndarray, shadow_mm: np.ndarray,
                      n_dot_l: np.ndarray, light_rgb: np.ndarray) -> np.ndarray:
        return transmission_pass(plan, slots, light_uvz, shadow_mm, n_dot_l, light_rgb)

    def _transmission_spread(self, plan: SpreadPlan, exitance: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
                             light_uvz: np.ndarray, shadow_mm: np.ndarray) -> NDArray[np.float64]:
        return spread_pass(plan, exitance, depth_mm, slots, light_uvz, shadow_mm)

    def _burley(self, plan: BurleyPlan, diffuse: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
                spp: NDArray[np.int64] | int, pyramid: MipPyramid | None) -> np.ndarray:
        return burley_pass(plan, np.asarray(diffuse, dtype=np.float64), np.asarray(depth_mm, dtype=np.float64),
                           np.asarray(slots, dtype=np.int64), spp, pyramid)

    def _adaptive_counts(self, plan: AdaptivePlan, frame: GuideFrame) -> NDArray[np.int64]:
        """The *estimate* of :mod:`ssskit.backends.adaptive_plan` (its reference functions)."""
        return reference_counts(plan, frame)

    def _adaptive_update(self, plan: AdaptivePlan, frame: GuideFrame) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        """The *update* of :mod:`ssskit.backends.adaptive_plan` (its reference functions)."""
        return reference_update_pass(plan, frame)


def shadow_depth(shadow_mm: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Step 1 of :mod:`ssskit.backends.transmission_plan`: the map's bilinear depth at texel coordinates
    (x, y) over its finite texels (weights renormalised); NaN where no texel with positive weight is left."""
    hs, ws = shadow_mm.shape
    px, py = x - 0.5, y - 0.5
    with np.errstate(invalid="ignore"):
        i0, j0 = np.floor(px), np.floor(py)
    fx, fy = px - i0, py - j0
    acc = np.zeros(x.shape)
    wsum = np.zeros(x.shape)
    finite = np.isfinite(px) & np.isfinite(py)
    i0 = np.where(finite, i0, -2).astype(np.int64)
    j0 = np.where(finite, j0, -2).astype(np.int64)
    for di, dj in ((0, 0), (1, 0), (0, 1), (1, 1)):
        wgt = (fx if di else 1.0 - fx) * (fy if dj else 1.0 - fy)
        ii, jj = i0 + di, j0 + dj
        inside = (ii >= 0) & (ii < ws) & (jj >= 0) & (jj < hs)
        d = shadow_mm[np.clip(jj, 0, hs - 1), np.clip(ii, 0, ws - 1)]
        ok = inside & np.isfinite(d) & (wgt > 0) & finite
        acc += np.where(ok, wgt * np.where(ok, d, 0.0), 0.0)
        wsum += np.where(ok, wgt, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(wsum > 0, acc / wsum, np.nan)


def transmission_pass(plan: TransmissionPlan, slots: np.ndarray, light_uvz: np.ndarray, shadow_mm: np.ndarray,
                      n_dot_l: np.ndarray, light_rgb: np.ndarray) -> NDArray[np.float64]:
    """Steps 1-5 of :mod:`ssskit.backends.transmission_plan` in float64, vectorised over the pixels."""
    uvz = np.asarray(light_uvz, np.float64)
    out = np.zeros(uvz.shape[:2] + (3,))
    ys, xs = np.nonzero(np.asarray(slots) > 0)
    if ys.size == 0:
        return out
    s = np.asarray(slots)[ys, xs]
    d = shadow_depth(np.asarray(shadow_mm, np.float64), uvz[ys, xs, 0], uvz[ys, xs, 1])  # step 1
    with np.errstate(invalid="ignore"):
        t = uvz[ys, xs, 2] - d  # step 2
        lit = np.isfinite(t) & (t > plan.bias_mm)
    t = np.where(lit, t, 0.0)
    ndl = np.asarray(n_dot_l, np.float64)[ys, xs]
    t = np.where(plan.normal[s] > 0, t * np.clip(-ndl, 0.0, 1.0), t)  # step 2: along the surface normal
    e = np.asarray(light_rgb, np.float64)[ys, xs] * np.clip(plan.wrap[s] - ndl, 0.0, 1.0)[:, None]  # step 3
    u = (plan.scale[s] * t)[:, None, None]
    tr = np.sum(plan.a[s] * np.exp(-plan.b[s] * u - plan.c[s] * u * u), axis=-1)  # step 4
    if plan.has_lut:  # step 4 of the unreal slots: UE's optical depth into the profile table
        q = plan.lut_slot[s]
        sq = s[q]
        x = unreal_lut_coordinate(plan.od_per_mm[sq] * t[q] + plan.od_offset[sq])
        i = np.minimum(np.floor(x), LUT_SIZE - 2).astype(np.int64)
        f = (x - i)[:, None]
        tr[q] = (1.0 - f) * plan.lut[sq, :, i] + f * plan.lut[sq, :, i + 1]
    out[ys, xs] = np.where(lit[:, None], tr * e, 0.0)  # step 5
    return out


def spread_sigma(plan: SpreadPlan, slots: np.ndarray, light_uvz: np.ndarray,
                 shadow_mm: np.ndarray) -> NDArray[np.float64]:
    """Steps 0-1 of :mod:`ssskit.backends.spread_plan`: (H, W, 3) sigma (mm) of every pixel in a slot, 0
    elsewhere."""
    sl = np.asarray(slots)
    uvz = np.asarray(light_uvz, np.float64)
    out = np.zeros(sl.shape + (3,))
    ys, xs = np.nonzero(sl > 0)
    if ys.size == 0:
        return out
    with np.errstate(invalid="ignore"):
        t = uvz[ys, xs, 2] - shadow_depth(np.asarray(shadow_mm, np.float64), uvz[ys, xs, 0], uvz[ys, xs, 1])
        t = np.where(np.isfinite(t) & (t > plan.bias_mm), t, 0.0)
    s = sl[ys, xs]
    for slot in np.unique(s):
        m = s == slot
        out[ys[m], xs[m]] = plan.sigma(int(slot), t[m])
    return out


def spread_axis(plan: SpreadPlan, v: np.ndarray, depth: np.ndarray, slots: np.ndarray, sigma: np.ndarray,
                horizontal: bool) -> NDArray[np.float64]:
    """Step 2 of :mod:`ssskit.backends.spread_plan` along one axis, float64."""
    h, w = slots.shape
    out = np.array(v, np.float64, copy=True)
    ys, xs = np.nonzero(slots > 0)
    if ys.size == 0:
        return out
    z = depth[ys, xs].astype(np.float64)
    sig = sigma[ys, xs]  # (N, 3) mm
    f = plan.fx if horizontal else plan.fy
    spx = sig * (f / z)[:, None]
    m = spx.max(axis=1)
    act = m >= plan.min_px
    ys, xs, z, sig, spx, m = ys[act], xs[act], z[act], sig[act], spx[act], m[act]
    if ys.size == 0:
        return out
    step = np.maximum(1, np.ceil(3.0 * m / plan.max_taps)).astype(np.int64)
    k = np.ceil(3.0 * m / step).astype(np.int64)
    s = slots[ys, xs]
    vp = np.asarray(v, np.float64)[ys, xs]
    acc = np.zeros_like(spx)
    for j in range(-int(k.max()), int(k.max()) + 1):
        if j == 0:
            continue
        d = j * step
        qy, qx = (ys, xs + d) if horizontal else (ys + d, xs)
        ok = (np.abs(j) <= k) & (qx >= 0) & (qx < w) & (qy >= 0) & (qy < h)
        qyc, qxc = np.clip(qy, 0, h - 1), np.clip(qx, 0, w - 1)
        ok &= slots[qyc, qxc] == s
        zq = depth[qyc, qxc].astype(np.float64)
        sq = sigma[qyc, qxc]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            pair_px = np.sqrt(spx * sq * (f / zq)[:, None])  # S_c
            pair_mm = np.sqrt(sig * sq)  # s_c
            dz = zq - z
            wgt = (step[:, None] * np.exp(-(d.astype(np.float64) ** 2)[:, None] / (2.0 * pair_px ** 2))
                   / (math.sqrt(2.0 * math.pi) * pair_px) * np.exp(-(dz * dz)[:, None] / (2.0 * pair_mm ** 2)))
        wgt = np.where((pair_px > 0) & (np.abs(d)[:, None] <= 3.0 * pair_px), wgt, 0.0)
        vq = np.asarray(v, np.float64)[qyc, qxc]
        acc += np.where(ok[:, None], wgt * (vq - vp), 0.0)
    out[ys, xs] = vp + acc
    return out


def spread_pass(plan: SpreadPlan, exitance: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
                light_uvz: np.ndarray, shadow_mm: np.ndarray) -> NDArray[np.float64]:
    """The float64 oracle of the transmitted light's lateral spread (:mod:`ssskit.backends.spread_plan`): steps 0-1,
    the horizontal pass, then the vertical one on its result, vectorised over the pixels."""
    sl = np.asarray(slots)
    depth = np.asarray(depth_mm, np.float64)
    sigma = spread_sigma(plan, sl, light_uvz, shadow_mm)
    tmp = spread_axis(plan, np.asarray(exitance, np.float64), depth, sl, sigma, True)
    return spread_axis(plan, tmp, depth, sl, sigma, False)
