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
  reflectance) or transmitted, all-or-none (CrossUpOrNot / CrossDnOrNot, RFresnel); an escaping photon scores its whole weight
  at its exit radius (the last radial bin collects every radius beyond the grid) and in the bin of
  its exit direction (:data:`N_EXIT_BINS` bins uniform in cos^2 of the angle to the normal
  outside the medium, i.e. of equal projected solid angle; MCML's Rd_a with other bins);
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

Randomness: each batch of photons owns an xoroshiro128+ stream seeded by splitmix64 from
(seed, batch index), so a batch's result depends on nothing but those two numbers: the same
seed gives bit-identical tallies for any number of threads, and batches can be resumed.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from .config import N_EXIT_BINS

WEIGHT_THRESHOLD = 1e-4  # MCML's Wth
ROULETTE_CHANCE = 0.1  # MCML's CHANCE
COS_ZERO = 1.0 - 1.0e-12  # MCML's COSZERO
COS_90D = 1.0e-6  # MCML's COS90D

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_TWO53 = 1.0 / 9007199254740992.0


@njit(inline="always")
def _splitmix64(x):
    z = x + _GOLDEN
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


@njit(inline="always")
def _rotl(x, k):
    return (x << np.uint64(k)) | (x >> np.uint64(64 - k))


@njit(inline="always")
def _next(state):
    """xoroshiro128+ step; returns 53 random bits as an integer-valued float in [0, 2^53)."""
    s0 = state[0]
    s1 = state[1]
    result = s0 + s1
    s1 ^= s0
    state[0] = _rotl(s0, 24) ^ s1 ^ (s1 << np.uint64(16))
    state[1] = _rotl(s1, 37)
    return float(result >> np.uint64(11))


@njit(inline="always")
def _uniform(state):
    """Uniform in [0, 1)."""
    return _next(state) * _TWO53


@njit(inline="always")
def _uniform_open0(state):
    """Uniform in (0, 1], safe for -log."""
    return (_next(state) + 1.0) * _TWO53


@njit(inline="always")
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


@njit(inline="always")
def _spin(g, ux, uy, uz, state):
    """New direction after Henyey-Greenstein scattering (MCML's SpinTheta and Spin)."""
    if g == 0.0:
        cost = 2.0 * _uniform(state) - 1.0
    else:
        temp = (1.0 - g * g) / (1.0 - g + 2.0 * g * _uniform(state))
        cost = (1.0 + g * g - temp * temp) / (2.0 * g)
        if cost < -1.0:
            cost = -1.0
        elif cost > 1.0:
            cost = 1.0
    sint = math.sqrt(1.0 - cost * cost)
    psi = 2.0 * math.pi * _uniform(state)
    cosp = math.cos(psi)
    sinp = math.sin(psi)
    if abs(uz) > COS_ZERO:
        return sint * cosp, sint * sinp, cost * (1.0 if uz >= 0.0 else -1.0)
    temp = math.sqrt(1.0 - uz * uz)
    nux = sint * (ux * uz * cosp - uy * sinp) / temp + ux * cost
    nuy = sint * (uy * uz * cosp + ux * sinp) / temp + uy * cost
    nuz = -sint * cosp * temp + uz * cost
    return nux, nuy, nuz


@njit(inline="always")
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


@njit(inline="always")
def _rough_interface(ux, uy, uz, n1, n2, alpha, state):
    """One photon meeting a rough dielectric surface z = const (uz != 0, towards it, from the side of
    index n1; n2 beyond). Walter et al. 2007: a microfacet normal m drawn from D(m) |m.n| (Beckmann,
    Eqs. 28-29: tan^2 theta_m = -alpha^2 ln(xi)), reflection about m with the probability of the
    Fresnel reflectance F(i.m) (dielectric, total internal reflection included), refraction through
    m otherwise (Eq. 40), and the photon's weight multiplied by the sample weight of Eq. 41,
    |i.m| G1(i, m) G1(o, m) / (|i.n| |m.n|). Its expectation is the BSDF's directional albedo, below 1
    at grazing angles: the single-scattering model loses the light its masking removes.

    Returns (weight factor, ux, uy, uz of the new direction, transmitted); the factor is 0 where
    the sample is invalid (m seen from behind, or the new direction on the wrong side).
    """
    sn = -1.0 if uz > 0.0 else 1.0  # n = (0, 0, sn): the surface normal on the incident side
    ix, iy, iz = -ux, -uy, -uz  # i: from the surface back along the photon's path
    i_n = sn * iz
    t2 = -alpha * alpha * math.log(_uniform_open0(state))
    cm = 1.0 / math.sqrt(1.0 + t2)
    sm = math.sqrt(t2) * cm
    phi = 2.0 * math.pi * _uniform(state)
    mx = sm * math.cos(phi)
    my = sm * math.sin(phi)
    mz = sn * cm
    c = ix * mx + iy * my + iz * mz
    if c <= 0.0:
        return 0.0, ux, uy, uz, False
    r, ct = _fresnel(n1, n2, c)
    if _uniform(state) < r:
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


@njit(inline="always")
def _score_exit(x, y, w, cos_out, dr, rd_bins, totals):
    """Score a photon of weight w escaping at (x, y) with exit cosine cos_out outside: its radial
    bin (the last one collects every radius beyond the grid) and its exit-direction bin; returns w."""
    nr = rd_bins.shape[0]
    ir = int(math.sqrt(x * x + y * y) / dr)
    if ir > nr - 1:
        ir = nr - 1
    rd_bins[ir] += w
    ia = int(cos_out * cos_out * N_EXIT_BINS)
    if ia > N_EXIT_BINS - 1:
        ia = N_EXIT_BINS - 1
    totals[3 + ia] += w
    return w


@njit(cache=True)
def _run_batch(seed, batch, n_photons, mua, mus, g, z_top, z_bot, n_idx, cos_crit_up, cos_crit_down,
               rsp, ux0, uz0, dr, alpha, rd_bins, totals):
    """Simulate ``n_photons`` photons of stream (seed, batch); add tallies into rd_bins / totals.

    Layers are 1..L in the arrays ``mua``, ``mus``, ``g``, ``z_top``, ``z_bot`` (index 0 and L + 1
    unused); ``n_idx[0]`` is the ambient index above, ``n_idx[L + 1]`` the one below. ``alpha`` > 0:
    the top surface is rough (module docstring); (ux0, 0, uz0) is then the beam outside the medium.
    totals: [diffuse reflectance, transmittance, absorbed] weight sums, then the diffusely reflected
    weight per exit-direction bin (:data:`N_EXIT_BINS` bins uniform in cos^2 theta outside).
    """
    n_layers = mua.shape[0] - 2
    state = np.empty(2, dtype=np.uint64)
    state[0] = _splitmix64(np.uint64(seed) * _MIX1 + np.uint64(batch))
    state[1] = _splitmix64(state[0] ^ _MIX2)
    if state[0] == 0 and state[1] == 0:
        state[1] = np.uint64(1)
    rd_sum = 0.0
    tt_sum = 0.0
    abs_sum = 0.0
    for _ in range(n_photons):
        x = 0.0
        y = 0.0
        z = 0.0
        ux = ux0
        uy = 0.0
        uz = uz0
        w = 1.0 - rsp
        layer = 1
        sleft = 0.0
        alive = True
        if alpha > 0.0:
            f, ux, uy, uz, entered = _rough_interface(ux0, 0.0, uz0, n_idx[0], n_idx[1], alpha, state)
            w = f
            alive = entered and f > 0.0
        while alive:
            mut = mua[layer] + mus[layer]
            if sleft == 0.0:
                s = -math.log(_uniform_open0(state)) / mut
            else:
                s = sleft / mut
                sleft = 0.0
            if uz > 0.0:
                db = (z_bot[layer] - z) / uz
            elif uz < 0.0:
                db = (z_top[layer] - z) / uz
            else:
                db = math.inf
            if s > db:
                # move to the boundary, keep the unused optical depth (MCML's HitBoundary / Photon.sleft)
                sleft = (s - db) * mut
                x += db * ux
                y += db * uy
                if uz < 0.0:
                    z = z_top[layer]
                    ni = n_idx[layer]
                    nt = n_idx[layer - 1]
                    if layer == 1 and alpha > 0.0:
                        f, nux, nuy, nuz, out = _rough_interface(ux, uy, uz, ni, nt, alpha, state)
                        w *= f
                        if out:
                            rd_sum += _score_exit(x, y, w, -nuz, dr, rd_bins, totals)
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
                        if _uniform(state) > r:  # transmitted
                            if layer == 1:
                                rd_sum += _score_exit(x, y, w, ca2, dr, rd_bins, totals)
                                alive = False
                            else:
                                layer -= 1
                                ux *= ni / nt
                                uy *= ni / nt
                                uz = -ca2
                        else:
                            uz = -uz
                else:
                    z = z_bot[layer]
                    ni = n_idx[layer]
                    nt = n_idx[layer + 1]
                    if uz <= cos_crit_down[layer]:
                        r = 1.0
                        ca2 = 0.0
                    else:
                        r, ca2 = _fresnel(ni, nt, uz)
                    if _uniform(state) > r:
                        if layer == n_layers:
                            tt_sum += w
                            alive = False
                        else:
                            layer += 1
                            ux *= ni / nt
                            uy *= ni / nt
                            uz = ca2
                    else:
                        uz = -uz
            else:
                x += s * ux
                y += s * uy
                z += s * uz
                dwa = w * mua[layer] / mut  # implicit capture (MCML's Drop)
                w -= dwa
                abs_sum += dwa
                ux, uy, uz = _spin(g[layer], ux, uy, uz, state)
            if alive and w < WEIGHT_THRESHOLD:
                if w == 0.0:
                    alive = False
                elif _uniform(state) < ROULETTE_CHANCE:  # Russian roulette (MCML's Roulette)
                    w /= ROULETTE_CHANCE
                else:
                    alive = False
    totals[0] += rd_sum
    totals[1] += tt_sum
    totals[2] += abs_sum


@njit(parallel=True, cache=True)
def run_batches(seed: np.uint64, batch_ids: NDArray[np.int64], batch_sizes: NDArray[np.int64],
                mua: NDArray[np.float64], mus: NDArray[np.float64], g: NDArray[np.float64],
                z_top: NDArray[np.float64], z_bot: NDArray[np.float64], n_idx: NDArray[np.float64],
                cos_crit_up: NDArray[np.float64], cos_crit_down: NDArray[np.float64], rsp: float, ux0: float,
                uz0: float, dr: float, alpha: float, rd_bins: NDArray[np.float64], totals: NDArray[np.float64]) -> None:
    """Run the given batches in parallel; row k of rd_bins / totals receives batch batch_ids[k]."""
    for k in prange(batch_ids.shape[0]):
        _run_batch(seed, batch_ids[k], batch_sizes[k], mua, mus, g, z_top, z_bot, n_idx, cos_crit_up,
                   cos_crit_down, rsp, ux0, uz0, dr, alpha, rd_bins[k], totals[k])
