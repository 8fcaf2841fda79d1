"""Per-frame pictures of a frame sequence (:mod:`ssskit.pipeline.sequence`): tone-mapped frames and
sample-count heatmaps with a colour bar, written as PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..io import atomic_output, tonemap, write_png


def save_frame_png(path: str | Path, image: ArrayLike, peak: float) -> Path:
    """A linear RGB frame (H, W, 3) as 8-bit sRGB PNG, tone-mapped by :func:`ssskit.io.tonemap` with one
    fixed ``peak`` for the whole sequence (so frames do not flicker in brightness)."""
    p = Path(path)
    ldr = np.round(255.0 * tonemap(np.nan_to_num(np.asarray(image, np.float64)), peak if peak > 0 else 1.0))
    write_png(p, ldr.astype(np.uint8))
    return p


def save_heatmap_png(path: str | Path, counts: ArrayLike, vmax: int, title: str = "", vmin: int = 0) -> Path:
    """Samples per pixel (H, W) as a heatmap PNG with a colour bar over [vmin, vmax] (pixels without
    SSS, count 0, drawn black)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    c = np.asarray(counts, dtype=np.float64)
    h, w = c.shape
    cmap = plt.get_cmap("viridis").with_extremes(bad="black")
    fig, ax = plt.subplots(figsize=(max(3.0, 3.0 * w / h + 1.0), 3.0), dpi=100)
    im = ax.imshow(np.ma.masked_where(c <= 0, c), cmap=cmap, vmin=vmin, vmax=vmax, interpolation="nearest")
    ax.set_axis_off()
    if title:
        ax.set_title(title, fontsize=8)
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label="samples per pixel")
    p = Path(path)
    with atomic_output(p) as tmp:
        fig.savefig(tmp, format="png", bbox_inches="tight")
    plt.close(fig)
    return p


__all__ = ["save_frame_png", "save_heatmap_png"]
