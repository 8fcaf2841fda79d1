"""numba kernel of the adaptive sampler's guiding phase (:mod:`ssskit.backends.adaptive_plan` for the maths).

One fused per-pixel function, :func:`guide_rows`, runs for every pixel of rows [y0, y1) the
reprojection (step 1), in *update* mode the history update (step 2, float32 in the oracle's order of
operations), and the count estimate and clamp (steps 3-4, float64 as in the oracle) on the reprojected
(estimate mode) or the new (update mode) history. Pixels are independent and the kernel releases the GIL,
so the backend runs ranges of rows on its thread pool and the result does not depend on the thread count.
Compiled once and cached on disk (``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def guide_rows(hist, motion, has_motion, valid, has_valid, mask, rgb, counts_in, update, alpha, sigma0_sq,
               spread_scale, variance, sigma0, b_min, b_max, gamma_one, inv_gamma, out_hist, out_counts, y0, y1):
    """Steps 1-4 of the guiding phase for rows [y0, y1) (Xie 2020 Eqs. 6, 8, 9, 13-17):

    ``hist`` (H, W, 4) float32 the previous history; ``motion`` (H, W, 2) float64 (read if has_motion);
    ``valid`` (H, W) bool (read if has_valid); ``mask`` (H, W) bool; ``rgb`` (H, W, 3) float32 and
    ``counts_in`` (H, W) int64 this frame's result and counts (read if ``update``); ``alpha``, ``sigma0_sq``
    float32 / float64 as below; ``spread_scale`` = kappa (k - 1) (Eq. 15); ``variance``: the variance form
    of Eq. 15 (else as printed, with ``sigma0``); ``inv_gamma`` = 1 / gamma (``gamma_one``: gamma = 1).
    Writes ``out_hist`` (update mode: the new history) and ``out_counts`` (the counts of steps 3-4).
    """
    hh, ww = mask.shape
    f32 = np.float32
    a0 = f32(alpha)
    s0_f32 = f32(sigma0_sq)
    for y in range(y0, y1):
        for x in range(ww):
            ok = True if not has_valid else valid[y, x]
            qx, qy = x, y
            if has_motion:
                fx = math.floor((x + 0.5) + motion[y, x, 0])
                fy = math.floor((y + 0.5) + motion[y, x, 1])
                if fx < 0 or fx >= ww or fy < 0 or fy >= hh:
                    ok = False
                else:
                    qx, qy = int(fx), int(fy)
            if ok:  # step 1: the reprojected history h
                h0, h1, h2, h3 = hist[qy, qx, 0], hist[qy, qx, 1], hist[qy, qx, 2], hist[qy, qx, 3]
            else:
                h0, h1, h2, h3 = f32(0.0), f32(0.0), f32(0.0), f32(0.0)
            m = mask[y, x]
            if update:  # step 2: Eqs. 8, 6, 9 (16-17 without history), float32
                if m:
                    lum = rgb[y, x, 0] * f32(0.2126) + rgb[y, x, 1] * f32(0.7152) + rgb[y, x, 2] * f32(0.0722)
                    lum = max(lum, f32(0.0))
                    v = lum if gamma_one else f32(lum ** f32(inv_gamma))
                else:
                    v = f32(0.0)
                had = h3 > f32(0.0)
                a = a0 if had else f32(1.0)  # Eq. 16
                b = f32(1.0) - a
                diff = v - h1  # S - C
                n_bar = b * h0 + a * f32(counts_in[y, x])  # Eq. 8
                mu = a * diff + h1  # Eq. 6
                var = (a * diff * diff + h2) * b  # Eq. 9
                if not had:
                    var = s0_f32  # Eq. 17
                if m:
                    h0, h1, h2, h3 = n_bar, mu, var, f32(1.0)
                else:
                    h0, h1, h2, h3 = f32(0.0), f32(0.0), f32(0.0), f32(0.0)
                out_hist[y, x, 0] = h0
                out_hist[y, x, 1] = h1
                out_hist[y, x, 2] = h2
                out_hist[y, x, 3] = h3
            if not m:  # step 4: no SSS, no samples
                out_counts[y, x] = 0
                continue
            # step 3: n_hat = n_bar (var + kappa (k - 1) spread) / sigma0^2 (Eqs. 13-15), float64
            nb = np.float64(h0) * np.float64(h3)
            vv = np.float64(h2)
            spread = (vv - sigma0_sq) if variance else (math.sqrt(vv) - sigma0)
            nh = ((spread * spread_scale + vv) * nb) / sigma0_sq
            # step 4: clamp(ceil(n_hat), b_min, b_max), NaN -> b_max
            if math.isnan(nh) or nh > b_max:
                n = b_max
            elif nh <= b_min:
                n = b_min
            else:
                n = int(math.ceil(nh))
            out_counts[y, x] = n
