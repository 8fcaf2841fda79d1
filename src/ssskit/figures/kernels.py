"""Kernel figures of the separable-SSS paper: Fig. 2, 4, 5, 7 (supplement S.3) and supplement S.5."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..kernels import build_kernel
from ..kernels.base import Kernel, default_grid
from ..kernels.methods import singular_values
from ..materials import CHANNELS
from ..metrics import psnr_text, tonemap
from ..profiles.base import RGBProfile
from .plots import CHANNEL_COLORS, pyplot, save_figure

#: grid of the kernel figures (the evaluation grids are tied to the image instead)
FIG_N = 201


def fig2_singular_values(out: Path, profile: RGBProfile, progress: Callable[[str], None] | None = None) -> list[Path]:
    """Paper Fig. 2: singular values of the discrete Rd per channel (sigma_i / sigma_1, log scale)."""
    plt = pyplot()
    h, n = default_grid(profile, FIG_N)
    sv = singular_values(profile, h, n)
    fig, ax = plt.subplots(figsize=(6, 4))
    for c in range(3):
        ax.semilogy(np.arange(1, 31), sv[c, :30] / sv[c, 0], "o-", ms=3, color=CHANNEL_COLORS[c], label=CHANNELS[c])
    ax.set_xlabel("index i")
    ax.set_ylabel(r"$\sigma_i / \sigma_1$")
    ax.set_title(f"Singular values of Rd ({profile.name}, {profile.model}; {n}x{n} cells)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    path = out / "fig2_singular_values.png"
    save_figure(fig, path)
    return [path]


def _finish(fig: Any, title: str, path: Path, fontsize: float = 12) -> list[Path]:
    """Title, lay out and write a figure; returns [path]."""
    fig.suptitle(title, fontsize=fontsize)
    fig.tight_layout()
    save_figure(fig, path)
    return [path]


def _kernel_rgb(cells: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """A 2D kernel as an RGB image: each channel over the true kernel's peak, log-compressed over 4 decades."""
    x = np.maximum(cells / ref.max(axis=(0, 1)), 1e-4)
    return (np.log10(x) + 4.0) / 4.0


def fig4_svd_ranks(out: Path, profile: RGBProfile, progress: Callable[[str], None] | None = None) -> list[Path]:
    """Paper Fig. 4: SVD rank 1, 3, 6 approximations of the 2D kernel next to the true kernel."""
    plt = pyplot()
    h, n = default_grid(profile, FIG_N)
    rd = profile.discretize_2d(h, n)
    ext = n * h / 2
    fig, axes = plt.subplots(1, 4, figsize=(14, 3.9))
    panels = [("true Rd", rd)]
    for r in (1, 3, 6):
        k = build_kernel("svd", profile, h, n, rank=r)
        assert isinstance(k, Kernel)  # svd tabulates
        err = np.mean(k.compare(profile)["relative_frobenius"])
        panels.append((f"SVD rank {r} (rel. Frobenius {err:.3f})", k.to_2d()))
    for ax, (title, cells) in zip(axes, panels):
        ax.imshow(_kernel_rgb(cells, rd).clip(0, 1), extent=(-ext, ext, -ext, ext), origin="lower")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("x [mm]")
    return _finish(fig, f"Rank-N SVD approximations, {profile.name} (log10 of each channel over 4 decades)",
                   out / "fig4_svd_ranks.png")


def fig5_slices(out: Path, profile: RGBProfile, progress: Callable[[str], None] | None = None) -> list[Path]:
    """Paper Fig. 5: axis and diagonal slices of the pre-integrated kernel vs the true kernel."""
    plt = pyplot()
    h, n = default_grid(profile, FIG_N)
    k = build_kernel("preintegrated", profile, h, n)
    assert isinstance(k, Kernel)  # preintegrated tabulates
    x = k.x_mm
    axis, diag = k.axis_slice(), k.diagonal_slice()
    fig, axes = plt.subplots(2, 3, figsize=(13, 6.5), sharex=True)
    for c in range(3):
        for row, (name, vals, r) in enumerate((("Axis", axis, np.abs(x)), ("Diagonal", diag, np.sqrt(2.0) * np.abs(x)))):
            ax = axes[row, c]
            xs = x if row == 0 else np.sign(x) * r
            ax.semilogy(xs, profile.channels[c].eval(np.maximum(r, 1e-9)), "k-", lw=1.2, label="Gr. truth")
            ax.semilogy(xs, np.maximum(vals[:, c], 1e-300), "--", color=CHANNEL_COLORS[c], lw=1.2, label="Pre-int.")
            ax.set_title(f"{name} slice ({CHANNELS[c]})", fontsize=9)
            ax.set_ylabel("Rd [mm$^{-2}$]")
            lo = profile.channels[c].eval(np.array([x.max()]))[0]
            hi = max(float(vals[:, c].max()), float(profile.channels[c].eval(np.array([h / 2]))[0]))
            ax.set_ylim(max(lo * 0.5, hi * 1e-12), hi * 3.0)
            ax.legend(fontsize=7)
    for ax in axes[1]:
        ax.set_xlabel("mm")
    return _finish(fig, f"Pre-integrated kernel vs ground truth, {profile.name} (paper Fig. 5)", out / "fig5_slices.png")


def _comparison(out: Path, profile: RGBProfile, signal: str, filename: str, title: str,
                progress: Callable[[str], None] | None, crop: str) -> list[Path]:
    from ..pipeline.evaluate import FIG7_METHODS, evaluate

    plt = pyplot()
    # the panels show relative RMSE, PSNR and FLIP (no SSIM)
    ev = evaluate(profile, signal, FIG7_METHODS, size=256, perceptual=("flip",), keep_images=True, progress=progress)
    peak = float(ev.truth.max())
    rows = [(m, ev.images[m], ev.results[m]) for m in FIG7_METHODS] + [("true kernel", ev.truth, None)]
    ncol = 3 if crop == "full" else 1
    nrow = int(np.ceil(len(rows) / ncol))
    size = (4.4 * ncol, 1.05 * nrow) if crop == "strip" else (3.6 * ncol, 3.0 * nrow)
    fig, axes = plt.subplots(nrow, ncol, figsize=size, squeeze=False)
    s = ev.truth.shape[0]
    for ax in axes.ravel():
        ax.axis("off")
    for ax, (label, img, res) in zip(axes.ravel(), rows):
        view = img[s // 2 - 12: s // 2 + 12] if crop == "strip" else img
        ax.imshow(tonemap(view, peak), interpolation="nearest", aspect="auto")
        text = label if res is None else (f"{label}  [{res['convolutions_1d']} conv]  rel.RMSE {res['relative_rmse']:.2e}"
                                          f"  PSNR {psnr_text(res['psnr'])}  FLIP {res['flip']:.3f}")
        ax.set_title(text, fontsize=7, loc="left")
    return _finish(fig, f"{title}: {profile.name} ({profile.model}), {ev.pixel_mm:.3f} mm/pixel", out / filename, 9)


def fig7_step(out: Path, profile: RGBProfile, progress: Callable[[str], None] | None = None) -> list[Path]:
    """Paper Fig. 7 / supplement Fig. S.3: every method on a step-like irradiance, errors beside each row."""
    return _comparison(out, profile, "edge", "fig7_step.png", "Step irradiance (paper Fig. 7 / S.3)", progress, "strip")


def figS5_disk(out: Path, profile: RGBProfile, progress: Callable[[str], None] | None = None) -> list[Path]:
    """Supplement Fig. S.5: every method on a white disk ('dot'), errors beside each image."""
    return _comparison(out, profile, "disk", "figS5_disk.png", "White disk (supplement Fig. S.5)", progress, "full")
