"""The screen-space figure: every built-in scene with several kernels, the exact 2D convolution and a
path-traced reference, with error numbers (used by ``ssskit demo``)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

#: (label, kernel spec, taps, tap placement) shown per scene
SCREEN_SPACE_METHODS = (
    ("pre-integrated, 7 IS taps", "preintegrated", 7, "importance"),
    ("pre-integrated, 7 uniform taps", "preintegrated", 7, "uniform"),
    ("artist (two-Gaussian), 7 IS taps", "artist", 7, "importance"),
    ("Jimenez 2012 engine, 11 taps", "jimenez2012", 11, "importance"),
)


def screen_space_comparison(out: Path, material: str = "skin1", scenes=None, width: int = 160, height: int = 120,
                            spp: int = 16, reference_spp: int = 32, progress: Callable[[str], None] | None = None):
    """Render every scene with :data:`SCREEN_SPACE_METHODS`; write ``screenspace.png``.

    Returns (png path, rows) with rows = [{scene, method, vs exact {psnr, flip}, vs path-traced {...}}].
    """
    from ..plots import _pyplot, save_figure
    from ..metrics import tonemap
    from ..render import region_metrics, render
    from ..scenes.render3d import SCENES

    say = progress or (lambda msg: None)
    scenes = list(scenes or SCENES.names())
    rows, grid = [], []
    for scene in scenes:
        line, base = [], None
        for label, spec, taps, placement in SCREEN_SPACE_METHODS:
            say(f"screen space: {scene}, {label}")
            # the first method renders the scene (G-buffer, exact 2D, path trace); the others reuse it
            r = render(scene if base is None else base.gbuffer, material, spec, taps=taps, tap_method=placement,
                       jitter=0.1, width=width, height=height, spp=spp, exact=base is None, reference=base is None,
                       reference_spp=reference_spp, progress=None)
            if base is None:
                base = r
                line.append(("no SSS", r.gbuffer.composite()))
            row = {"scene": scene, "method": label}
            if base.exact is not None:
                row["exact_2d"] = region_metrics(r.gbuffer.composite(base.exact), r.image, r.gbuffer.mask)
            row["path_traced"] = region_metrics(base.reference, r.image, r.gbuffer.mask)
            rows.append(row)
            line.append((label, r.image))
        if base.exact is not None:
            line.append(("exact 2D convolution", base.gbuffer.composite(base.exact)))
        else:
            line.append(("exact 2D (non-square pixels)", np.zeros_like(base.image)))
        line.append(("path traced (volpathmis)", base.reference))
        grid.append((scene, line))
    plt = _pyplot()
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
