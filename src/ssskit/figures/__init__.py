"""The papers' figures, reproduced; each is ``fn(out_dir, profile, progress) -> list of written paths``.

    ssskit figures [NAME...] [--material skin1] [--model montecarlo] [--backend numba] [--out DIR]

A figure that runs a screen-space pass takes a ``backend`` keyword (see :func:`runs_a_pass`).
"""

from __future__ import annotations

import inspect
from pathlib import Path
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Callable

from ..errors import SsskitError
from ..registry import Registry
from . import adaptive as _a
from . import burley as _b
from . import head as _h
from . import kernels as _k
from . import views as _v

if TYPE_CHECKING:
    from ..profiles.base import RGBProfile

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
FIGURES.register("xie-fig5", _b.fig5_xie_c)
FIGURES.register("xie-fig1", _v.xie_fig1)
FIGURES.register("head-fig7", _h.head_fig7)
FIGURES.register("head-fig9", _h.head_fig9)
FIGURES.register("head-separable", _h.head_separable)


def runs_a_pass(fn: Figure) -> bool:
    """Whether figure ``fn`` runs a screen-space pass (it then takes ``backend=``)."""
    return "backend" in inspect.signature(fn).parameters


def renders_a_scene(fn: Figure) -> bool:
    """Whether figure ``fn`` renders a scene of the user's choice (it then takes ``scene=``, ``units=``,
    ``material_map=`` and ``material=``)."""
    return "scene" in inspect.signature(fn).parameters


def make_figures(names: Sequence[str], out_dir: str | Path, profile: RGBProfile | None,
                 progress: Callable[[str], None] | None = None, backend: str | None = None,
                 scene: dict[str, Any] | None = None) -> dict[str, list[Path]]:
    """Build the named figures (all when ``names`` is empty) for ``profile`` into ``out_dir``; the figures
    that run a screen-space pass run it on ``backend`` (default: ssskit's default backend); those that
    render a scene (:func:`renders_a_scene`) take the keywords of ``scene`` (scene, units, material_map,
    material)."""
    chosen = [FIGURES.get(n) for n in names] if names else [f for _, f in FIGURES.items()]
    labels = list(names) if names else FIGURES.names()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    result: dict[str, list[Path]] = {}
    for label, fn in zip(labels, chosen):
        if progress is not None:
            progress(f"figure {label}")
        kw = {"backend": backend} if backend is not None and runs_a_pass(fn) else {}
        if scene and renders_a_scene(fn):
            kw.update(scene)
        result[label] = fn(out, profile, progress, **kw)
    return result


__all__ = ["FIGURES", "make_figures", "renders_a_scene", "runs_a_pass"]
