"""The papers' figures, reproduced; each is ``fn(out_dir, profile, progress) -> list of written paths``.

    ssskit figures [NAME...] [--material skin1] [--model montecarlo] [--out DIR]
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from ..errors import SsskitError
from ..registry import Registry
from . import adaptive as _a
from . import burley as _b
from . import kernels as _k

Figure = Callable[..., list[Path]]
FIGURES: Registry[Figure] = Registry("figure", SsskitError)
FIGURES.register("fig2", _k.fig2_singular_values)
FIGURES.register("fig4", _k.fig4_svd_ranks)
FIGURES.register("fig5", _k.fig5_slices)
FIGURES.register("fig7", _k.fig7_step)
FIGURES.register("figS5", _k.figS5_disk)
FIGURES.register("xie-fig2", _a.xie_fig2_cold_start)
FIGURES.register("xie-fig3", _a.xie_fig3_disocclusion)
FIGURES.register("xie-fig4", _a.xie_fig4)
FIGURES.register("xie-fig10", _a.xie_fig10)
FIGURES.register("xie-fig11", _a.xie_fig11)
FIGURES.register("xie-fig13", _a.xie_fig13)
FIGURES.register("xie-table1", _a.xie_table1)

FIGURES.register("xie-fig6", _b.fig6_xie_inverse)


def make_figures(names, out_dir, profile, progress=None) -> dict[str, list[Path]]:
    """Build the named figures (all when ``names`` is empty) for ``profile`` into ``out_dir``."""
    chosen = [FIGURES.get(n) for n in names] if names else [f for _, f in FIGURES.items()]
    labels = list(names) if names else FIGURES.names()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    result = {}
    for label, fn in zip(labels, chosen):
        if progress is not None:
            progress(f"figure {label}")
        result[label] = fn(out, profile, progress)
    return result


__all__ = ["FIGURES", "make_figures"]
