"""The ``ssskit demo`` report: an output folder with figures and an ``index.html`` that shows them.

The report is a list of sections; each capability of ssskit adds its own section builder to
``SECTIONS``. A builder gets the output folder and a progress callback and returns HTML.
"""

from __future__ import annotations

import html
import json
import math
import os
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .backends import DEFAULT_BACKEND
from .io import write_text
from .materials import CHANNELS, MATERIALS, Material
from .quantities import Quantity

if TYPE_CHECKING:
    from .backends.base import Backend
    from .profiles.base import RadialProfile, RGBProfile

Progress = Callable[[str], None]
Section = Callable[[Path, Progress, dict], str]

#: photons per channel of the demo's Monte Carlo profiles: supplement F's 10^7, the shipped profiles
#: (:mod:`ssskit.profiles.montecarlo.shipped`); ``ssskit demo --full`` simulates them instead
DEMO_PHOTONS = 10_000_000
#: worker processes of one report (``ssskit demo --jobs``)
JOBS = Quantity("jobs", 1, math.inf, "", "worker processes of one report", integer=True, hi_open=True)

_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1400px; color: #222; }
table { border-collapse: collapse; font-size: 0.85em; margin: 1em 0; }
th, td { border: 1px solid #ccc; padding: 3px 7px; text-align: right; }
th { background: #f3f3f3; } td.name { text-align: left; font-weight: 600; }
img { max-width: 100%; border: 1px solid #eee; margin: 0.5em 0; }
h2 { border-bottom: 2px solid #ddd; padding-bottom: 0.2em; margin-top: 2em; }
.note { color: #555; font-size: 0.9em; }
tr.best td { background: #e8f5e9; font-weight: 600; }
tr.scene td { background: #f7f7f7; font-style: italic; }
"""


def _fmt(values: Iterable[float], digits: int = 4) -> str:
    return ", ".join(f"{v:.{digits}g}" for v in values)


def _burley_d(channel: RadialProfile) -> float:
    """A Burley channel's d (mm)."""
    from .profiles.burley import BurleyProfile

    assert isinstance(channel, BurleyProfile)  # burley_profile's channels
    return channel.d


def _materials_section(out: Path, progress: Progress, ctx: dict) -> str:
    from .profiles import burley_profile, dipole_profile

    rows = []
    for name, m in MATERIALS.items():
        dip = dipole_profile(m)
        bur = burley_profile(m, photons=ctx.get("photons", DEMO_PHOTONS))
        rows.append(
            f"<tr><td class=name><a href='#{name}'>{html.escape(name)}</a></td>"
            f"<td>{_fmt(m.sigma_a)}</td><td>{_fmt(m.sigma_s)}</td><td>{m.eta:g}</td>"
            f"<td>{_fmt(m.albedo)}</td><td>{_fmt(m.mfp_mm)}</td><td>{_fmt(m.sigma_tr)}</td>"
            f"<td>{_fmt(dip.total_rd())}</td><td>{_fmt([_burley_d(c) for c in bur.channels])}</td></tr>"
        )
    return (
        "<h2>Materials</h2><p class=note>The 11 measured materials of the separable-SSS supplement, "
        "section G (g = 0, semi-infinite). Coefficients in mm<sup>-1</sup>, lengths in mm, values R, G, B.</p>"
        "<table><tr><th>material</th><th>σ<sub>a</sub></th><th>σ<sub>s</sub></th><th>η</th>"
        "<th>albedo α</th><th>mean free path</th><th>σ<sub>tr</sub></th><th>dipole total R<sub>d</sub></th>"
        "<th>Burley d (searchlight)</th></tr>" + "".join(rows) + "</table>"
    )


def _profiles_section(out: Path, progress: Progress, ctx: dict) -> str:
    from .figures.plots import plot_kernel_2d, plot_profiles
    from .profiles import profile_for_material
    from .profiles.montecarlo import montecarlo_rgb

    photons = ctx.get("photons", DEMO_PHOTONS)

    parts = [
        "<h2>Diffusion profiles</h2><p class=note>Per material: the [JMLH01] dipole (solid), Burley's "
        "normalized diffusion with A = the Monte Carlo total R<sub>d</sub> (the dipole's albedo error against MCML is the dipole's model error; compare the totals below) and d from the searchlight configuration "
        "(Xie 2020 Eq. 5; dashed), and six Gaussians fitted to the dipole under the L1 constraint (Eq. S.1; "
        f"dotted), and the MCML simulation with supplement F's grid, {photons:,} photons per channel "
        "(dash-dot; cached on disk). Left to right: R(r), R(r) on a log scale, and 2πr R(r) as in the supplement's plots. "
        "Below: the dipole's 2D kernel R<sub>d</sub>(x, y) as exact cell integrals.</p>"
    ]
    for name, m in MATERIALS.items():
        progress(f"profiles: {name}")
        profs = [profile_for_material(m, "dipole"), profile_for_material(m, "burley", photons=photons),
                 profile_for_material(m, "gaussians")]
        progress(f"Monte Carlo: {name} ({photons:,} photons per channel)")
        profs.append(montecarlo_rgb(m, photons=photons, progress=ctx.get("progress_bars", False)))
        fig = f"profile_{name.lower()}.png"
        plot_profiles(profs, f"{name}: σa = [{_fmt(m.sigma_a)}], σs = [{_fmt(m.sigma_s)}] mm⁻¹, η = {m.eta:g}", out / fig)
        parts.append(f"<h3 id='{name}'>{html.escape(name)}</h3>{_totals_table(m, profs)}<img src='{fig}'>")
        fig2 = f"kernel2d_{name.lower()}.png"
        r99 = float(np.max(profs[0].radius_at_fraction(0.99)))
        n = 201
        cells = profs[0].discretize_2d(2 * r99 / n, n)
        plot_kernel_2d(cells, 2 * r99 / n, f"{name}: dipole Rd(x, y), {n}×{n} cells of {2 * r99 / n:.3g} mm", out / fig2)
        parts.append(f"<img src='{fig2}'>")
    return "".join(parts)


def _totals_table(m: Material, profs: Sequence[RGBProfile]) -> str:
    head = "".join(f"<th>{c}</th>" for c in CHANNELS)
    rows = "".join(
        f"<tr><td class=name>{p.model}</td>"
        + "".join(f"<td>{v:.5f}</td>" for v in p.total_rd())
        + "".join(f"<td>{v:.4g}</td>" for v in p.radius_at_fraction(0.99))
        + "</tr>"
        for p in profs
    )
    return (
        f"<table><tr><th>model</th>{head.replace('<th>', '<th>total R<sub>d</sub> ')}"
        f"{head.replace('<th>', '<th>r<sub>99%</sub> [mm] ')}</tr>{rows}</table>"
    )


def _sampling_section(out: Path, progress: Progress, ctx: dict) -> str:
    from .figures.plots import plot_xie_c
    from .sampling import XIE_C, fit_xie_c, xie_cdf_error

    progress("Burley sampling: refitting c")
    c_lsq, err_lsq = fit_xie_c("lsq")
    c_mm, err_mm = fit_xie_c("minimax")
    err_paper = float(np.max(np.abs(xie_cdf_error(XIE_C))))
    plot_xie_c(out / "xie_c.png", c_minimax=c_mm)
    return (
        "<h2>Burley sampling (Xie 2020 Sec. 4.2)</h2><p class=note>Approximate inverse CDF "
        "g(ξ) = d((2−c)ξ−2) log(1−ξ) (Eq. 21) against the exact inverse of Eq. 20.</p>"
        "<table><tr><th>c</th><th>criterion</th><th>max |cdf(g(ξ)) − ξ|</th></tr>"
        f"<tr><td>{XIE_C}</td><td class=name>paper</td><td>{err_paper:.5f}</td></tr>"
        f"<tr><td>{c_lsq:.5f}</td><td class=name>least squares (refit)</td><td>{err_lsq:.5f}</td></tr>"
        f"<tr><td>{c_mm:.5f}</td><td class=name>minimax</td><td>{err_mm:.5f}</td></tr></table>"
        "<img src='xie_c.png'>"
    )


#: the kernel methods the report ranks, and the test signals it ranks them on
RANKED_METHODS = ["svd:1", "svd:3", "gaussians:1", "gaussians:6", "preintegrated", "preintegrated_svd:1", "guided:0",
                  "guided:2", "artist:fit", "jimenez2012", "burley_fit"]
RANK_SIGNALS = ("edge", "edge-rotated", "disk", "texture")
#: the materials the report ranks the kernels for unless ``ssskit demo --material`` names others: all 11
RANK_MATERIALS = tuple(MATERIALS.names())
#: the test signals' size (pixels per side) of the demo's ranking: 128 ranks the 11 materials in ~7 CPU s each
#: (256: ~17 s each; measured 2026-12-06 at load ~18 on 2 cores), the kernel's 99.9% radius still ~21 pixels
RANK_SIZE = 128


def kernel_ranking(profile: RGBProfile, methods: list[str] = RANKED_METHODS, signals: tuple[str, ...] = RANK_SIGNALS,
                   progress: Progress | None = None,
                   size: int = 256) -> list[tuple[str, dict[str, dict[str, Any]], float]]:
    """Each method's error against the exact 2D convolution (the kernel's error, not the model's) on
    each signal of ``size`` x ``size`` pixels, ranked by the mean relative RMSE over the signals: a list of
    (method, {signal: metrics}, mean relative RMSE), best first."""
    from .pipeline.evaluate import evaluate

    res = {}
    for sig in signals:
        if progress is not None:
            progress(f"kernel ranking, {profile.name}: {sig}")
        res[sig] = evaluate(profile, sig, methods, size=size, perceptual=("flip",)).results
    rows = [(m, {sig: res[sig][m] for sig in signals}, float(np.mean([res[sig][m]["relative_rmse"] for sig in signals])))
            for m in methods]
    return sorted(rows, key=lambda row: row[2])


def _ranking_table(profile: RGBProfile, rows: list[tuple[str, dict[str, dict[str, Any]], float]],
                   signals: tuple[str, ...] = RANK_SIGNALS) -> str:
    head = "".join(f"<th>{s}<br>rel. RMSE / FLIP</th>" for s in signals)
    body = []
    for k, (m, per, mean) in enumerate(rows, 1):
        best = k == 1
        cells = "".join(f"<td>{per[s]['relative_rmse']:.2e} / {per[s]['flip']:.3f}</td>" for s in signals)
        body.append(f"<tr{' class=best' if best else ''}><td>{k}{' ★' if best else ''}</td>"
                    f"<td class=name>{html.escape(m)}{' (best)' if best else ''}</td>"
                    f"<td>{per[signals[0]]['convolutions_1d']}</td>{cells}<td><b>{mean:.2e}</b></td></tr>")
    return (f"<h3 id='rank-{html.escape(profile.name.lower())}'>{html.escape(profile.name)}</h3>"
            f"<table><tr><th>rank</th><th>method</th><th>1D conv.</th>{head}<th>mean rel. RMSE</th></tr>"
            + "".join(body) + "</table>")


def _head_section(out: Path, progress: Progress, ctx: dict) -> str:
    """The report's opening: Skin1 on the scanned head with the kernel the ranking recommends for it, against
    the path trace per region (:func:`ssskit.figures.screenspace.head_opener`; the path traces' numbers shipped)."""
    from .figures.screenspace import HEAD_NUMBERS, head_opener
    from .profiles import profile_for_material

    backend = ctx.get("backend", DEFAULT_BACKEND)
    progress("the head: ranking the kernels for Skin1")
    ranking = kernel_ranking(profile_for_material("Skin1", "montecarlo", photons=ctx.get("photons", DEMO_PHOTONS)),
                             progress=progress, size=RANK_SIZE)
    best = ranking[0][0]
    png, data = head_opener(out / "figures", best, backend=backend, progress=progress)
    body = []
    for row in data["rows"]:
        for region, r in row["regions"].items():
            lev, ref, se = (np.asarray(r[k], float) for k in ("screen_space", "path_traced", "path_traced_se"))
            z = (lev - ref) / se
            body.append(f"<tr><td class=name>{html.escape(row['view'])}</td><td class=name>"
                        f"{html.escape(region.replace('_', ' '))}</td><td>{r['pixels']}</td><td>{_fmt(lev, 3)}</td>"
                        "<td>" + ", ".join(f"{a:.3f} ± {e:.3f}" for a, e in zip(ref, se)) + "</td>"
                        f"<td>{_fmt(lev / ref, 3)}</td><td>{', '.join(f'{v:+.1f}' for v in z)}</td></tr>")
    table = ("<table><tr><th>view</th><th>region</th><th>pixels</th><th>kernel's level (R, G, B)</th>"
             "<th>path traced ± SE</th><th>kernel / path traced</th><th>difference in SE</th></tr>"
             + "".join(body) + "</table>") if body else (
        f"<p class=note>The shipped head numbers have no row for {html.escape(best)}: the figure shows the "
        "render alone.</p>")
    return (
        f"<h2 id=head>The head: Skin1 with the recommended kernel ({html.escape(best)}) against the path trace</h2>"
        f"<p class=note>Left: the scanned head (front view, Skin1, the Monte Carlo profile), rendered now by the "
        f"separable pass with the kernel the ranking below recommends for Skin1 ({html.escape(best)}, 7 "
        f"importance-sampled taps, on the {html.escape(backend)} backend). Right: per view and region, that "
        "kernel's level (mean diffuse part over E/&pi;) over the volumetric path trace's, with ± 2 standard "
        "errors of the path trace: a point whose bar crosses 1 agrees with the truth within its noise. These "
        f"numbers are <b>shipped, not computed by this demo</b>: the path traces ({data['size'][0]}x"
        f"{data['size'][1]}, ~3000 spp, ~6 min per view on 2 cores) are made by <code>python docs/head_numbers.py "
        f"--sections separable</code> (<code>ssskit figures head-separable</code> shows their images), copied to "
        f"the package's <code>{html.escape(HEAD_NUMBERS.name)}</code>. {html.escape(data['attribution'])}.</p>"
        f"<img src='figures/{png.name}'>" + table
    )


#: the live viewer in the report: its scene, its material (``ssskit view --out`` precomputes only it: the demo's time)
#: and the page's size in the report's frame
VIEWER_SCENE, VIEWER_MATERIAL, VIEWER_SIZE = "head", "skin1", (640, 360)


def _viewer_section(out: Path, progress: Progress, ctx: dict) -> str:
    """The live viewer of the head with Skin1, embedded: the static folder ``viewer/`` written by the code of
    ``ssskit view --scene head --material skin1 --presets none --out DIR`` (:func:`ssskit.view.site.write_static`)
    and shown in a frame (a page opened from ``file://`` may frame a page beside it)."""
    from .view.site import MaterialRequest, write_static

    progress(f"the live viewer: the {VIEWER_SCENE} with {VIEWER_MATERIAL} (ssskit view --out)")
    t0 = time.perf_counter()
    dest = write_static(out / "viewer", VIEWER_SCENE, {VIEWER_MATERIAL: MaterialRequest(VIEWER_MATERIAL)},
                        VIEWER_MATERIAL)
    seconds = time.perf_counter() - t0
    w, h = VIEWER_SIZE
    src = f"{dest.name}/index.html?w={w}&h={h}"
    return (
        "<h2 id=viewer>Live: the head with Skin1 in your browser (WebGL2)</h2>"
        f"<p class=note>The page of <code>ssskit view --scene {VIEWER_SCENE} --material {VIEWER_MATERIAL} --out DIR"
        f"</code>, written into <code>{dest.name}/</code> ({seconds:.1f} s): a G-buffer pass, then the separable, "
        "Burley, adaptive and transmittance passes as the GLSL ES 3.00 fragment shaders <code>ssskit export</code> "
        "writes, composite and tone mapping, with per-pass frame times. Drag to orbit; the controls change the "
        "pass, spp, light, split view and transmission. Only Skin1 is precomputed here (<code>ssskit view</code> "
        "itself serves any material). A browser without WebGL2 shows why in the frame; "
        f"<a href='{html.escape(src)}'>open it alone</a>.</p>"
        f"<iframe src='{html.escape(src)}' title='ssskit view: the head with Skin1' width={w + 340} height={h + 40} "
        "style='border: 1px solid #ccc'></iframe>"
    )


def _kernels_section(out: Path, progress: Progress, ctx: dict) -> str:
    from .figures import FIGURES, make_figures
    from .profiles import profile_for_material

    names = ctx.get("materials") or RANK_MATERIALS
    ranked: list[tuple[RGBProfile, list[tuple[str, dict[str, dict[str, Any]], float]]]] = []
    for name in names:  # (every material checked by the CLI before any work: none is left out)
        progress(f"kernel ranking: {name}")
        prof = profile_for_material(name, "montecarlo", photons=ctx["photons"])
        ranked.append((prof, kernel_ranking(prof, progress=progress, size=RANK_SIZE)))
    summary = "".join(
        f"<tr><td class=name><a href='#rank-{html.escape(p.name.lower())}'>{html.escape(p.name)}</a></td>"
        f"<td class=name>{html.escape(rows[0][0])}</td><td>{rows[0][2]:.2e}</td>"
        f"<td>{rows[0][1][RANK_SIGNALS[0]]['convolutions_1d']}</td>"
        f"<td class=name>{html.escape(rows[1][0])}</td><td>{rows[1][2]:.2e}</td>"
        f"<td class=name>{html.escape(rows[-1][0])}</td><td>{rows[-1][2]:.2e}</td></tr>"
        for p, rows in ranked)
    tables = "".join(_ranking_table(p, rows) for p, rows in ranked)
    # the paper's kernel figures for Skin1 (the adaptive sampler's have their own section; the
    # three-view study takes minutes on a life-size bust: ssskit figures xie-fig1, its table in RESULTS.md)
    figs = [n for n, fn in FIGURES.items() if fn.__module__ == "ssskit.figures.kernels"]
    shown = next((p for p, _ in ranked if p.name.lower() == "skin1"), ranked[0][0])  # the papers' skin if ranked
    written = make_figures(figs, out / "figures", shown, progress=progress, backend=ctx.get("backend"))
    imgs = "".join(f"<img src='figures/{p.name}'>" for paths in written.values() for p in paths)
    return (
        "<h2 id=kernels>Which kernel for my material? (separable-SSS paper Secs. 3-5, supplement B-D)</h2>"
        f"<p class=note>Per material, every kernel method ranked by its error against the exact 2D convolution "
        f"E * Rd of the same Monte Carlo profile (supplement F, {ctx['photons']:,} photons per channel): the "
        f"<b>kernel's</b> error alone, on {RANK_SIZE}x{RANK_SIZE} test signals ({', '.join(RANK_SIGNALS)}) whose "
        "kernel radius (99.9% of the energy) spans 1/6 of the image; ranked by the mean relative RMSE over the "
        f"{len(RANK_SIGNALS)} signals, the best marked ★. The grid matters where two kernels are close: at "
        "256x256 (<code>ssskit.report.kernel_ranking(profile, size=256)</code>, ~2.5x the time) Skin1's first two "
        "swap (gaussians:6 4.4e-3, preintegrated_svd:1 6.0e-3; at 128: 4.6e-3 and 4.0e-3; measured 2026-12-06). "
        "How far the profile itself is from the light transport is the model's error: next section, per "
        "region.</p>"
        f"<h3>The answer: the kernel to ship, {len(ranked)} of {len(names)} materials ranked</h3>"
        "<table><tr><th>material</th><th>recommended kernel</th><th>mean rel. RMSE</th><th>1D conv.</th>"
        "<th>runner-up</th><th>mean rel. RMSE</th><th>worst</th><th>mean rel. RMSE</th></tr>"
        + summary + "</table>"
        + tables
        + f"<h3>The paper's kernel figures, {html.escape(shown.name)}</h3>" + imgs
    )


def _level_cells(row: dict[str, Any], key: str, ref: bool | None = None) -> str:
    if key not in row or row[key]["level"] is None:
        return "<td>-</td>"
    lev = row[key]["level"]
    if ref is None or row[key].get("se") is None:
        return "<td>" + ", ".join(f"{v:.3f}" for v in lev) + "</td>"
    return "<td>" + ", ".join(f"{v:.3f} ± {e:.3f}" for v, e in zip(lev, row[key]["se"])) + "</td>"


#: the measured cause of the model's error per (scene, region), stored by the lab's controlled experiments
#: (experiments/RESULTS.md, "What the differences are"); a region missing here links to the experiments
MEASURED_CAUSES: dict[tuple[str, str], str] = {
    ("ear", "silhouette"): "transmission: a black backing behind the unseen surface closes 99-103% of the gap "
                           "(the key light is behind the ear); backed, the red excess is the ear's thickness "
                           "(x 1.145 ± 0.016) and the screen-space projection (x 1.054)",
    ("ear", "shadow_edge"): "transmission: a black backing closes 84-101% of the gap",
    ("sphere", "terminator"): "curvature and grazing-incidence Fresnel cancel (scaled 8x the reference loses "
                              "20%, 13%, 10%)",
    ("sphere", "silhouette"): "curvature: scaled 8x, the reference loses 4-6% and agrees with the model within 2%",
    ("bumpy", "silhouette"): "red: curvature of the relief (scaled 8x, 93 ± 3% of the gap closes); G, B: the flat "
                             "medium at the tile's angles (1.010, 1.014, 1.007 ± 0.012 left)",
    ("bumpy", "shadow_edge"): "red: curvature of the relief (scaled 8x, 76 ± 7% of the gap closes)",
    ("slab", "plateau"): "oblique incidence (23°), the non-Lambertian exit and the rough surface: MCML of the same "
                         "set-up agrees within 1.1% (0.996, 0.989, 0.992 ± 0.006)",
}


def _cause_cell(scene: str, region: str) -> str:
    cause = MEASURED_CAUSES.get((scene, region))
    if cause is not None:
        return f"<td class=name style='font-weight:normal'>{html.escape(cause)} ({_results_link('measured')})</td>"
    return f"<td class=name style='font-weight:normal'>not measured: {_results_link('the experiments')}</td>"


def _ratio_cell(row: dict[str, Any], key: str) -> str:
    rr = row.get(f"{key}_vs_path_traced")
    if rr is None:
        return "<td>-</td>"
    return "<td>" + ", ".join(f"{v:.3f} ± {e:.3f}" for v, e in zip(rr["ratio"], rr["se"])) + "</td>"


def _region_table(regions: dict) -> str:
    """The model's error per region: the exact 2D convolution (the screen-space model with a perfect
    kernel) over the path-traced reference, with standard errors, and the measured cause; the pass's
    level beside it (its own kernel error is the ranking's, above)."""
    head = ("<table><tr><th>scene</th><th>reference</th><th>region</th><th>pixels</th>"
            "<th>model's error: exact 2D / path traced ± SE (R, G, B)</th><th>measured cause</th>"
            "<th>levels: screen space, exact 2D, path traced ± SE</th><th>screen / path traced</th></tr>")
    body = []
    for scene, item in regions.items():
        table, ref = item["table"], item["reference"]
        if not table:
            continue
        conv = "converged" if ref["converged"] else "budget spent"
        info = (f"{ref['spp']} spp, rel. SE " + ", ".join(f"{v:.1%}" for v in ref["rel_se"]) + f" ({conv})")
        for name, row in table["regions"].items():
            if not row["pixels"]:
                continue
            levels = "".join(_level_cells(row, k, True if k == "path_traced" else None).replace("<td>", "", 1)
                             .replace("</td>", "<br>", 1) for k in ("screen_space", "exact_2d", "path_traced"))
            body.append(f"<tr><td class=name>{html.escape(scene)}</td><td>{info}</td><td class=name>{name}</td>"
                        f"<td>{row['pixels']}</td>{_ratio_cell(row, 'exact_2d')}{_cause_cell(scene, name)}"
                        f"<td>{levels}</td>{_ratio_cell(row, 'screen_space')}</tr>")
    return head + "".join(body) + "</table>"


def _kernel_rows(rows: list[dict[str, Any]], regions: dict[str, Any]) -> str:
    """The screen-space kernels per scene: the kernel's error against the exact 2D convolution (PSNR / FLIP, no
    noise: the kernel alone) and per region its level over the path trace's (R, G, B); above each scene's
    kernels its reference and the noise floor per region, the relative standard error of the reference's
    level (the same for every kernel, so stated once)."""
    from .metrics import REGIONS, psnr_text

    # the lit plateau left out: there every kernel that conserves energy gives the profile's albedo, the same for
    # all by construction (the model's error there is the region table's, below)
    regions_shown = [name for name in REGIONS if name != "plateau"]
    head = ("<table><tr><th>scene</th><th>kernel / taps</th><th>vs exact 2D<br>PSNR / FLIP (no noise)</th>"
            + "".join(f"<th>{name.replace('_', ' ')}: level / path traced<br>(R, G, B)</th>" for name in regions_shown)
            + "</tr>")
    body = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        mine = [r for r in rows if r["scene"] == scene]
        ref = regions.get(scene, {}).get("reference")
        floors = []
        for name in regions_shown:
            pt = (mine[0].get("regions") or {}).get(name, {}).get("path_traced")
            if not pt or pt.get("se") is None or not (mine[0]["regions"][name]["pixels"]):
                floors.append("<td>no pixels</td>")
                continue
            rel = np.asarray(pt["se"]) / np.maximum(np.abs(pt["level"]), 1e-300)
            floors.append("<td>± " + ", ".join(f"{v:.1%}" for v in rel) + "</td>")
        spp = f"{ref['spp']} spp" if ref else "no reference"
        resolved = _kernels_resolved(mine, regions_shown)
        body.append(f"<tr class=scene><td class=name>{html.escape(scene)}</td><td class=name>noise floor "
                    f"(reference's rel. SE, {spp})</td><td>{resolved}</td>" + "".join(floors) + "</tr>")
        for r in mine:
            cells = []
            for name in regions_shown:
                ratio = (r.get("regions") or {}).get(name, {}).get("screen_space_vs_path_traced")
                cells.append("<td>-</td>" if ratio is None else
                             "<td>" + ", ".join(f"{v:.4f}" for v in ratio["ratio"]) + "</td>")
            ex = r.get("exact_2d")
            body.append(f"<tr><td class=name>{html.escape(scene)}</td><td class=name>{html.escape(r['method'])}</td>"
                        + (f"<td>{psnr_text(ex['psnr'])} / {ex['flip']:.3f}</td>" if ex else "<td>-</td>")
                        + "".join(cells) + "</tr>")
    return head + "".join(body) + "</table>"


def _kernels_resolved(rows: list[dict[str, Any]], regions: list[str]) -> str:
    """Whether the path trace tells a scene's kernels apart: the regions (of ``regions``) where two kernels' levels
    differ by more than twice the reference's standard error of their ratio, or that none does."""
    apart = []
    for name in regions:
        found = [((r.get("regions") or {}).get(name) or {}).get("screen_space_vs_path_traced") for r in rows]
        ratios = [x for x in found if x is not None and x["se"] is not None]
        if not ratios or len(ratios) < len(found):
            continue
        spread = np.ptp([x["ratio"] for x in ratios], axis=0)
        if np.any(spread > 2 * np.asarray(ratios[0]["se"])):
            apart.append(name.replace("_", " "))
    return ("kernels apart beyond 2 SE: " + ", ".join(apart)) if apart else "no two kernels apart beyond 2 SE"


def _display_note(regions: dict[str, Any]) -> str:
    """How the path-traced images are shown (:func:`ssskit.figures.screenspace.display_copy`)."""
    from .figures.screenspace import DISPLAY_BLOCKS, DISPLAY_REL_SE

    return ("The path-traced panels are display copies: where the reference's relative noise over the SSS mask "
            f"(the RMS of its pixels' standard errors over their mean) is above {DISPLAY_REL_SE:.0%}, the panel shows "
            f"the means of the smallest pixel blocks ({', '.join(f'{b}x{b}' for b in DISPLAY_BLOCKS[1:])}) that "
            "bring it to that, else the largest, each panel's title naming its block and its remaining noise (where "
            f"that stays far above {DISPLAY_REL_SE:.0%}, the reference's samples, its row above, cannot show the "
            "scene's detail at any block size that still shows the scene; the region levels, averaged over hundreds "
            "of pixels, are what it measures); every number above is measured on the unfiltered reference.")


def _screenspace_section(out: Path, progress: Progress, ctx: dict) -> str:
    from .figures.screenspace import screen_space_comparison, slab_edge_profile
    from .screenspace import PassSettings

    photons = ctx.get("photons", DEMO_PHOTONS)
    backend = ctx.get("backend", DEFAULT_BACKEND)
    png, rows, regions = screen_space_comparison(out / "figures", photons=photons, progress=progress,
                                                 sss=PassSettings(jitter=0.1, backend=backend))
    body = _kernel_rows(rows, regions)
    edge_png, edge = slab_edge_profile(out / "figures", photons=photons, progress=progress, backend=backend)
    shape = edge["shape"]
    rmse_rows = "".join(
        f"<tr><td class=name>{label}</td><td>{shape[k]['rmse']:.4f} ± {shape[k]['rmse_se']:.4f}</td>"
        f"<td>{shape[k]['noise']:.4f}</td><td>{'yes' if shape[k]['resolved'] else 'no'}</td></tr>"
        for label, k in (("screen space vs exact 2D (the kernel's error)", "rmse_screen_space_vs_exact_2d"),
                         ("exact 2D vs path traced (the model's error)", "rmse_exact_2d_vs_path_traced"),
                         ("screen space vs path traced", "rmse_screen_space_vs_path_traced")) if k in shape)
    return (
        "<h2 id=screenspace>Screen-space separable SSS on 3D scenes (paper section 6, supplement E)</h2>"
        f"<p class=note>Skin1, Monte Carlo profile ({photons:,} photons per channel), on the scenes lit from the "
        f"front ({html.escape(', '.join(regions))}; the scenes lit only from behind, black without the transmittance pass, "
        "are left out: the transmission section measures that pass). G-buffers rendered by "
        "Mitsuba 3 (scalar_rgb, CPU): diffuse light E/&pi; (direct light only), specular, albedo, depth, normals, "
        "SSS mask. Horizontal then vertical pass inside the mask, footprint from depth and projection, "
        f"follow-surface depth test, 10% jitter, on the {html.escape(backend)} backend. Errors inside the SSS mask: PSNR (dB) / FLIP against the exact "
        "2D convolution with the same profile and against a volumetric path-traced reference (Mitsuba volpathmis, "
        "homogeneous medium inside a rough dielectric, Beckmann &alpha; = 0.15; every other surface black, so "
        "both sides are lit by the lights alone; independent chunks until the SSS mask's relative standard "
        "error is 1% or 128 spp are spent). Against the path trace each kernel is compared per region (its level "
        "over the reference's): a per-pixel PSNR against it would measure the reference's own per-pixel noise, "
        "the same for every kernel; the region levels average that noise away down to the noise floor stated "
        "in each scene's first row (the reference level's relative standard error). A difference between two "
        "kernels below about twice that floor is not resolved (each scene's first row says whether any is). Which "
        "kernel is closer to the model is the noise-free error against the exact 2D convolution (third column). "
        "The lit plateau is left out: there every kernel "
        "that conserves energy gives the profile's albedo (its error against the path trace is the model's: "
        "the region table below); '-': the scene has no such region.</p>"
        + body + f"<img src='figures/{png.name}' style='width:100%'><p class=note>{_display_note(regions)}</p>"
        "<h3>The model's error per region, against path-traced references</h3><p class=note>Level = mean diffuse "
        "part / mean E/&pi; (R, G, B). Specular subtracted "
        "on every side. On the lit plateau the level is the effective albedo; in the shadow-edge band, at the "
        "terminator and the silhouette it measures the light carried across. The exact 2D convolution sits "
        "between the pass and the reference: screen / exact is the kernel's error, exact / path traced the "
        "screen-space model's (a flat, semi-infinite, front-lit medium with a Lambertian exit) against the light "
        "transport, with the reference's standard error (pre-integrated kernel, 7 importance-sampled taps).</p>"
        + _region_table(regions)
        + "<h3>The slab's shadow edge: shape apart from level</h3><p class=note>Each curve divided by its own "
        "plateau. Index-matched set-up (the material at &eta; = 1, Mitsuba null boundary, Monte Carlo profile at "
        f"&eta; = 1): the reference converges there ({edge['reference']['spp']} spp, relative standard error "
        + ", ".join(f"{v:.2%}" for v in edge["reference"]["rel_se"]) + "), where the rough dielectric's needs "
        "~10<sup>4</sup> spp for 0.5% on the plateau.</p>"
        "<table><tr><th>RMSE of the normalised edge profile</th><th>RMSE ± SE</th><th>reference noise</th>"
        f"<th>resolved</th></tr>{rmse_rows}</table><img src='figures/{edge_png.name}' style='width:100%'>"
        + _attribution_html()
    )


#: where the stored attribution results live (the repository's lab, not installed with the package)
ATTRIBUTION_RESULTS = "experiments/RESULTS.md"


def _results_link(text: str) -> str:
    """A link to the lab's stored results (a source checkout has them), else their name in the repository."""
    results = Path(__file__).resolve().parents[2] / ATTRIBUTION_RESULTS
    if results.is_file():
        return f"<a href='{html.escape(results.as_uri())}'>{html.escape(text)}</a>"
    return f"{html.escape(text)}: <code>{ATTRIBUTION_RESULTS}</code> in the ssskit repository"


def _attribution_html() -> str:
    """What each region difference is: a link to the lab's stored results (the controlled experiments are
    research, run by ``python experiments/region_attribution.py``; the report never computes them)."""
    results = Path(__file__).resolve().parents[2] / ATTRIBUTION_RESULTS  # a source checkout has it
    link = (f"<a href='{html.escape(results.as_uri())}'>{ATTRIBUTION_RESULTS}</a>" if results.is_file()
            else f"<code>{ATTRIBUTION_RESULTS}</code> in the ssskit repository")
    return ("<h3>What each difference is: controlled experiments</h3><p class=note>Each region's difference "
            "between the exact 2D convolution and the path-traced reference is measured by switching one cause "
            "off in the reference (light entering the unseen surface, grazing Fresnel, curvature, a thin "
            f"object's back, the angles and the boundary): the stored results are in {link} (section \"What "
            "each region difference is\"), made by <code>python experiments/region_attribution.py</code>.</p>")


def _burley_section(out: Path, progress: Progress, ctx: dict) -> str:
    from .figures.burley import demo_section

    return demo_section(out, progress, ctx)


def _adaptive_section(out: Path, progress: Progress, ctx: dict) -> str:
    from .figures.adaptive import demo_section

    return demo_section(out, progress, ctx)


def _model_section(out: Path, progress: Progress, ctx: dict) -> str:
    from .figures.views import demo_section

    return demo_section(out, progress, ctx)


#: the transmission section's back-lit ear: size, G-buffer samples (a few seconds on a warm cache)
TRANSMISSION_SIZE = (160, 120)
TRANSMISSION_SPP = 16
#: the transmittance pass's docs (docs/transmission.md in the repository)
TRANSMISSION_DOC = "docs/transmission.md"


def _doc_link(rel: str, text: str) -> str:
    """A link to a repository doc (a source checkout has it), else its name in the repository."""
    doc = Path(__file__).resolve().parents[2] / rel
    if doc.is_file():
        return f"<a href='{html.escape(doc.as_uri())}'>{html.escape(text)}</a>"
    return f"{html.escape(text)}: <code>{html.escape(rel)}</code> in the ssskit repository"


def _transmission_section(out: Path, progress: Progress, ctx: dict) -> str:
    """Light through thin parts: the back-lit ear with and without the transmittance pass, how much light it adds
    per channel for each model (:mod:`ssskit.pipeline.transmission`)."""
    from .io import save_image
    from .pipeline import RenderSettings, SeparablePass
    from .pipeline.render import render_separable

    backend = ctx.get("backend", DEFAULT_BACKEND)
    w, h = TRANSMISSION_SIZE
    base = RenderSettings(material="skin1", model="montecarlo", photons=ctx.get("photons", DEMO_PHOTONS), width=w,
                          height=h, spp=TRANSMISSION_SPP, backend=backend, exact=False, perceptual=False,
                          pass_=SeparablePass(jitter=0.1))
    progress(f"transmission: the back-lit ear, {w}x{h}, {TRANSMISSION_SPP} spp, light layers ray-cast")
    on = render_separable("ear", base.replace(transmission="on"))
    gb = on.gbuffer
    off = render_separable(gb, base.replace(transmission="off"))
    mask = gb.mask
    reflect = off.image[mask].mean(axis=0)
    rows = []
    for model in ("mcml", "unreal", "jimenez2010"):
        r = on if model == "mcml" else render_separable(gb, base.replace(transmission_model=model))
        assert r.transmitted is not None
        added = r.transmitted[mask].mean(axis=0)
        lit = r.transmission.lit_pixels / max(int(mask.sum()), 1)
        rows.append(f"<tr><td class=name>{model}</td><td>{_fmt(added, 3)}</td>"
                    f"<td>{_fmt(1.0 + added / np.maximum(reflect, 1e-12), 3)}</td><td>{lit:.0%}</td></tr>")
    gap = np.ones((h, 4, 3)) * float(np.percentile(on.image[np.isfinite(on.image)], 99.5))
    fig = out / "figures" / "transmission_ear.png"
    fig.parent.mkdir(parents=True, exist_ok=True)
    save_image(fig, np.concatenate([off.image, gap, on.image], axis=1), what="transmission figure")
    return (
        "<h2 id=transmission>Light through thin parts: the transmittance pass</h2>"
        f"<p class=note>The ear lit from behind (its key light behind it), Skin1, {w}&times;{h}, the separable pass "
        f"on the {html.escape(backend)} backend; left without, right with the transmittance pass (one tone map). "
        "The pass reads the thickness the light crosses from a translucency shadow map (ray-cast by Mitsuba, stored "
        "as the G-buffer's light layers), looks up the material's transmittance T(t) and adds the light leaving the "
        "front, T E / &pi;, before the albedo multiply. Per model: the mean transmitted radiance over the SSS mask "
        "(R, G, B), the image's mean brightness with it relative to without (the reflectance pass alone), and the "
        "share of SSS pixels it lights. <b>mcml</b>: T(t) of the material's own Monte Carlo slab tables; "
        "<b>unreal</b>: Unreal Engine 5's computation with its defaults for the material's Burley profile; "
        "<b>jimenez2010</b>: Jimenez et al. 2010's skin Gaussians (thickness in mm). How it works, what is "
        f"measured against path-traced references and what is not: {_doc_link(TRANSMISSION_DOC, 'the transmission docs')}.</p>"
        "<table><tr><th>model</th><th>mean added radiance (R, G, B)</th><th>brightness with / without</th>"
        f"<th>SSS pixels lit</th></tr>{''.join(rows)}</table>"
        f"<img src='figures/{fig.name}'>"
    )


#: the report's sections in order: the head first (the answer on a face), the user's question (which kernel, how
#: close to truth), then the
#: materials and profiles behind the answer, then Xie 2020's passes (``ssskit demo --scene`` adds "model")
SECTIONS: list[tuple[str, Section]] = [
    ("head", _head_section),
    ("viewer", _viewer_section),
    ("kernels", _kernels_section),
    ("screenspace", _screenspace_section),
    ("transmission", _transmission_section),
    ("materials", _materials_section),
    ("profiles", _profiles_section),
    ("sampling", _sampling_section),
    ("burley", _burley_section),
    ("adaptive", _adaptive_section),
]

#: the screen-space passes each section runs (:data:`ssskit.backends.base.WARM_UP` names): with several
#: processes (``build_report(jobs=...)``) their kernels are compiled once, by jobs of their own that the
#: sections wait for (:func:`section_jobs`), the first beside the kernel ranking, which runs none
SECTION_PASSES: dict[str, tuple[str, ...]] = {
    "screenspace": ("separable:follow", "separable:gaussian", "separable:ids"),
    "transmission": ("separable:follow", "transmission"),  # the default settings: no lateral spread
    "burley": ("separable:follow", "burley"),
    "adaptive": ("burley", "adaptive"),
    "model": ("separable:follow", "separable:ids", "burley", "adaptive"),
    "head": ("separable:follow",),
}

#: the order several processes take the sections in: the kernel ranking first (it runs no pass: beside the first
#: compilation), then the longest (CPU seconds on this project's 2 cores, a fresh machine's demo of 2026-12-05:
#: screen space ~54 with its four front-lit scenes, kernels ~27, adaptive ~16, profiles ~9, Burley ~8; transmission
#: ~2 since the shipped tables: small, its place matters little; 2026-12-06 at load ~17: kernels 29 with all 11
#: materials at 128x128, screen space 53 with the head, head 4); a section not named here comes last
SECTION_ORDER = ("kernels", "screenspace", "model", "adaptive", "head", "transmission", "profiles", "burley",
                 "sampling", "materials", "viewer")


def _cached_section(name: str, section: Section, out: Path, progress: Progress, ctx: dict) -> str:
    """Run a report section, or copy its HTML and files from the ``demo`` cache when the same settings
    and the same source made them before (a second ``ssskit demo`` is then fast)."""
    import hashlib
    import pickle

    from .cache import cache_dir, source_digest
    from .io import atomic_output

    key = json.dumps({"section": name, "photons": ctx.get("photons"), "backend": ctx.get("backend"),
                      "recompute": ctx.get("recompute", False), "materials": ctx.get("materials"),
                      "scene": ctx.get("scene_key") if name == "model" else None, "source": source_digest()},
                     sort_keys=True)
    path = cache_dir("demo") / f"{name}-{hashlib.sha1(key.encode()).hexdigest()[:16]}.pkl"
    if path.is_file():
        try:
            with open(path, "rb") as fh:
                text, files = pickle.load(fh)
            progress(f"{name}: from the cache")
            for rel, data in files.items():
                target = out / rel
                target.parent.mkdir(parents=True, exist_ok=True)
                with atomic_output(target) as tmp:
                    tmp.write_bytes(data)
            return text
        except Exception:  # noqa: BLE001 - an unreadable entry is built again
            pass
    before = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()}
    text = section(out, progress, ctx)
    files = {str(p.relative_to(out)): p.read_bytes() for p in out.rglob("*")
             if p.is_file() and before.get(p) != p.stat().st_mtime_ns}
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as fh:
            pickle.dump((text, files), fh)
    return text


def _section_job(name: str, section: Section, out: Path, ctx: dict[str, Any],
                 label: str) -> tuple[str, float, float]:
    """A worker's job (:func:`_build_parallel`): one section into its own folder ``out`` (:func:`_cached_section`),
    its progress to the parent; returns (its HTML, its seconds, its CPU seconds)."""
    import contextlib

    from .compute.workers import line
    from .profiles.montecarlo.shipped import recompute as no_shipped
    from .progress import reporting

    line(f"{label} section {name}")
    t0, c0 = time.perf_counter(), _cpu_s()
    out.mkdir(parents=True, exist_ok=True)
    with reporting(line), (no_shipped() if ctx.get("recompute") else contextlib.nullcontext()):
        text = _cached_section(name, section, out, line, ctx)
    return text, time.perf_counter() - t0, _cpu_s() - c0


def _cpu_s() -> float:
    """This process's CPU seconds so far (user + system, every thread)."""
    import resource

    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _warm_up_job(backend: str, passes: list[str]) -> None:
    """A worker's job (:func:`_build_parallel`): compile the passes' kernels into numba's disk cache
    (:meth:`Backend.warm_up`), from which the other workers' sections load them."""
    from .backends import get_backend
    from .compute.workers import line

    line(f"compiling the {backend} kernels of {', '.join(passes)} (once: numba caches them on disk)")
    t0, c0 = time.perf_counter(), _cpu_s()
    get_backend(backend).warm_up(passes)
    line(f"compiled the {backend} kernels in {time.perf_counter() - t0:.1f} s (CPU {_cpu_s() - c0:.1f} s)")


def section_jobs(names: list[str], compiles: bool) -> tuple[list[tuple[str, Any]], dict[int, set[int]]]:
    """The jobs that build the sections ``names`` on several processes, in the order free workers take them, and
    which must finish before which: (jobs, after). A job is ("section", index into ``names``) or, where the
    backend ``compiles`` its kernels, ("compile", [passes]): each pass a section runs (:data:`SECTION_PASSES`)
    is compiled by one job, placed just before the first section that runs it (the first such job before
    everything, beside the sections that run none), and every section waits for the jobs compiling its
    passes (``after``: job index -> job indices). Sections in :data:`SECTION_ORDER`, the others last."""
    rank = {name: k for k, name in enumerate(SECTION_ORDER)}
    order = sorted(range(len(names)), key=lambda k: (rank.get(names[k], len(rank)), k))
    needs = {k: list(SECTION_PASSES.get(names[k], ())) if compiles else [] for k in order}
    jobs: list[tuple[str, Any]] = []
    after: dict[int, set[int]] = {}
    warmed: dict[str, int] = {}  # pass -> the job compiling it

    def compile_job(passes: list[str]) -> None:
        warmed.update(dict.fromkeys(passes, len(jobs)))
        jobs.append(("compile", passes))

    first = next((k for k in order if needs[k]), None)
    if first is not None:
        compile_job(needs[first])
    for k in order:
        new = [p for p in needs[k] if p not in warmed]
        if new:
            compile_job(new)
        after[len(jobs)] = {warmed[p] for p in needs[k]}
        jobs.append(("section", k))
    return jobs, after


def _build_parallel(out: Path, sections: list[tuple[str, Section]], progress: Progress, ctx: dict[str, Any],
                    jobs: int) -> list[str]:
    """The sections' HTML in report order, built by ``jobs`` worker processes
    (:func:`ssskit.compute.workers.run_jobs`) as :func:`section_jobs` plans them (the kernels of the passes
    compiled once, beside the sections that run none), each section into a folder of its own whose files
    move into ``out`` as it finishes. On an error or Ctrl-C the workers end before the error goes on, so
    nothing writes into the staging folder when it is removed."""
    import shutil

    from .backends import get_backend
    from .compute.workers import one_library_thread, run_jobs

    names = [name for name, _ in sections]
    backend = ctx.get("backend", DEFAULT_BACKEND)
    parts = out / ".sections"
    plan, after = section_jobs(names, get_backend(backend).compiles_on_first_use)
    tasks: list[tuple[Callable[..., Any], tuple[Any, ...]]] = [
        (_warm_up_job, (backend, what)) if kind == "compile" else
        (_section_job, (names[what], sections[what][1], parts / names[what], ctx, f"[{what + 1}/{len(sections)}]"))
        for kind, what in plan]
    section_of = {j: what for j, (kind, what) in enumerate(plan) if kind == "section"}  # job -> section index
    body: dict[int, str] = {}

    def done(index: int, value: Any) -> None:
        if index not in section_of:
            return
        k = section_of[index]
        body[k], seconds, cpu = value
        for src in sorted(p for p in (parts / names[k]).rglob("*") if p.is_file()):
            dst = out / src.relative_to(parts / names[k])
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.replace(src, dst)
        progress(f"[{k + 1}/{len(sections)}] section {names[k]}: done in {seconds:.1f} s (CPU {cpu:.1f} s)")

    workers = min(jobs, len(sections))
    progress(f"{len(sections)} sections on {workers} processes (starting them takes a few seconds)")
    # plain progress lines from the workers (redrawn bars of several processes would garble a terminal); one
    # BLAS and one OpenMP thread each unless the user chose (ssskit.compute.workers.one_library_thread; the CLI
    # has set it already): beside another busy worker a second thread only spins on the core the other needs
    env = {"SSSKIT_PROGRESS": "lines", **one_library_thread()}
    try:
        run_jobs(tasks, workers, progress, done, env=env, after=after)
    finally:
        shutil.rmtree(parts, ignore_errors=True)
    return [body[k] for k in range(len(sections))]


def _file_digest(path: str | Path) -> str:
    """sha1 of a file's bytes ("" for a name that is no file, e.g. the generated bust)."""
    import hashlib

    p = Path(str(path))
    return hashlib.sha1(p.read_bytes()).hexdigest() if p.is_file() else ""


def _backend_text(backend: Backend) -> str:
    """``name backend (details)``, e.g. the gl backend's renderer string."""
    ok, details = backend.availability()
    return f"{backend.name} backend" + (f" ({details})" if ok and details else "")


def _with_contents(sections: list[str]) -> tuple[list[str], str]:
    """Give every section heading (h2) an id and return (sections, a table of contents linking them)."""
    import re

    items: list[tuple[str, str]] = []
    out: list[str] = []
    for k, text in enumerate(sections):
        def named(m: re.Match[str], k: int = k) -> str:
            attrs, title = m.group(1), m.group(2)
            found = re.search(r"id=['\"]?([\w-]+)", attrs)
            ident = found.group(1) if found else f"section-{k}-{len(items)}"
            items.append((ident, re.sub(r"<[^>]+>", "", title)))
            return f"<h2 id='{ident}'>{title}</h2>"

        out.append(re.sub(r"<h2([^>]*)>(.*?)</h2>", named, text))
    toc = "<nav><b>Contents</b><ol>" + "".join(f"<li><a href='#{i}'>{html.escape(t)}</a></li>" for i, t in items)
    return out, toc + "</ol></nav>"


def build_report(out_dir: str | Path, progress: Progress | None = None, photons: int = DEMO_PHOTONS,
                 progress_bars: bool = False, backend: str = DEFAULT_BACKEND, recompute: bool = False,
                 materials: list[str] | None = None, scene: dict | None = None, jobs: int = 1) -> Path:
    """Run every section into ``out_dir`` and write ``index.html`` last; returns its path. The
    screen-space passes run on ``backend`` (checked before any work: a BackendError if it cannot run
    here). ``recompute``: simulate the Monte Carlo profiles instead of reading the shipped ones;
    ``materials``: whose kernels the report ranks (:data:`RANK_MATERIALS` by default); ``scene`` (scene,
    units, material_map: ``ssskit demo --scene``) adds the "Your model" section
    (:func:`ssskit.figures.views.demo_section`), cached by the options and the scene file's content. Each
    section says when it starts and how long it took on ``progress``; the report is built in a staging
    folder, so an interrupted or failed demo leaves no partial folder.

    ``jobs`` > 1: the sections are built by that many worker processes at once (:func:`_build_parallel`;
    most of a section's work runs on one core: the optimisations, the metrics, the plots, numba's
    compilation), each in a folder of its own, their progress passed on to ``progress``; the page is the
    same as with one process."""
    import contextlib

    from .backends import get_backend
    from .io import staged_folder
    from .profiles.montecarlo.shipped import recompute as no_shipped

    JOBS.check(jobs)
    runner = get_backend(backend)
    sections = list(SECTIONS)
    ctx: dict = {"photons": photons, "progress_bars": progress_bars, "backend": runner.name, "recompute": recompute,
                 "materials": list(materials or RANK_MATERIALS), "sections": sections}
    if scene is not None:
        from .scenes import resolve_scene

        resolve_scene(scene["scene"], units=scene.get("units"), material_map=scene.get("material_map"),
                      view="front")  # every check before any work (the study places its own views)
        ctx["scene"] = scene
        ctx["scene_key"] = {**scene, "file": _file_digest(scene["scene"])}
        sections.append(("model", _model_section))
    progress = progress or (lambda msg: None)
    with staged_folder(out_dir) as stage, (no_shipped() if recompute else contextlib.nullcontext()):
        _build(stage, progress, ctx, runner, jobs)
    return Path(out_dir) / "index.html"


def _build(out: Path, progress: Progress, ctx: dict[str, Any], runner: Backend, jobs: int = 1) -> None:
    t0 = time.perf_counter()
    sections = ctx.pop("sections", SECTIONS)
    if jobs > 1 and len(sections) > 1:
        body = _build_parallel(out, sections, progress, ctx, jobs)
    else:
        body = []
        for k, (name, section) in enumerate(sections, 1):
            progress(f"[{k}/{len(sections)}] section {name}")
            t_section, c_section = time.perf_counter(), _cpu_s()
            body.append(_cached_section(name, section, out, progress, ctx))
            progress(f"[{k}/{len(sections)}] section {name}: done in {time.perf_counter() - t_section:.1f} s "
                     f"(CPU {_cpu_s() - c_section:.1f} s)")
    from . import __version__

    body, toc = _with_contents(body)
    page = (
        "<!doctype html><html><head><meta charset='utf-8'><title>ssskit demo</title>"
        f"<style>{_CSS}</style></head><body><h1>ssskit demo report</h1>"
        f"<p class=note>ssskit {__version__}; screen-space passes on the {html.escape(_backend_text(runner))}; "
        f"built in {time.perf_counter() - t0:.1f} s.</p>"
        + toc
        + "".join(body)
        + "</body></html>\n"
    )
    write_text(out / "index.html", page)
