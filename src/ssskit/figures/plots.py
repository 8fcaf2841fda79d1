"""Matplotlib plots shared by the figures and the report: profiles, the Burley sampler's c, 2D kernels.

pyplot is imported on first use, with the Agg backend (no display needed).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from ..io import atomic_output
from ..materials import CHANNELS

if TYPE_CHECKING:
    from ..profiles.base import RGBProfile

CHANNEL_COLORS = ("#d62728", "#2ca02c", "#1f77b4")
_STYLES = ("-", "--", ":", "-.")


def pyplot() -> ModuleType:
    """matplotlib.pyplot with the Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: str | Path, dpi: int = 110) -> None:
    """Write ``fig`` atomically (format from the suffix) and close it."""
    with atomic_output(path) as tmp:
        # "tight": titles, labels and a legend beside the axes are kept whole, never clipped
        fig.savefig(tmp, dpi=dpi, format=Path(path).suffix.lstrip(".") or "png", bbox_inches="tight")
    pyplot().close(fig)


def plot_profiles(profiles: Sequence[RGBProfile], title: str, path: str | Path, n: int = 400) -> None:
    """Three panels: R(r) linear, R(r) on log-log axes (to the end of a Monte Carlo grid, marked), and
    2 pi r R(r) (the supplement's weighted view); one legend beside the panels.

    ``profiles`` is a list of RGBProfile sharing one r axis (to the largest 99.9%-energy radius).
    """
    plt = pyplot()
    # simulated profiles extend to 32 mean free paths: scale the axis by the analytic ones if any
    analytic = [p for p in profiles if p.model != "montecarlo"] or profiles
    r_max = max(float(np.max(p.radius_at_fraction(0.999))) for p in analytic)
    r = (np.arange(n) + 0.5) * (r_max / n)
    grid_ends = [float(c.edges[-1]) for p in profiles if p.model == "montecarlo" for c in p.channels
                 if hasattr(c, "edges")]
    r_log = np.geomspace(r_max / 2000, max([r_max] + grid_ends) * 1.15, n)
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    for k, prof in enumerate(profiles):
        values = prof.eval(r)
        logv = prof.eval(r_log)
        for c in range(3):
            kw = dict(color=CHANNEL_COLORS[c], ls=_STYLES[k % len(_STYLES)], lw=1.4)
            label = f"{prof.model} {CHANNELS[c]}"
            axes[0].plot(r, values[:, c], label=label, **kw)
            axes[1].loglog(r_log, np.where(logv[:, c] > 0, logv[:, c], np.nan), **kw)
            axes[2].plot(r, 2 * np.pi * r * values[:, c], **kw)
    for end in sorted(set(round(e, 6) for e in grid_ends)):
        axes[1].axvline(end, color="0.4", lw=0.8, ls=":")
    if grid_ends:
        # x in data, y in axes units: the label stays inside the panel whatever y range is set below (placed
        # at the autoscaled top, it fell outside once set_ylim narrowed the range: a blank band in the saved figure)
        axes[1].text(max(grid_ends), 0.98, " Monte Carlo grid ends", rotation=90, va="top", ha="right",
                     fontsize=8, color="0.3", transform=axes[1].get_xaxis_transform())
    # 1/r profiles (Burley) diverge at the origin: scale the linear panel from r >= r_max / 50, and say
    # so in the panel where a curve runs above it (the log-log panel shows the peaks)
    cap = 1.2 * max(float(p.eval(r[n // 50 :]).max()) for p in profiles)
    axes[0].set_ylim(0, cap)
    if max(float(p.eval(r[:1]).max()) for p in profiles) > cap:
        axes[0].text(0.98, 0.97, f"clipped at {cap:.3g} mm$^{{-2}}$ near r = 0\n(the peaks: log-log panel)",
                     transform=axes[0].transAxes, ha="right", va="top", fontsize=8, color="0.3")
    top = max(float(p.eval(r_log[:1]).max()) for p in profiles)
    axes[1].set_ylim(top * 1e-10, top * 3)
    axes[0].set_title("R(r)  [mm$^{-2}$]")
    axes[1].set_title("R(r), log-log")
    axes[2].set_title(r"$2\pi r\,R(r)$  [mm$^{-1}$]")
    for ax in axes:
        ax.set_xlabel("r [mm]")
        ax.grid(alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="center left", bbox_to_anchor=(0.995, 0.5), fontsize=8, frameon=False)
    fig.suptitle(title)
    fig.subplots_adjust(left=0.05, right=0.98, wspace=0.22, top=0.86, bottom=0.13)
    save_figure(fig, path)


def plot_xie_c(path: str | Path, cs: Sequence[float] = (2.0, 2.5715, 3.0), c_minimax: float | None = None) -> None:
    """Xie 2020 Fig. 5 analogue: percentage error of Eq. 21 against the exact inverse of Eq. 20,
    and the CDF error cdf(g(xi)) - xi, for several c."""
    from ..profiles.burley import burley_inverse_cdf
    from ..sampling.burley_radius import xie_cdf_error, xie_g

    plt = pyplot()
    xi = np.linspace(1e-4, 1 - 1e-4, 2000)
    exact = burley_inverse_cdf(xi, 1.0)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    values = list(cs) + ([c_minimax] if c_minimax is not None else [])
    for c in values:
        axes[0].plot(xi, 100 * (xie_g(xi, 1.0, c) / exact - 1), label=f"c = {c:.4f}")
        axes[1].plot(xi, xie_cdf_error(c, xi), label=f"c = {c:.4f}")
    axes[0].set_title("Eq. 21 vs exact inverse of Eq. 20  [% error in r]")
    axes[1].set_title("cdf(g(ξ)) − ξ")
    for ax in axes:
        ax.set_xlabel("ξ")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)


def plot_kernel_2d(cells: np.ndarray, cell_mm: float, title: str, path: str | Path) -> None:
    """The discretised 2D profile (cell integrals per mm^2), log scale, one panel per channel."""
    plt = pyplot()
    n = cells.shape[0]
    ext = n * cell_mm / 2
    fig, axes = plt.subplots(1, 3, figsize=(12, 4))
    density = cells / cell_mm**2
    vmax = float(np.log10(density.max()))
    for c in range(3):
        im = axes[c].imshow(
            np.log10(np.maximum(density[..., c], 1e-12)), extent=(-ext, ext, -ext, ext),
            cmap="magma", vmin=vmax - 6, vmax=vmax, origin="lower",
        )
        axes[c].set_title(f"{CHANNELS[c]}: log10 Rd(x, y) [mm$^{{-2}}$]")
        axes[c].set_xlabel("x [mm]")
    fig.colorbar(im, ax=axes, shrink=0.8)
    fig.suptitle(title)
    save_figure(fig, path)
