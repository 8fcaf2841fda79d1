"""What each difference of the region table is, measured by controlled path-traced experiments
(:mod:`lab.attribution`: transmission, grazing Fresnel, curvature), as a plot of exact 2D / reference
per region and setup, and a table (``python experiments/region_attribution.py --plot FILE.png``).

The numbers are computed once per (material, photons, spp, image size) and stored
(:func:`ssskit.figures.stored.stored`, ``cache_dir("figures")``); :func:`cached_attribution` reads them
without computing anything. The results are recorded in experiments/RESULTS.md.
"""

from __future__ import annotations

import html
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ssskit.materials import CHANNELS
from .attribution import ATTRIBUTION_REGIONS
from ssskit.figures.plots import CHANNEL_COLORS, pyplot, save_figure
from ssskit.figures.stored import peek, stored

#: (experiment, scene) pairs of the figure (experiments/region_attribution.py's default run)
ATTRIBUTION_RUNS = (("transmission", "ear"), ("transmission", "sphere"), ("fresnel", "sphere"), ("fresnel", "ear"),
                    ("fresnel", "bumpy"), ("curvature", "sphere"), ("curvature", "bumpy"))
#: the curvature experiment's scale factors (the first is the scene as built)
CURVATURE_FACTORS = (1.0, 2.0, 4.0, 8.0)
#: bumped when what the stored numbers hold changes
_VERSION = 1


def _key(material: str, photons: int, spp: int, width: int, height: int) -> dict:
    return dict(material=material.lower(), photons=int(photons), spp=int(spp), w=int(width), h=int(height),
                runs=ATTRIBUTION_RUNS, factors=CURVATURE_FACTORS, v=_VERSION)


#: reference samples per pixel per setup (the same in every setup of a run)
ATTRIBUTION_SPP = 1024


def attribution_data(material: str = "skin1", photons: int = 200_000, spp: int = ATTRIBUTION_SPP, width: int = 160,
                     height: int = 120, progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Every run of :data:`ATTRIBUTION_RUNS` (:func:`lab.attribution.run_experiment`), stored."""

    def make() -> dict[str, Any]:
        from .attribution import experiment_setups, run_experiment

        runs = []
        for exp, scene in ATTRIBUTION_RUNS:
            if progress is not None:
                progress(f"region attribution: {exp} on {scene}")
            t0 = time.perf_counter()
            setups = experiment_setups(exp, scene, material, CURVATURE_FACTORS)
            res = run_experiment(setups, width=width, height=height, spp=spp, photons=photons, progress=progress)
            runs.append({"experiment": exp, "scene": scene, "seconds": round(time.perf_counter() - t0, 1), **res})
        return {"material": material, "photons": photons, "spp": spp, "runs": runs}

    return stored("figures", "region_attribution", _key(material, photons, spp, width, height), make)


def cached_attribution(material: str = "skin1", photons: int = 200_000, spp: int = ATTRIBUTION_SPP, width: int = 160,
                       height: int = 120) -> dict[str, Any] | None:
    """The stored numbers of :func:`attribution_data` with these settings, or None (nothing computed)."""
    return peek("figures", "region_attribution", _key(material, photons, spp, width, height))


def _fmt(pair, digits: int = 3) -> str:
    return ", ".join(f"{v:.{digits}f} ± {e:.{digits}f}" for v, e in zip(pair["value"], pair["se"]))


def attribution_table_html(data: dict[str, Any]) -> str:
    """An HTML table: per run, region and setup the reference's level, exact / reference, that ratio
    relative to the plateau's, and against the run's first setup the reference ratio and the share of
    the gap (reference - exact) removed; every number R, G, B ± its standard error."""
    head = ("<table><tr><th>experiment</th><th>scene</th><th>region</th><th>setup</th><th>path traced ± SE</th>"
            "<th>exact / path traced</th><th>... / the plateau's (none: the object's)</th><th>path traced / first setup's</th>"
            "<th>share of the gap removed</th></tr>")
    rows = []
    for run in data["runs"]:
        for name in ATTRIBUTION_REGIONS:
            if not run["regions"].get(name):
                continue
            for k, s in enumerate(run["setups"]):
                cell = s["regions"][name]
                vs = s.get("vs_first", {}).get(name)
                rel = cell.get("exact_over_reference_vs_plateau") or cell.get("exact_over_reference_vs_object")
                rows.append(
                    f"<tr><td class=name>{run['experiment'] if k == 0 else ''}</td>"
                    f"<td class=name>{html.escape(run['scene']) if k == 0 else ''}</td>"
                    f"<td class=name>{name if k == 0 else ''}</td><td class=name>{html.escape(s['label'])}</td>"
                    f"<td>{_fmt(cell['path_traced'])}</td><td>{_fmt(cell['exact_over_reference'])}</td>"
                    f"<td>{_fmt(rel) if rel else '-'}</td>"
                    f"<td>{_fmt(vs['reference_ratio']) if vs else '-'}</td>"
                    f"<td>{_fmt(vs['gap_removed'], 2) if vs else '-'}</td></tr>")
    return head + "".join(rows) + "</table>"


def plot_attribution(data: dict[str, Any], path: str | Path) -> None:
    """One panel per run: exact 2D / path traced (± 2 SE) per region (x) and setup (marker), R, G, B."""
    plt = pyplot()
    runs = data["runs"]
    ncol = 4
    nrow = -(-len(runs) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.4 * nrow), squeeze=False)
    markers = "osD^v"
    for ax, run in zip(axes.flat, runs):
        names = [n for n in ATTRIBUTION_REGIONS if run["regions"].get(n)]
        nset = len(run["setups"])
        for k, s in enumerate(run["setups"]):
            for c in range(3):
                x = np.arange(len(names)) + (k - (nset - 1) / 2) * 0.22 + (c - 1) * 0.06
                y = [s["regions"][n]["exact_over_reference"]["value"][c] for n in names]
                e = [2 * s["regions"][n]["exact_over_reference"]["se"][c] for n in names]
                ax.errorbar(x, y, yerr=e, fmt=markers[k % len(markers)], color=CHANNEL_COLORS[c], ms=4,
                            mfc="white" if k else CHANNEL_COLORS[c], lw=0.8,
                            label=s["label"] if c == 0 else None)
        ax.axhline(1.0, color="0.6", lw=0.8)
        ax.set_xticks(np.arange(len(names)))
        ax.set_xticklabels([n.replace("_", " ") for n in names], fontsize=8)
        ax.set_yscale("log")
        ax.set_title(f"{run['experiment']}: {run['scene']}", fontsize=9)
        ax.legend(fontsize=6, loc="best")
        ax.grid(alpha=0.3, which="both")
    for ax in axes.flat[len(runs):]:
        ax.axis("off")
    axes[0, 0].set_ylabel("exact 2D / path traced (± 2 SE)")
    fig.suptitle(f"What each region's difference is ({data['material']}, Monte Carlo profile, "
                 f"{data['spp']} spp per setup; colours {', '.join(CHANNELS)}; filled: first setup)", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)


__all__ = ["ATTRIBUTION_RUNS", "ATTRIBUTION_SPP", "CURVATURE_FACTORS", "attribution_data", "attribution_table_html",
           "cached_attribution", "plot_attribution"]
