"""The MCML photon transport in numba (Wang, Jacques, Zheng 1995, "MCML -- Monte Carlo modeling of
light transport in multi-layered tissues"; names in parentheses are the MCML 1.2.2 routines each
rule follows).

This module compiles on first use (cached on disk by numba, ``cache=True``); import it only when
simulating. :func:`ssskit.profiles.montecarlo.simulate` drives it; its inputs are the arrays of
:func:`ssskit.profiles.montecarlo.config.layer_arrays`. The numpy twin
(:mod:`ssskit.profiles.montecarlo.engine_numpy`) follows the same rules and shares the constants below.

Per photon (MCML 1.2.2 semantics):
* launch at the origin along +z (or, for an oblique beam, along the refracted direction (ux0, 0, uz0))
  with weight 1 - Rsp (MCML's LaunchPhoton / Rspecular; Rsp is reported separately);
* step s = -ln(xi) / mu_t, or the optical depth left over from a boundary hit (StepSizeInTissue, HitBoundary);
* a step that crosses a boundary stops on it, keeps the unused optical depth, and the photon is
  reflected (total internal reflection, or with probability R(theta_i), the unpolarised Fresnel
  reflectance) or transmitted, all-or-none (CrossUpOrNot / CrossDnOrNot, RFresnel); a photon escaping
  through the top (reflected) or the bottom (transmitted) scores its whole weight at its exit radius (the
  last radial bin collects every radius beyond the grid; MCML's RecordR / RecordT into Rd_r and Tt_r) and in
  the bin of its exit direction (:data:`N_EXIT_BINS` bins uniform in cos^2 of the angle to the normal
  outside the medium, i.e. of equal projected solid angle; MCML's Rd_a and Tt_a with other bins);
* otherwise implicit capture: deposit w mu_a / mu_t, keep the rest (Drop); Henyey-Greenstein
  scattering, the isotropic case exact (SpinTheta, Spin);
* Russian roulette below weight 1e-4 with survival chance 0.1 (Roulette).

A rough top surface (``alpha`` > 0, not in MCML): the surface between the ambient medium above and
the top layer, crossed at launch and at every escape attempt, is a single-scattering microfacet
dielectric with Beckmann roughness alpha, the BSDF of Mitsuba 3's ``roughdielectric`` (Walter, Marschner,
Li, Torrance 2007, "Microfacet models for refraction through rough surfaces"): :func:`_rough_interface`.
The launch then starts from the beam's direction outside the medium with weight 1 and the light that
the surface reflects at entry ends there (its share is the separately estimated Rsp,
:func:`rough_interface_albedo`); the other boundaries stay smooth.

Speed: the photons of a batch are traced LANES = 8 at a time. One branch-free lane loop takes every
lane's next step inside its layer (step length, hop, implicit capture, Henyey-Greenstein scattering) in
float32, with the vectorisable exp/log/sincos of :mod:`ssskit.compute.numba_math`, so LLVM compiles
it to 8-wide AVX2 code; the direction is renormalised after each scattering (one Newton step), so
float32 roundings do not build up over the thousands of steps of a high-albedo photon. Lanes whose
step meets a boundary or whose weight fell below the roulette threshold are then handled one by one in
float64 with MCML's rules (HitBoundary, CrossUpOrNot / CrossDnOrNot, RFresnel, Roulette, the scoring),
and a lane whose photon ended takes the batch's next photon. Tallies are float64.

Randomness: every lane of a batch owns an xoshiro128+ stream (Blackman and Vigna 2018, "Scrambled
linear pseudorandom number generators"; the top 24 bits of each 32-bit output make a uniform) seeded
by splitmix64 from (seed, batch index, lane), so a batch's result depends on nothing but those
numbers: the same seed gives bit-identical tallies for any number of threads, and batches can be
resumed. The specular-entry estimate of a rough surface (:func:`rough_interface_albedo`) draws from
one xoroshiro128+ stream.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numba import njit
from numpy.typing import NDArray

from ...compute.workers import submit_all
from ...compute.numba_math import FM32, log_f32, sincos_u24, stack_empty, u24_f32, xoshiro128p
from .config import N_EXIT_BINS

WEIGHT_THRESHOLD = 1e-4  # MCML's Wth
ROULETTE_CHANCE = 0.1  # MCML's CHANCE
COS_ZERO = 1.0 - 1.0e-12  # MCML's COSZERO
COS_90D = 1.0e-6  # MCML's COS90D

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_TWO53 = 1.0 / 9007199254740992.0


@njit(cache=True)
def _splitmix64(x):
    z = x + _GOLDEN
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


@njit(cache=True)
def _rotl(x, k):
    return (x << np.uint64(k)) | (x >> np.uint64(64 - k))


@njit(cache=True)
def _next(state):
    """xoroshiro128+ step; returns 53 random bits as an integer-valued float in [0, 2^53)."""
    s0 = state[0]
    s1 = state[1]
    result = s0 + s1
    s1 ^= s0
    state[0] = _rotl(s0, 24) ^ s1 ^ (s1 << np.uint64(16))
    state[1] = _rotl(s1, 37)
    return float(result >> np.uint64(11))


@njit(cache=True)
def _uniform(state):
    """Uniform in [0, 1)."""
    return _next(state) * _TWO53


@njit(cache=True)
def _uniform_open0(state):
    """Uniform in (0, 1], safe for -log."""
    return (_next(state) + 1.0) * _TWO53


@njit(cache=True)
def _fresnel(n1, n2, ca1):
    """Unpolarised Fresnel reflectance and transmitted cosine, MCML's RFresnel."""
    if n1 == n2:
        return 0.0, ca1
    if ca1 > COS_ZERO:
        r = (n2 - n1) / (n2 + n1)
        return r * r, ca1
    if ca1 < COS_90D:
        return 1.0, 0.0
    sa1 = math.sqrt(1.0 - ca1 * ca1)
    sa2 = n1 * sa1 / n2
    if sa2 >= 1.0:
        return 1.0, 0.0
    ca2 = math.sqrt(1.0 - sa2 * sa2)
    cap = ca1 * ca2 - sa1 * sa2  # cos(a1 + a2)
    cam = ca1 * ca2 + sa1 * sa2  # cos(a1 - a2)
    sap = sa1 * ca2 + ca1 * sa2  # sin(a1 + a2)
    sam = sa1 * ca2 - ca1 * sa2  # sin(a1 - a2)
    r = 0.5 * sam * sam * (cam * cam + cap * cap) / (sap * sap * cam * cam)
    return r, ca2


@njit(cache=True)
def _beckmann_g1(vx, vy, vz, v_dot_m, v_dot_n, alpha):
    """Smith's masking function G1(v, m) of Beckmann microfacets by Walter et al. 2007's rational
    approximation (Eq. 27, the form Mitsuba 3's MicrofacetDistribution::smith_g1 evaluates), with the
    orientation factor chi+((v.m) / (v.n)) of Eq. 7: 0 when v sees the back of m. The normal is +-z."""
    if v_dot_m * v_dot_n <= 0.0:
        return 0.0
    xy = vx * vx + vy * vy
    if xy == 0.0:
        return 1.0
    a = abs(vz) / (alpha * math.sqrt(xy))  # 1 / (alpha tan theta_v)
    if a >= 1.6:
        return 1.0
    return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)


@njit(cache=True)
def _rough_interface_u(ux, uy, uz, n1, n2, alpha, u_slope, u_phi, u_choice):
    """One photon meeting a rough dielectric surface z = const (uz != 0, towards it, from the side of
    index n1; n2 beyond). Walter et al. 2007: a microfacet normal m drawn from D(m) |m.n| (Beckmann,
    Eqs. 28-29: tan^2 theta_m = -alpha^2 ln(xi)), reflection about m with the probability of the
    Fresnel reflectance F(i.m) (dielectric, total internal reflection included), refraction through
    m otherwise (Eq. 40), and the photon's weight multiplied by the sample weight of Eq. 41,
    |i.m| G1(i, m) G1(o, m) / (|i.n| |m.n|). Its expectation is the BSDF's directional albedo, below 1
    at grazing angles: the single-scattering model loses the light its masking removes.

    Returns (weight factor, ux, uy, uz of the new direction, transmitted); the factor is 0 where
    the sample is invalid (m seen from behind, or the new direction on the wrong side). The three
    uniforms (in (0, 1]) draw the slope, the azimuth and the choice between reflection and refraction.
    """
    sn = -1.0 if uz > 0.0 else 1.0  # n = (0, 0, sn): the surface normal on the incident side
    ix, iy, iz = -ux, -uy, -uz  # i: from the surface back along the photon's path
    i_n = sn * iz
    t2 = -alpha * alpha * math.log(u_slope)
    cm = 1.0 / math.sqrt(1.0 + t2)
    sm = math.sqrt(t2) * cm
    phi = 2.0 * math.pi * u_phi
    mx = sm * math.cos(phi)
    my = sm * math.sin(phi)
    mz = sn * cm
    c = ix * mx + iy * my + iz * mz
    if c <= 0.0:
        return 0.0, ux, uy, uz, False
    r, ct = _fresnel(n1, n2, c)
    if u_choice < r:
        ox = 2.0 * c * mx - ix
        oy = 2.0 * c * my - iy
        oz = 2.0 * c * mz - iz
        o_m = c
        transmitted = False
        if sn * oz <= 0.0:
            return 0.0, ux, uy, uz, False
    else:
        eta = n1 / n2
        k = eta * c - ct
        ox = -eta * ix + k * mx
        oy = -eta * iy + k * my
        oz = -eta * iz + k * mz
        o_m = -ct
        transmitted = True
        if sn * oz >= 0.0:
            return 0.0, ux, uy, uz, False
    norm = math.sqrt(ox * ox + oy * oy + oz * oz)
    ox /= norm
    oy /= norm
    oz /= norm
    g = _beckmann_g1(ix, iy, iz, c, i_n, alpha) * _beckmann_g1(ox, oy, oz, o_m, sn * oz, alpha)
    return c * g / (i_n * cm), ox, oy, oz, transmitted


@njit(cache=True)
def _rough_interface(ux, uy, uz, n1, n2, alpha, state):
    """:func:`_rough_interface_u` with its uniforms from an xoroshiro128+ stream."""
    u_slope = _uniform_open0(state)
    u_phi = _uniform(state)
    return _rough_interface_u(ux, uy, uz, n1, n2, alpha, u_slope, u_phi, _uniform(state))


@njit(cache=True)
def rough_interface_albedo(cos_theta: float, n1: float, n2: float, alpha: float, n_samples: int,
                           seed: int) -> NDArray[np.float64]:
    """Monte Carlo estimate of a rough dielectric surface's directional albedo for light arriving
    at ``cos_theta`` from the side of index n1 (:func:`_rough_interface`, ``n_samples`` samples of
    the stream ``seed``): array [reflected, transmitted, lost, SE of each]. Lost = 1 - reflected -
    transmitted, the energy the single-scattering BSDF does not return."""
    state = np.empty(2, dtype=np.uint64)
    state[0] = _splitmix64(np.uint64(seed) ^ _MIX2)
    state[1] = _splitmix64(state[0] ^ _MIX1)
    sin_theta = math.sqrt(max(1.0 - cos_theta * cos_theta, 0.0))
    acc = np.zeros(3)
    acc2 = np.zeros(3)
    for _ in range(n_samples):
        f, _ux, _uy, _uz, tr = _rough_interface(sin_theta, 0.0, cos_theta, n1, n2, alpha, state)
        k = 1 if tr else 0
        lost = 1.0 - f
        acc[k] += f
        acc2[k] += f * f
        acc[2] += lost
        acc2[2] += lost * lost
    out = np.empty(6)
    for k in range(3):
        mean = acc[k] / n_samples
        out[k] = mean
        out[3 + k] = math.sqrt(max(acc2[k] / n_samples - mean * mean, 0.0) / max(n_samples - 1, 1))
    return out


@njit(cache=True)
def _score_exit(x, y, w, cos_out, dr, bins, totals, exit0):
    """Score a photon of weight w escaping at (x, y) with exit cosine cos_out outside: its radial
    bin in ``bins`` (the last one collects every radius beyond the grid; MCML's RecordR / RecordT) and
    its exit-direction bin, totals[exit0 + k] (exit0 = 3: reflected, 3 + N_EXIT_BINS: transmitted);
    returns w."""
    nr = bins.shape[0]
    ir = int(math.sqrt(x * x + y * y) / dr)
    if ir > nr - 1:
        ir = nr - 1
    bins[ir] += w
    ia = int(cos_out * cos_out * N_EXIT_BINS)
    if ia > N_EXIT_BINS - 1:
        ia = N_EXIT_BINS - 1
    totals[exit0 + ia] += w
    return w


#: photons traced side by side (8 float32 lanes of an AVX2 register)
LANES = 8
_L2, _L3, _L4, _L5 = 2 * LANES, 3 * LANES, 4 * LANES, 5 * LANES
_F32 = np.float32
_ONE = _F32(1.0)
_ZERO = _F32(0.0)
_HALF = _F32(0.5)
_TWO = _F32(2.0)
_THREE_HALVES = _F32(1.5)
_U24 = _F32(2.0**-24)
_WTH32 = _F32(WEIGHT_THRESHOLD)
#: float32 twin of COS_ZERO for the vectorised scattering: |uz| above it spins about the z axis (a direction
#: within 1.4e-3 rad of the axis, one scattering in ~10^6)
_COS_ZERO32 = _F32(1.0 - 2.0**-20)
_INF32 = _F32(np.inf)


@njit(cache=True)
def _lane_uniform(rs, lu):
    """A uniform in (0, 1) from lane lu's xoshiro128+ stream (scalar use: boundaries, roulette, launch)."""
    U = np.uintp
    out, a, b, c, d = xoshiro128p(rs[lu], rs[U(LANES) + lu], rs[U(_L2) + lu], rs[U(_L3) + lu])
    rs[lu] = a
    rs[U(LANES) + lu] = b
    rs[U(_L2) + lu] = c
    rs[U(_L3) + lu] = d
    return (float(u24_f32(out)) + 0.5) * (1.0 / 16777216.0)


@njit(cache=True)
def _set_layer(lu, layer, mua, mus, g, z_top, z_bot, lf):
    """Lane lu's copy of layer ``layer``'s coefficients in the lane table lf (1/mu_t, mu_a/mu_t, g, z_top,
    z_bot as float32 rows of LANES)."""
    U = np.uintp
    mut = mua[layer] + mus[layer]
    lf[lu] = _F32(1.0 / mut)
    lf[U(LANES) + lu] = _F32(mua[layer] / mut)
    lf[U(_L2) + lu] = _F32(g[layer])
    lf[U(_L3) + lu] = _F32(z_top[layer])
    lf[U(_L4) + lu] = _F32(z_bot[layer])


@njit(cache=True, nogil=True, fastmath=FM32, error_model="numpy")
def _run_batch(seed, batch, n_photons, mua, mus, g, z_top, z_bot, n_idx, cos_crit_up, cos_crit_down,
               rsp, ux0, uz0, dr, alpha, rd_bins, tt_bins, totals):
    """Simulate ``n_photons`` photons of stream (seed, batch); add tallies into rd_bins / tt_bins / totals.

    Layers are 1..L in the arrays ``mua``, ``mus``, ``g``, ``z_top``, ``z_bot`` (index 0 and L + 1
    unused); ``n_idx[0]`` is the ambient index above, ``n_idx[L + 1]`` the one below. ``alpha`` > 0:
    the top surface is rough (module docstring); (ux0, 0, uz0) is then the beam outside the medium.
    rd_bins / tt_bins: the diffusely reflected / transmitted weight per radial bin of the exit point
    (MCML's Rd_r and Tt_r; the last bin collects every radius beyond the grid). totals: [diffuse
    reflectance, transmittance, absorbed] weight sums, then the reflected and then the transmitted weight
    per exit-direction bin (:data:`N_EXIT_BINS` bins each, uniform in cos^2 theta outside; MCML's Rd_a and
    Tt_a with other bins).

    LANES photons are traced side by side (module docstring): one branch-free float32 lane loop takes
    every lane's next step inside its layer (the step length, the hop, the absorption, the scattering),
    which LLVM vectorises; the lanes whose step meets a boundary or whose weight falls below the roulette
    threshold are then handled one by one in float64 (MCML's boundary, roulette and scoring rules), and a
    lane whose photon ended takes the next photon of the batch.
    """
    U = np.uintp
    n_layers = mua.shape[0] - 2
    px = stack_empty(LANES, np.float32)  # photon state per lane
    py = stack_empty(LANES, np.float32)
    pz = stack_empty(LANES, np.float32)
    dx = stack_empty(LANES, np.float32)
    dy = stack_empty(LANES, np.float32)
    dz = stack_empty(LANES, np.float32)
    pw = stack_empty(LANES, np.float32)
    sl = stack_empty(LANES, np.float32)  # optical depth left over from a boundary (0: draw a new step)
    st = stack_empty(LANES, np.float32)  # the step drawn (mm), for the boundary handler
    ab = stack_empty(LANES, np.float32)  # weight absorbed by the lane's photon so far
    lf = stack_empty(_L5, np.float32)  # the lane's layer: 1/mu_t, mu_a/mu_t, g, z_top, z_bot
    ly = stack_empty(LANES, np.int32)  # layer index
    al = stack_empty(LANES, np.int32)  # 1: a photon is in flight
    fl = stack_empty(LANES, np.int32)  # 1: needs the scalar handler (boundary or roulette)
    rs = stack_empty(_L4, np.uint32)  # xoshiro128+ state per lane
    key = _splitmix64(np.uint64(seed) * _MIX1 + np.uint64(batch))
    for l in range(LANES):
        a = _splitmix64(key ^ (np.uint64(l) * _GOLDEN))
        b = _splitmix64(a ^ _MIX2)
        if a == 0 and b == 0:
            b = np.uint64(1)
        rs[l] = np.uint32(a & np.uint64(0xFFFFFFFF))
        rs[LANES + l] = np.uint32(a >> np.uint64(32))
        rs[_L2 + l] = np.uint32(b & np.uint64(0xFFFFFFFF))
        rs[_L3 + l] = np.uint32(b >> np.uint64(32))
        al[l] = 0
        fl[l] = 0
        ab[l] = _ZERO
    rd_sum = 0.0
    tt_sum = 0.0
    abs_sum = 0.0
    launched = 0
    n_alive = 0
    for l in range(LANES):  # the first photons
        while launched < n_photons and al[l] == 0:
            launched += 1
            if _launch(U(l), ux0, uz0, rsp, alpha, n_idx, mua, mus, g, z_top, z_bot, px, py, pz, dx, dy, dz, pw,
                       sl, ly, lf, rs):
                al[l] = 1
                n_alive += 1
    while n_alive > 0:
        for l in range(LANES):  # one step of every lane inside its layer: vectorised, no branches
            lu = U(l)
            live = al[lu] != 0
            o1, a, b, c, d = xoshiro128p(rs[lu], rs[U(LANES) + lu], rs[U(_L2) + lu], rs[U(_L3) + lu])
            o2, a, b, c, d = xoshiro128p(a, b, c, d)
            o3, a, b, c, d = xoshiro128p(a, b, c, d)
            rs[lu] = a
            rs[U(LANES) + lu] = b
            rs[U(_L2) + lu] = c
            rs[U(_L3) + lu] = d
            u1 = (u24_f32(o1) + _HALF) * _U24
            u2 = (u24_f32(o2) + _HALF) * _U24
            imut = lf[lu]
            left = sl[lu]
            s = (left if left > _ZERO else -log_f32(u1)) * imut  # StepSizeInTissue
            x = px[lu]
            y = py[lu]
            z = pz[lu]
            ux = dx[lu]
            uy = dy[lu]
            uz = dz[lu]
            w = pw[lu]
            zb = lf[U(_L4) + lu] if uz > _ZERO else lf[U(_L3) + lu]
            db = (zb - z) / uz if uz != _ZERO else _INF32
            hit = s > db  # HitBoundary
            dwa = w * lf[U(LANES) + lu]  # Drop (implicit capture)
            nw = w - dwa
            gg = lf[U(_L2) + lu]  # SpinTheta: Henyey-Greenstein, the isotropic case exact
            tmp = (_ONE - gg * gg) / (_ONE - gg + _TWO * gg * u2)
            hg = (_ONE + gg * gg - tmp * tmp) / (_TWO * gg)
            hg = min(max(hg, -_ONE), _ONE)
            cost = _TWO * u2 - _ONE if gg == _ZERO else hg
            sint = math.sqrt(max(_ONE - cost * cost, _ZERO))
            cosp, sinp = sincos_u24(u24_f32(o3))
            ax = abs(uz) > _COS_ZERO32  # Spin
            den = math.sqrt(max(_ONE - uz * uz, _ZERO))
            inv = _ONE / den if not ax else _ONE
            nux = sint * (ux * uz * cosp - uy * sinp) * inv + ux * cost
            nuy = sint * (uy * uz * cosp + ux * sinp) * inv + uy * cost
            nuz = -sint * cosp * den + uz * cost
            nux = sint * cosp if ax else nux
            nuy = sint * sinp if ax else nuy
            nuz = (cost if uz >= _ZERO else -cost) if ax else nuz
            n2 = nux * nux + nuy * nuy + nuz * nuz  # renormalise: float32 roundings must not build up over
            rn = _THREE_HALVES - _HALF * n2  # thousands of steps (one Newton step of 1/sqrt from 1)
            nux *= rn
            nuy *= rn
            nuz *= rn
            move = live & (not hit)
            st[lu] = s
            sl[lu] = _ZERO if move else left
            px[lu] = x + s * ux if move else x
            py[lu] = y + s * uy if move else y
            pz[lu] = z + s * uz if move else z
            dx[lu] = nux if move else ux
            dy[lu] = nuy if move else uy
            dz[lu] = nuz if move else uz
            pw[lu] = nw if move else w
            ab[lu] = ab[lu] + dwa if move else ab[lu]
            fl[lu] = np.int32(2) if live & hit else (np.int32(1) if move & (nw < _WTH32) else np.int32(0))
        any_flag = 0
        for l in range(LANES):
            any_flag |= fl[l]
        if any_flag == 0:
            continue
        for l in range(LANES):  # boundaries, roulette, scoring and new photons: one lane at a time
            lu = U(l)
            kind = fl[lu]  # 2: the step meets a boundary (the photon has not moved); 1: roulette
            if kind == 0:
                continue
            fl[lu] = 0
            x = float(px[lu])
            y = float(py[lu])
            z = float(pz[lu])
            ux = float(dx[lu])
            uy = float(dy[lu])
            uz = float(dz[lu])
            w = float(pw[lu])
            layer = int(ly[lu])
            alive = True
            if kind == 2:
                s = float(st[lu])
                zt = z_top[layer]
                zbt = z_bot[layer]
                db = (zbt - z) / uz if uz > 0.0 else (zt - z) / uz
                db = min(max(db, 0.0), s)  # the float32 test said s > db
                # move to the boundary, keep the unused optical depth (MCML's HitBoundary / Photon.sleft)
                mut = mua[layer] + mus[layer]
                sleft = (s - db) * mut
                x += db * ux
                y += db * uy
                if uz < 0.0:
                    z = zt
                    ni = n_idx[layer]
                    nt = n_idx[layer - 1]
                    if layer == 1 and alpha > 0.0:
                        f, nux, nuy, nuz, out = _rough_interface_u(ux, uy, uz, ni, nt, alpha, _lane_uniform(rs, lu),
                                                                   _lane_uniform(rs, lu), _lane_uniform(rs, lu))
                        w *= f
                        if out:
                            rd_sum += _score_exit(x, y, w, -nuz, dr, rd_bins, totals, 3)
                            alive = False
                        else:
                            ux = nux
                            uy = nuy
                            uz = nuz
                    else:
                        if -uz <= cos_crit_up[layer]:
                            r = 1.0
                            ca2 = 0.0
                        else:
                            r, ca2 = _fresnel(ni, nt, -uz)
                        if _lane_uniform(rs, lu) > r:  # transmitted
                            if layer == 1:
                                rd_sum += _score_exit(x, y, w, ca2, dr, rd_bins, totals, 3)
                                alive = False
                            else:
                                layer -= 1
                                ux *= ni / nt
                                uy *= ni / nt
                                uz = -ca2
                        else:
                            uz = -uz
                else:
                    z = zbt
                    ni = n_idx[layer]
                    nt = n_idx[layer + 1]
                    if uz <= cos_crit_down[layer]:
                        r = 1.0
                        ca2 = 0.0
                    else:
                        r, ca2 = _fresnel(ni, nt, uz)
                    if _lane_uniform(rs, lu) > r:
                        if layer == n_layers:
                            tt_sum += _score_exit(x, y, w, ca2, dr, tt_bins, totals, 3 + N_EXIT_BINS)
                            alive = False
                        else:
                            layer += 1
                            ux *= ni / nt
                            uy *= ni / nt
                            uz = ca2
                    else:
                        uz = -uz
                sl[lu] = _F32(sleft)
                if alive and layer != ly[lu]:
                    ly[lu] = layer
                    _set_layer(lu, layer, mua, mus, g, z_top, z_bot, lf)
            if alive and w < WEIGHT_THRESHOLD:
                if w == 0.0:
                    alive = False
                elif _lane_uniform(rs, lu) < ROULETTE_CHANCE:  # Russian roulette (MCML's Roulette)
                    w /= ROULETTE_CHANCE
                else:
                    alive = False
            px[lu] = _F32(x)
            py[lu] = _F32(y)
            pz[lu] = _F32(z)
            dx[lu] = _F32(ux)
            dy[lu] = _F32(uy)
            dz[lu] = _F32(uz)
            pw[lu] = _F32(w)
            if not alive:  # the photon ended: its absorbed weight, and the next photon
                abs_sum += float(ab[lu])
                ab[lu] = _ZERO
                al[lu] = 0
                n_alive -= 1
                while launched < n_photons and al[lu] == 0:
                    launched += 1
                    if _launch(lu, ux0, uz0, rsp, alpha, n_idx, mua, mus, g, z_top, z_bot, px, py, pz, dx, dy, dz, pw,
                               sl, ly, lf, rs):
                        al[lu] = 1
                        n_alive += 1
    totals[0] += rd_sum
    totals[1] += tt_sum
    totals[2] += abs_sum


@njit(cache=True)
def _launch(lu, ux0, uz0, rsp, alpha, n_idx, mua, mus, g, z_top, z_bot, px, py, pz, dx, dy, dz, pw, sl, ly, lf, rs):
    """A new photon in lane lu (MCML's LaunchPhoton: at the origin along (ux0, 0, uz0) with weight 1 - Rsp;
    through the rough surface with weight 1, its reflected share ending here). False if it ends at once."""
    ux = ux0
    uy = 0.0
    uz = uz0
    w = 1.0 - rsp
    if alpha > 0.0:
        f, ux, uy, uz, entered = _rough_interface_u(ux0, 0.0, uz0, n_idx[0], n_idx[1], alpha, _lane_uniform(rs, lu),
                                                    _lane_uniform(rs, lu), _lane_uniform(rs, lu))
        w = f
        if not (entered and f > 0.0):
            return False
    px[lu] = _ZERO
    py[lu] = _ZERO
    pz[lu] = _ZERO
    dx[lu] = _F32(ux)
    dy[lu] = _F32(uy)
    dz[lu] = _F32(uz)
    pw[lu] = _F32(w)
    sl[lu] = _ZERO
    ly[lu] = 1
    _set_layer(lu, 1, mua, mus, g, z_top, z_bot, lf)
    return True


def run_batches(seed: np.uint64, batch_ids: NDArray[np.int64], batch_sizes: NDArray[np.int64],
                mua: NDArray[np.float64], mus: NDArray[np.float64], g: NDArray[np.float64],
                z_top: NDArray[np.float64], z_bot: NDArray[np.float64], n_idx: NDArray[np.float64],
                cos_crit_up: NDArray[np.float64], cos_crit_down: NDArray[np.float64], rsp: float, ux0: float,
                uz0: float, dr: float, alpha: float, rd_bins: NDArray[np.float64], tt_bins: NDArray[np.float64],
                totals: NDArray[np.float64]) -> None:
    """Run the given batches on numba.get_num_threads() threads (the kernel releases the GIL; a thread
    pool instead of a parallel loop: nothing to compile or load for it); row k of rd_bins / tt_bins (K, nr)
    and totals (K, 3 + 2 N_EXIT_BINS) receives batch batch_ids[k] (:func:`_run_batch` for the layout).
    Each batch is its own stream and row: any thread count, the same rows."""
    import numba

    def one(k: int) -> None:
        _run_batch(seed, batch_ids[k], batch_sizes[k], mua, mus, g, z_top, z_bot, n_idx, cos_crit_up,
                   cos_crit_down, rsp, ux0, uz0, dr, alpha, rd_bins[k], tt_bins[k], totals[k])

    n = int(batch_ids.shape[0])
    threads = min(numba.get_num_threads(), n)
    if threads <= 1:
        for k in range(n):
            one(k)
        return
    for f in submit_all(_pool(threads), one, [(k,) for k in range(n)]):
        f.result()


_POOLS: dict[int, ThreadPoolExecutor] = {}


def _pool(threads: int) -> ThreadPoolExecutor:
    """A thread pool of ``threads`` workers, made once per size (submitted to through
    :func:`~ssskit.compute.workers.submit_all`)."""
    pool = _POOLS.get(threads)
    if pool is None:
        pool = _POOLS[threads] = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="ssskit-mcml")
    return pool
