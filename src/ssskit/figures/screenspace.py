"""The screen-space figure: every built-in scene with several kernels, the exact 2D convolution and a
path-traced reference, with error numbers (used by ``ssskit demo``)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from ..metrics import region_metrics, tonemap
from ..pipeline import RenderSettings, render
from ..scenes import SCENES
from ..screenspace import PassSettings
from .plots import pyplot, save_figure

#: (label, kernel spec, taps, tap placement) shown per scene
SCREEN_SPACE_METHODS = (
    ("pre-integrated, 7 IS taps", "preintegrated", 7, "importance"),
    ("pre-integrated, 7 uniform taps", "preintegrated", 7, "uniform"),
    ("artist (two-Gaussian), 7 IS taps", "artist", 7, "importance"),
    ("Jimenez 2012 engine, 11 taps", "jimenez2012", 11, "importance"),
)


def screen_space_comparison(out: Path, material: str = "skin1", scenes=None, width: int = 160, height: int = 120,
                            spp: int = 16, reference_spp: int = 32, progress: Callable[[str], None] | None = None,
                            sss: PassSettings | None = None):
    """Render every scene with :data:`SCREEN_SPACE_METHODS`; write ``screenspace.png``.

    Each scene's G-buffer, exact 2D convolution and path trace are made once (with the first method)
    and shared by the others. ``sss``: the pass settings (default: 10% jitter).
    Returns (png path, rows) with rows = [{scene, method, exact_2d {psnr, flip...}, path_traced {...}}].
    """
    say = progress or (lambda msg: None)
    sss = PassSettings(jitter=0.1) if sss is None else sss
    scenes = list(scenes or SCENES.names())
    rows, grid = [], []
    for scene in scenes:
        line, base = [], None
        for label, spec, taps, placement in SCREEN_SPACE_METHODS:
            say(f"screen space: {scene}, {label}")
            first = base is None
            settings = RenderSettings(material=material, kernel=spec, taps=taps, tap_method=placement,
                                      width=width, height=height, spp=spp, exact=first, reference=first,
                                      reference_spp=reference_spp, sss=sss)
            r = render(scene if first else base.gbuffer, settings)
            if first:
                base = r
                line.append(("no SSS", r.gbuffer.composite()))
            mask = r.gbuffer.mask
            row = {"scene": scene, "method": label}
            if base.exact is not None:
                row["exact_2d"] = r.metrics["exact_2d"] if first else region_metrics(
                    r.gbuffer.composite(base.exact), r.image, mask)
            row["path_traced"] = r.metrics["path_traced"] if first else region_metrics(base.reference, r.image, mask)
            rows.append(row)
            line.append((label, r.image))
        if base.exact is not None:
            line.append(("exact 2D convolution", base.gbuffer.composite(base.exact)))
        else:
            line.append(("exact 2D (non-square pixels)", np.zeros_like(base.image)))
        line.append(("path traced (volpathmis)", base.reference))
        grid.append((scene, line))
    plt = pyplot()
    ncol = max(len(line) for _, line in grid)
    fig, axes = plt.subplots(len(grid), ncol, figsize=(2.6 * ncol, 2.1 * len(grid)), squeeze=False)
    for r, (scene, line) in enumerate(grid):
        peak = float(np.percentile(line[-1][1], 99.5)) or 1.0
        for c in range(ncol):
            ax = axes[r, c]
            ax.axis("off")
            if c < len(line):
                ax.imshow(tonemap(line[c][1], peak))
                ax.set_title(f"{scene}: {line[c][0]}" if c == 0 else line[c][0], fontsize=7)
    fig.suptitle(f"Screen-space separable SSS, {material}; tone-mapped to each scene's path-traced peak", fontsize=9)
    path = Path(out) / "screenspace.png"
    save_figure(fig, path)
    return path, rows
