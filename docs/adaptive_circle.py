"""The circle scenario (Xie 2020 Sec. 4.1.3) over many pixels: Eq. 15 as printed vs its variance form.

For each correction form, kappa and unit of the values (the irradiance and sigma0 scaled together),
runs :func:`ssskit.screenspace.adaptive.circle_scenario` (b = [8, 64], alpha = 0.2, 150 frames, cold
start) on independent pixels and prints, over frames 50-150 (after the cold start): mean samples per
frame, sigma (RMS and median) over sigma0, |mean mu - 1|, the peaks of n (runs of frames above the
budget's midpoint: mean height and length), the mean frame-to-frame jump of n, and the share of frames
at b_min and at b_max; then the start-up (cold start vs disocclusion initialisation): samples above the
steady rate over the first 20 frames and the median peak of n_hat.
The numbers quoted in docs/adaptive.md come from this script.

    python docs/adaptive_circle.py [--pixels 300] [--seed 2]
"""

from __future__ import annotations

import argparse
import math

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pixels", type=int, default=300)
    ap.add_argument("--seed", type=int, default=2)
    args = ap.parse_args()
    from ssskit.screenspace.adaptive import AdaptiveSettings, circle_scenario

    print("| scale | sigma0^2 | Eq. 15 | kappa | mean n | sigma/sigma0 RMS, median | |mu-1| | peak height, length "
          "| mean jump | at b_min, b_max |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    # scale c: irradiance 4c/pi and sigma0 = 0.08 c, the same problem in other units (c = 0.395: sigma0^2 =
    # 1e-3, Xie's Figs. 1, 9-11; c = 0.125: sigma0 = 0.01, Fig. 4)
    for c in (1.0, math.sqrt(1e-3) / 0.08, 0.125):
        s0 = (0.08 * c) ** 2
        for corr in ("variance", "sigma"):
            for kappa in (0.0, 0.2, 0.6, 1.0):
                s = AdaptiveSettings(sigma0_sq=s0, kappa=kappa, correction=corr)
                run = circle_scenario(s, 150, pixels=args.pixels, seed=args.seed, scale=c)
                n, sig = run.n[50:], run.sigma[50:]
                h, ln = run.peaks(0.5 * (s.b_min + s.b_max), 50)
                print(f"| {c:.3g} | {s0:.3g} | {corr} | {kappa:g} | {n.mean():.1f} | "
                      f"{math.sqrt((sig**2).mean() / s0):.3f}, "
                      f"{np.median(sig) / math.sqrt(s0):.3f} | {abs(run.mu[50:].mean() / c - 1):.4f} | "
                      f"{h:.1f}, {ln:.2f} | "
                      f"{np.abs(np.diff(n, axis=0)).mean():.1f} | {(n == s.b_min).mean():.2f}, "
                      f"{(n == s.b_max).mean():.2f} |")
    print()
    print("| Eq. 15 | kappa | start | samples above the steady rate, frames 1-20 (per frame) "
          "| median max n_hat, frames 1-30 |")
    print("|---|---|---|---|---|")
    for corr in ("variance", "sigma"):
        for kappa in (0.0, 1.0):
            for dis in (False, True):
                s = AdaptiveSettings(sigma0_sq=0.08**2, kappa=kappa, correction=corr)
                run = circle_scenario(s, 150, pixels=args.pixels, seed=args.seed, disocclusion=dis)
                excess = run.n[:20].mean() - run.n[75:].mean()
                print(f"| {corr} | {kappa:g} | {'disocclusion' if dis else 'cold start'} | {excess:+.1f} | "
                      f"{np.median(run.n_hat[:30].max(axis=0)):.0f} |")


if __name__ == "__main__":
    main()
