"""The MCML algorithm of :mod:`ssskit.profiles.montecarlo.engine_numba`, written as plain
vectorised numpy (Wang, Jacques, Zheng 1995).

It advances every live photon one step per iteration (same launch, step, boundary, Fresnel,
implicit capture, Henyey-Greenstein and roulette rules and constants as the numba engine). It is
the comparison the benchmark times against the numba engine, and an independent statistical
check in the tests: its random numbers come from numpy's PCG64, not the numba streams. Photon k
belongs to batch k // cfg.batch_size, so the result has the same per-batch standard errors.
"""

from __future__ import annotations

import time

import numpy as np

from ...errors import ProfileError
from ...quantities import refuse_unused
from .config import N_EXIT_BINS, MCConfig, layer_arrays
from .engine_numba import COS_90D, COS_ZERO, ROULETTE_CHANCE, WEIGHT_THRESHOLD
from .result import N_TOTALS, MCResult, assemble_result


def _fresnel(n1, n2, ca1):
    """Vectorised MCML RFresnel: reflectance and transmitted cosine (MCML's RFresnel)."""
    ca1 = np.asarray(ca1, dtype=float)
    r = np.ones_like(ca1)
    ca2 = np.zeros_like(ca1)
    same = n1 == n2
    r[same], ca2[same] = 0.0, ca1[same]
    normal = ~same & (ca1 > COS_ZERO)
    r[normal] = ((n2[normal] - n1[normal]) / (n2[normal] + n1[normal])) ** 2
    ca2[normal] = ca1[normal]
    gen = ~same & ~normal & (ca1 >= COS_90D)
    a1, m1, m2 = ca1[gen], n1[gen], n2[gen]
    sa1 = np.sqrt(1.0 - a1 * a1)
    sa2 = m1 * sa1 / m2
    ok = sa2 < 1.0
    a2 = np.sqrt(np.maximum(1.0 - sa2 * sa2, 0.0))
    cap, cam = a1 * a2 - sa1 * sa2, a1 * a2 + sa1 * sa2
    sap, sam = sa1 * a2 + a1 * sa2, sa1 * a2 - a1 * sa2
    with np.errstate(divide="ignore", invalid="ignore"):
        rg = 0.5 * sam * sam * (cam * cam + cap * cap) / (sap * sap * cam * cam)
    r[gen] = np.where(ok, rg, 1.0)
    ca2[gen] = np.where(ok, a2, 0.0)
    return r, ca2


def simulate_numpy(cfg: MCConfig, seed: int | None = None) -> MCResult:
    """Run all ``cfg.photons`` photons at once with numpy's PCG64 seeded by ``seed`` (default
    ``cfg.seed``); nothing is cached. The twin of :func:`~ssskit.profiles.montecarlo.simulate`, for
    smooth surfaces only (MCML's)."""
    if cfg.roughness > 0:
        refuse_unused([f"roughness {cfg.roughness:g}"], "engine", ("numba or gl (simulate)",), "numpy", ProfileError)
    t0 = time.perf_counter()
    rng = np.random.default_rng(cfg.seed if seed is None else seed)
    a = layer_arrays(cfg)
    n_layers = len(cfg.layers)
    n = cfg.photons
    n_b = cfg.n_batches
    batch = np.arange(n) // cfg.batch_size
    x, y, z = np.zeros(n), np.zeros(n), np.zeros(n)
    ux0, uz0 = cfg.launch_direction()
    ux, uy, uz = np.full(n, ux0), np.zeros(n), np.full(n, uz0)
    w = np.full(n, 1.0 - cfg.specular_reflectance())
    layer = np.ones(n, dtype=np.int64)
    sleft = np.zeros(n)
    idx = np.arange(n)
    bins = np.zeros((n_b, cfg.nr))
    tt_bins = np.zeros((n_b, cfg.nr))
    # per batch: [reflected, transmitted, absorbed] weight sums, then the reflected and the transmitted weight
    # per exit-direction bin
    totals = np.zeros((n_b, N_TOTALS))
    while idx.size:
        lay = layer[idx]
        mut = a["mua"][lay] + a["mus"][lay]
        fresh = sleft[idx] == 0.0
        s = np.where(fresh, -np.log1p(-rng.random(idx.size)) / mut, sleft[idx] / mut)
        sleft[idx] = 0.0
        uzi = uz[idx]
        with np.errstate(divide="ignore", invalid="ignore"):
            db = np.where(uzi > 0, (a["z_bot"][lay] - z[idx]) / uzi,
                          np.where(uzi < 0, (a["z_top"][lay] - z[idx]) / uzi, np.inf))
        hit = s > db
        # --- photons reaching a boundary
        h = idx[hit]
        if h.size:
            dbh = db[hit]
            sleft[h] = (s[hit] - dbh) * mut[hit]
            x[h] += dbh * ux[h]
            y[h] += dbh * uy[h]
            lh = layer[h]
            up = uz[h] < 0
            z[h] = np.where(up, a["z_top"][lh], a["z_bot"][lh])
            ni = a["n_idx"][lh]
            nt = np.where(up, a["n_idx"][lh - 1], a["n_idx"][lh + 1])
            crit = np.where(up, a["cos_crit_up"][lh], a["cos_crit_down"][lh])
            ca1 = np.abs(uz[h])
            r, ca2 = _fresnel(ni, nt, ca1)
            r = np.where(ca1 <= crit, 1.0, r)
            trans = rng.random(h.size) > r
            escape_top = trans & up & (lh == 1)
            escape_bot = trans & ~up & (lh == n_layers)
            move = trans & ~escape_top & ~escape_bot
            e = h[escape_top]
            ir = np.minimum((np.sqrt(x[e] ** 2 + y[e] ** 2) / cfg.dr_mm).astype(np.int64), cfg.nr - 1)
            np.add.at(bins, (batch[e], ir), w[e])
            totals[:, 0] += np.bincount(batch[e], weights=w[e], minlength=n_b)
            ia = np.minimum((ca2[escape_top] ** 2 * N_EXIT_BINS).astype(np.int64), N_EXIT_BINS - 1)
            np.add.at(totals, (batch[e], 3 + ia), w[e])
            eb = h[escape_bot]
            totals[:, 1] += np.bincount(batch[eb], weights=w[eb], minlength=n_b)
            ir = np.minimum((np.sqrt(x[eb] ** 2 + y[eb] ** 2) / cfg.dr_mm).astype(np.int64), cfg.nr - 1)
            np.add.at(tt_bins, (batch[eb], ir), w[eb])
            ia = np.minimum((ca2[escape_bot] ** 2 * N_EXIT_BINS).astype(np.int64), N_EXIT_BINS - 1)
            np.add.at(totals, (batch[eb], 3 + N_EXIT_BINS + ia), w[eb])
            w[h[escape_top | escape_bot]] = 0.0
            mv = h[move]
            ratio = (ni / nt)[move]
            ux[mv] *= ratio
            uy[mv] *= ratio
            uz[mv] = np.where(up[move], -ca2[move], ca2[move])
            layer[mv] += np.where(up[move], -1, 1)
            refl = h[~trans]
            uz[refl] = -uz[refl]
        # --- photons interacting inside a layer
        m = idx[~hit]
        if m.size:
            sm = s[~hit]
            x[m] += sm * ux[m]
            y[m] += sm * uy[m]
            z[m] += sm * uz[m]
            lm = layer[m]
            dwa = w[m] * a["mua"][lm] / (a["mua"][lm] + a["mus"][lm])
            w[m] -= dwa
            totals[:, 2] += np.bincount(batch[m], weights=dwa, minlength=n_b)
            g = a["g"][lm]
            xi = rng.random(m.size)
            with np.errstate(divide="ignore", invalid="ignore"):
                temp = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi)
                cost = np.where(g == 0.0, 2.0 * xi - 1.0, np.clip((1.0 + g * g - temp * temp) / (2.0 * g), -1.0, 1.0))
            sint = np.sqrt(1.0 - cost * cost)
            psi = 2.0 * np.pi * rng.random(m.size)
            cosp, sinp = np.cos(psi), np.sin(psi)
            ox, oy, oz = ux[m], uy[m], uz[m]
            vertical = np.abs(oz) > COS_ZERO
            tmp = np.sqrt(np.maximum(1.0 - oz * oz, 1e-300))
            ux[m] = np.where(vertical, sint * cosp, sint * (ox * oz * cosp - oy * sinp) / tmp + ox * cost)
            uy[m] = np.where(vertical, sint * sinp, sint * (oy * oz * cosp + ox * sinp) / tmp + oy * cost)
            uz[m] = np.where(vertical, cost * np.sign(oz + (oz == 0)), -sint * cosp * tmp + oz * cost)
        # --- roulette and removal of the dead
        live = idx[w[idx] > 0.0]
        low = live[w[live] < WEIGHT_THRESHOLD]
        survive = rng.random(low.size) < ROULETTE_CHANCE
        w[low[survive]] /= ROULETTE_CHANCE
        w[low[~survive]] = 0.0
        idx = idx[w[idx] > 0.0]
    return assemble_result(cfg, bins, totals, time.perf_counter() - t0, {"engine": "numpy"}, tt_bins=tt_bins)
