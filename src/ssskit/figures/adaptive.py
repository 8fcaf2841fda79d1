"""Xie et al. 2020 Figs. 2 and 3: the circle scenario of the variance-guided adaptive sampler (Sec. 4.1.3-4.1.4).

One pixel integrates uniform irradiance 4/pi inside a circle of radius 0.5 centred at (0.5, 0.5) with
uniform random samples (:func:`ssskit.screenspace.adaptive.circle_scenario`): b = [8, 64], alpha = 0.2,
sigma0^2 = 0.08^2, H_0 = 0, 150 frames, kappa = 0 and kappa = 1. Fig. 2 is the *cold start* (H_0 = 0
taken as history), Fig. 3 the disocclusion initialisation (Eqs. 16-17). Per kappa, two panels as the
paper has them: the estimate n_hat (Eq. 14) and the samples used n; sigma (the square root of Eq. 9)
and mu (Eq. 6).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..screenspace.adaptive import AdaptiveSettings, CircleRun, circle_scenario
from .plots import pyplot, save_figure

#: the paper's circle-scenario setting (Sec. 4.1.3)
CIRCLE_SIGMA0_SQ = 0.08**2
CIRCLE_FRAMES = 150
CIRCLE_KAPPAS = (0.0, 1.0)
#: the pixel shown (any seed shows the same behaviour; the tests check it over hundreds of pixels)
CIRCLE_SEED = 1


def circle_runs(disocclusion: bool, correction: str = "variance", seed: int = CIRCLE_SEED,
                pixels: int = 1) -> list[CircleRun]:
    """The circle scenario for kappa = 0 and kappa = 1 (Xie 2020 Sec. 4.1.3)."""
    return [circle_scenario(AdaptiveSettings(sigma0_sq=CIRCLE_SIGMA0_SQ, kappa=k, b_min=8, b_max=64, alpha=0.2,
                                             correction=correction),
                            CIRCLE_FRAMES, disocclusion=disocclusion, pixels=pixels, seed=seed)
            for k in CIRCLE_KAPPAS]


def plot_circle(runs: list[CircleRun], title: str, path: Path) -> list[Path]:
    """One row per run: n_hat and n per frame (left), sigma and mu per frame (right)."""
    plt = pyplot()
    fig, axes = plt.subplots(len(runs), 2, figsize=(12, 3.2 * len(runs)), squeeze=False)
    for row, run in zip(axes, runs):
        s = run.settings
        frames = np.arange(1, run.n.shape[0] + 1)
        top = 2.0 * s.b_max
        n_hat = run.n_hat[:, 0]
        ax = row[0]
        ax.plot(frames, np.clip(n_hat, -0.5 * s.b_max, top), color="#9467bd", lw=1.0, label=r"$\hat n$ (Eq. 14)")
        ax.plot(frames, run.n[:, 0], color="#1f77b4", lw=1.4, drawstyle="steps-mid", label="samples n")
        ax.axhline(s.b_min, color="0.6", ls=":", lw=0.8)
        ax.axhline(s.b_max, color="0.6", ls=":", lw=0.8)
        ax.set_ylim(-0.5 * s.b_max, top)
        ax.set_xlabel("frame")
        ax.set_ylabel("samples per pixel")
        ax.set_title(rf"$\kappa$ = {s.kappa:g}: samples (total {int(run.n.sum())}; "
                     rf"$\hat n$ peaks at {n_hat.max():.0f}, clipped to [{-0.5 * s.b_max:g}, {top:g}])", fontsize=9)
        ax.legend(fontsize=8, loc="upper right")
        ax = row[1]
        ax.plot(frames, run.sigma[:, 0], color="#d62728", lw=1.2, label=r"$\sigma$ (Eq. 9)")
        ax.axhline(np.sqrt(s.sigma0_sq), color="#d62728", ls="--", lw=0.8, label=r"$\sigma_0$")
        ax.set_ylabel(r"$\sigma$")
        ax.set_xlabel("frame")
        ax.set_ylim(0, max(0.3, 1.1 * float(run.sigma[:, 0].max())))
        twin = ax.twinx()
        twin.plot(frames, run.mu[:, 0], color="#2ca02c", lw=1.2, label=r"$\mu$ (Eq. 6)")
        twin.axhline(1.0, color="#2ca02c", ls="--", lw=0.8)
        twin.set_ylim(0, 1.5)
        twin.set_ylabel(r"$\mu$")
        lines = ax.get_lines()[:2] + twin.get_lines()[:1]
        ax.legend(lines, [ln.get_label() for ln in lines], fontsize=8, loc="upper right")
        ax.set_title(rf"$\kappa$ = {s.kappa:g}: $\sigma$ and $\mu$ after each frame's update", fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    return [path]


def xie_fig2_cold_start(out: Path, profile=None, progress=None) -> list[Path]:
    """Xie 2020 Fig. 2: the circle scenario from a cold start (H_0 = 0), kappa = 0 and 1.

    ``profile`` is not used (the scenario integrates a uniform disk, not a diffusion profile)."""
    return plot_circle(circle_runs(False), "Xie 2020 Fig. 2, circle scenario, cold start: b = [8, 64], "
                       r"$\alpha$ = 0.2, $\sigma_0^2 = 0.08^2$, $\mathcal{H}_0$ = 0",
                       Path(out) / "xie_fig2_circle_cold_start.png")


def xie_fig3_disocclusion(out: Path, profile=None, progress=None) -> list[Path]:
    """Xie 2020 Fig. 3: the circle scenario with the disocclusion initialisation (Eqs. 16-17), kappa = 0 and 1."""
    return plot_circle(circle_runs(True), "Xie 2020 Fig. 3, circle scenario, disocclusion initialisation "
                       r"(Eqs. 16-17: $\mathcal{M}'$ = 1, $\hat\sigma^2 = \sigma_0^2$ on frame 1)",
                       Path(out) / "xie_fig3_circle_disocclusion.png")


__all__ = ["circle_runs", "plot_circle", "xie_fig2_cold_start", "xie_fig3_disocclusion"]
