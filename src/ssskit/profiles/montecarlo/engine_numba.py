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

Randomness: each batch of photons owns an xoroshiro128+ stream seeded by splitmix64 from
(seed, batch index), so a batch's result depends on nothing but those two numbers: the same
seed gives bit-identical tallies for any number of threads, and batches can be resumed.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

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


@njit(cache=True)
def _run_batch(seed, batch, n_photons, mua, mus, g, z_top, z_bot, n_idx, cos_crit_up, cos_crit_down,
               rsp, ux0, uz0, dr, rd_bins, totals):
    """Simulate ``n_photons`` photons of stream (seed, batch); add tallies into rd_bins / totals.

    Layers are 1..L in the arrays ``mua``, ``mus``, ``g``, ``z_top``, ``z_bot`` (index 0 and L + 1
    unused); ``n_idx[0]`` is the ambient index above, ``n_idx[L + 1]`` the one below.
    totals: [diffuse reflectance, transmittance, absorbed] weight sums, then the diffusely reflected
    weight per exit-direction bin (:data:`N_EXIT_BINS` bins uniform in cos^2 theta outside).
    """
    n_layers = mua.shape[0] - 2
    nr = rd_bins.shape[0]
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
                    if -uz <= cos_crit_up[layer]:
                        r = 1.0
                        ca2 = 0.0
                    else:
                        r, ca2 = _fresnel(ni, nt, -uz)
                    if _uniform(state) > r:  # transmitted
                        if layer == 1:
                            rr = math.sqrt(x * x + y * y)
                            ir = int(rr / dr)
                            if ir > nr - 1:
                                ir = nr - 1
                            rd_bins[ir] += w
                            rd_sum += w
                            ia = int(ca2 * ca2 * N_EXIT_BINS)
                            if ia > N_EXIT_BINS - 1:
                                ia = N_EXIT_BINS - 1
                            totals[3 + ia] += w
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
def run_batches(seed, batch_ids, batch_sizes, mua, mus, g, z_top, z_bot, n_idx, cos_crit_up,
                cos_crit_down, rsp, ux0, uz0, dr, rd_bins, totals):
    """Run the given batches in parallel; row k of rd_bins / totals receives batch batch_ids[k]."""
    for k in prange(batch_ids.shape[0]):
        _run_batch(seed, batch_ids[k], batch_sizes[k], mua, mus, g, z_top, z_bot, n_idx, cos_crit_up,
                   cos_crit_down, rsp, ux0, uz0, dr, rd_bins[k], totals[k])
