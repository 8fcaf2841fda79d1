"""Xie et al. 2020 Fig. 5 (:func:`fig5_xie_c`: the error of Eq. 21 for several c, with the CDF) and
Fig. 6: the analytic inverse of Eq. 20 against the approximation of Eq. 21, and a beam-light disk of
1 cm radius rendered with both samplers by the screen-space Burley pass; and the demo's Burley
comparison (:func:`burley_comparison`, :func:`demo_section`).

Parameters: the figure's ``profile`` when it is a Burley profile (``--model burley``), else Xie's
Fig. 5 albedo A = 0.9 with diffuse mean free paths 20, 10, 5 mm (Eq. 5, configuration 3: d = 1.42,
0.71, 0.36 mm; Fig. 5's ell = 1 mm would scatter less than a pixel here). The disk: a fronto-parallel
plane of one profile id at 500 mm, 8 pixels per mm (256 x 256 pixels, 32 x 32 mm), irradiance 1
inside r <= 10 mm and 0 outside; the pass runs with 256 samples
per pixel, no mips, the same seed for both samplers, and is compared with its exact limit
(:func:`ssskit.pipeline.burley_frame.burley_exact`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..backends import DEFAULT_BACKEND
from .plots import pyplot, save_figure

if TYPE_CHECKING:
    from ..profiles.base import RGBProfile
    from ..screenspace import BurleyParams, BurleySettings, GBuffer

#: c values of the inverse panel: Xie's least-squares 2.5715 and Unreal's 2.6
CS = (2.5715, 2.6)


def _params(profile: RGBProfile | None) -> BurleyParams:
    from ..screenspace import BurleyParams

    if getattr(profile, "model", "") == "burley":
        return BurleyParams.from_profile(profile)
    return BurleyParams.from_dmfp(0.9, (20.0, 10.0, 5.0))


def beam_disk(size: int = 256, px_per_mm: float = 8.0, radius_mm: float = 10.0) -> GBuffer:
    """The beam-light G-buffer: a plane at 500 mm, irradiance 1 inside ``radius_mm`` of the centre."""
    from ..screenspace import Camera, GBuffer

    z = 500.0
    yy, xx = (np.mgrid[0:size, 0:size] + 0.5 - size / 2) / px_per_mm
    lit = (xx**2 + yy**2 <= radius_mm**2).astype(np.float32)
    e = np.repeat(lit[..., None], 3, axis=2)
    f = px_per_mm * z
    return GBuffer(diffuse=e, albedo=np.ones_like(e), depth=np.full((size, size), z, np.float32),
                   profile_id=np.ones((size, size), np.uint32), camera=Camera(size, size, f, f, size / 2, size / 2))


def fig6_xie_inverse(out: Path, profile: RGBProfile | None, progress: Callable[[str], None] | None = None, spp: int = 256, backend: str = DEFAULT_BACKEND) -> list[Path]:
    """Xie 2020 Fig. 6 (module docstring): ``xie_fig6.png``; the Burley pass runs on ``backend``."""
    from ..metrics import tonemap
    from ..pipeline.burley_frame import burley_exact
    from ..profiles.burley import burley_inverse_cdf
    from ..sampling.burley_radius import xie_g
    from ..screenspace import burley_sss

    params = _params(profile)
    plt = pyplot()
    fig, axes = plt.subplots(1, 4, figsize=(17, 4))
    xi = np.linspace(1e-4, 1 - 1e-4, 2000)
    d = max(params.d_mm)
    exact_r = burley_inverse_cdf(xi, d)
    ax = axes[0]
    ax.plot(xi, exact_r, color="tab:orange", label="analytic inverse of Eq. 20")
    err = ax.twinx()
    for c, style in zip(CS, ("--", ":")):
        g = xie_g(xi, d, c)
        ax.plot(xi, g, style, color="tab:blue", label=f"Eq. 21, c = {c}")
        err.plot(xi, 100 * (g / exact_r - 1), style, color="tab:gray", lw=0.8)
    ax.set_yscale("log")
    ax.set_xlabel("ξ")
    ax.set_ylabel(f"r (mm), d = {d:.3g} mm")
    err.set_ylabel("% error of Eq. 21 (gray)")
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("inverse CDF: analytic vs approximate", fontsize=9)

    gb = beam_disk()
    if progress is not None:
        progress("xie fig6: beam-light disk, exact and xie samplers")
    common: dict[str, Any] = dict(spp=spp, mips=False, seed=3, backend=backend)
    images = {"exact sampler": burley_sss(gb, params, sampler="exact", **common),
              f"xie sampler, c = {CS[0]}": burley_sss(gb, params, sampler="xie", c=CS[0], **common)}
    ref = burley_exact(gb, params)
    assert ref is not None  # the beam disk's pixels are square
    peak = float(ref.max())
    for ax, (label, img) in zip(axes[1:3], images.items()):
        ax.imshow(tonemap(img, peak))
        ax.set_title(f"{label}, {spp} spp", fontsize=9)
        ax.axis("off")
    ax = axes[3]
    h, w = gb.shape
    r_mm = (np.arange(w) + 0.5 - w / 2) / 8.0
    row = slice(h // 2 - 2, h // 2 + 2)  # a few rows through the centre, averaged
    ch = params.sampling_channel
    ax.plot(r_mm, ref[row, :, ch].mean(axis=0), color="k", lw=1, label="exact limit")
    for (label, img), style in zip(images.items(), ("-", "--")):
        ax.plot(r_mm, img[row, :, ch].mean(axis=0), style, lw=1, label=label)
    ax.set_yscale("log")
    ax.set_ylim(1e-4 * peak, 2 * peak)
    ax.set_xlim(0, r_mm[-1])
    ax.set_xlabel("x (mm) from the disk's centre (edge at 10 mm)")
    ax.set_title(f"centre rows, channel {'RGB'[ch]}", fontsize=9)
    ax.legend(fontsize=7)
    fig.suptitle("Xie et al. 2020 Fig. 6: analytic vs approximate inverse CDF; 1 cm beam-light disk", fontsize=10)
    fig.tight_layout()
    path = Path(out) / "xie_fig6.png"
    save_figure(fig, path)
    return [path]


#: c values of Fig. 5: the range Eq. 21 allows, Xie's least-squares value and Unreal's
FIG5_CS = (2.0, 2.5715, 2.6, 3.0)


def fig5_xie_c(out: Path, profile: RGBProfile | None = None,
               progress: Callable[[str], None] | None = None) -> list[Path]:
    """Xie 2020 Fig. 5: the percentage error of g (Eq. 21) against the exact inverse of Eq. 20 for
    several c (left axis), and the CDF of Eq. 20 (right axis), over the radius r for Fig. 5's
    d: A = 0.9, ell = 1 mm, Eq. 5 configuration 3 (d = 1 / (3.5 + 100 x 0.57^4) = 0.0711 mm). The
    error at r is 100 (g(cdf(r)) / r - 1) (it depends on r / d only). ``xie_fig5.png``; ``profile``
    is unused (the figure's parameters are the paper's)."""
    from ..profiles.burley import burley_cdf
    from ..sampling.burley_radius import xie_g

    d = 1.0 / (3.5 + 100.0 * (0.9 - 0.33) ** 4)  # Eq. 5, configuration 3
    r = np.linspace(1e-4, 12 * d, 2000)
    xi = burley_cdf(r, d)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for c in FIG5_CS:
        ax.plot(r, 100 * (xie_g(xi, d, c) / r - 1), label=f"c = {c:g}" + (" (Xie)" if c == 2.5715 else
                                                                          " (Unreal)" if c == 2.6 else ""))
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel(f"r (mm), d = {d:.4f} mm (A = 0.9, ℓ = 1 mm)")
    ax.set_ylabel("% error of g(ξ) against cdf⁻¹(ξ), ξ = cdf(r)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    cdf_ax = ax.twinx()
    cdf_ax.plot(r, xi, color="lightblue", lw=2.5, zorder=0)
    cdf_ax.set_ylabel("cdf(r), Eq. 20 (light blue)")
    cdf_ax.set_ylim(0, 1.02)
    ax.set_title("Xie et al. 2020 Fig. 5: approximation error of Eq. 21 for several c, and the CDF", fontsize=9)
    fig.tight_layout()
    path = Path(out) / "xie_fig5.png"
    save_figure(fig, path)
    return [path]


#: samples per pixel of the Burley pass shown per scene (issue 13: 8/16/64 spp)
DEMO_SPPS = (8, 16, 64)
#: the demo's converged references: Xie 2020's 2k spp (the section's time is mostly these; their
#: standard error is measured and printed)
DEMO_REFERENCE_SPP = 2048


def _gray_psnr(reference: np.ndarray, test: np.ndarray, mask: np.ndarray) -> float:
    """Gray-scale PSNR inside the mask (Xie 2020 Sec. 6 reports gray-scale PSNR): the channel mean."""
    from ..metrics import psnr

    r = np.repeat(reference[mask].mean(axis=-1)[None, :, None], 3, axis=2)
    t = np.repeat(test[mask].mean(axis=-1)[None, :, None], 3, axis=2)
    return psnr(r, t)


def burley_comparison(out: Path, material: str = "skin1", scenes: Iterable[str] | None = None, width: int = 160,
                      height: int = 120, spp: int = 16, spps: Iterable[int] = DEMO_SPPS, reference_spp: int = 4096,
                      burley: BurleySettings | None = None, backend: str | None = None,
                      progress: Callable[[str], None] | None = None) -> tuple[Path, list[dict[str, Any]],
                                                                             dict[str, Any]]:
    """Every scene (default: the built-in ones lit from the front, :func:`ssskit.scenes.front_lit_scenes`;
    a back-lit one is black without the transmittance pass) with the Burley pass at ``spps`` samples per pixel beside its converged reference
    (:func:`ssskit.pipeline.burley_frame.burley_reference`: exact sampler, ``reference_spp``, no mips) and the
    separable pass with the ``burley_fit`` kernel (Xie 2020 appendix A.1); writes ``burley.png``.

    ``burley``: the pass's :class:`BurleySettings` (default: Xie's pass, the xie sampler with mips);
    ``backend``: runs both passes (default: ``burley.backend``); ``spp``: the G-buffers' samples per
    pixel. Errors against the converged reference on the composited images inside the SSS mask:
    gray-scale PSNR (as Xie reports), RGB RMSE and FLIP. The reference's own error: a second reference
    with another seed, ``ref_se`` = RMS of their difference over the mask / sqrt(2) (both cached).

    The figure: per scene a row of tone-mapped images, all at one exposure (the converged
    reference's 99.5th percentile), and below it the gray difference of each image from the
    reference (the last panel: the second reference's), on one colour scale per scene with its colour
    bar. Returns (png path, rows, references) with rows = [{scene, method, spp, psnr_gray, rmse,
    flip}] and references = {scene: {spp, ref_se, peak}}.
    """
    from ..metrics import region_metrics, tonemap
    from ..pipeline import RenderSettings, render
    from ..pipeline.burley_frame import burley_reference
    from ..scenes import front_lit_scenes
    from ..screenspace import BurleySettings, burley_sss
    from ..screenspace.burley import burley_params_for_material

    say = progress or (lambda msg: None)
    burley = BurleySettings(sampler="xie") if burley is None else burley
    if backend is not None:
        burley = burley.replace(backend=backend)
    params = burley_params_for_material(material)
    rows: list[dict[str, Any]] = []
    grid: list[Any] = []
    refs: dict[str, Any] = {}
    for scene in list(scenes or front_lit_scenes()):
        say(f"Burley pass: {scene}, G-buffer and separable burley_fit")
        sep = render(scene, RenderSettings(material=material, model="burley", kernel="burley_fit", width=width,
                                           height=height, spp=spp, exact=False, perceptual=False,
                                           backend=burley.backend))
        gb = sep.gbuffer
        mask = gb.mask
        say(f"Burley pass: {scene}, converged references ({reference_spp} spp, seeds 0 and 1, cached)")
        ref = gb.composite(burley_reference(gb, params, spp=reference_spp, backend=burley.backend))
        ref2 = gb.composite(burley_reference(gb, params, spp=reference_spp, seed=1, backend=burley.backend))
        ref_se = float(np.sqrt(np.mean((ref2[mask] - ref[mask]) ** 2)) / np.sqrt(2.0))
        refs[scene] = {"spp": reference_spp, "ref_se": ref_se, "peak": float(ref[mask].max())}
        line = [("separable, burley_fit", sep.image)]
        for n in spps:
            img = gb.composite(burley_sss(gb, params, burley.replace(spp=n)))
            line.append((f"Burley, {n} spp", img))
            rows.append(_row(scene, f"Burley {burley.sampler}{' + mips' if burley.mips else ''}", n, ref, img, mask,
                             region_metrics))
        rows.append(_row(scene, "separable burley_fit", None, ref, sep.image, mask, region_metrics))
        line.append((f"converged ({reference_spp} spp)", ref))
        grid.append((scene, line, ref, ref2, mask))
    plt = pyplot()
    ncol = max(len(g[1]) for g in grid)
    fig, axes = plt.subplots(2 * len(grid), ncol, figsize=(2.5 * ncol + 0.8, 3.75 * len(grid)), squeeze=False)
    fig.subplots_adjust(left=0.01, right=0.9, top=1 - 0.25 / len(grid), bottom=0.01, wspace=0.05, hspace=0.18)
    for r, (scene, line, ref, ref2, mask) in enumerate(grid):
        peak = float(np.percentile(ref, 99.5)) or 1.0
        diffs = [img.mean(axis=-1) - ref.mean(axis=-1) for _, img in line[:-1]] + [ref2.mean(axis=-1) - ref.mean(axis=-1)]
        scale = float(np.percentile(np.abs(np.concatenate([d[mask] for d in diffs[1:-1]])), 99.5)) or 1e-6
        for c in range(ncol):
            top, bottom = axes[2 * r, c], axes[2 * r + 1, c]
            top.axis("off")
            bottom.axis("off")
            if c >= len(line):
                continue
            top.imshow(tonemap(line[c][1], peak))
            top.set_title(f"{scene}: {line[c][0]}" if c == 0 else line[c][0], fontsize=7)
            im = bottom.imshow(np.where(mask, diffs[c], np.nan), cmap="RdBu_r", vmin=-scale, vmax=scale)
            label = "second reference − reference" if c == len(line) - 1 else "− converged reference"
            bottom.set_title(label, fontsize=6)
        bar = fig.colorbar(im, ax=list(axes[2 * r + 1, :]), fraction=0.025, pad=0.01)
        bar.ax.tick_params(labelsize=6)
        bar.set_label("gray difference (linear)", fontsize=6)
    fig.suptitle(f"Screen-space Burley SSS (Xie 2020), {material}; each image row at one exposure (its converged "
                 "reference's 99.5th percentile); below: differences from the reference inside the SSS mask, one "
                 "colour scale per scene", fontsize=8)
    path = Path(out) / "burley.png"
    save_figure(fig, path)
    return path, rows, refs


def _row(scene: str, method: str, n: int | None, ref: np.ndarray, img: np.ndarray, mask: np.ndarray,
         region_metrics: Callable[..., dict[str, float]]) -> dict[str, Any]:
    m = region_metrics(ref, img, mask)
    return {"scene": scene, "method": method, "spp": n, "psnr_gray": _gray_psnr(ref, img, mask), "rmse": m["rmse"],
            "flip": m["flip"]}


def demo_section(out: Path, progress: Callable[[str], None] | None, ctx: dict[str, Any]) -> str:
    """The demo report's Burley section (``ssskit.report.SECTIONS`` signature): :func:`burley_comparison`
    on ``ctx["backend"]`` as a table and the figure."""
    import html
    import time

    backend = ctx.get("backend") or "numba"
    t0 = time.perf_counter()
    png, rows, refs = burley_comparison(Path(out) / "figures", backend=backend, reference_spp=DEMO_REFERENCE_SPP,
                                        progress=progress)
    seconds = time.perf_counter() - t0
    body = "".join(
        f"<tr><td class=name>{html.escape(r['scene'])}</td><td class=name>{html.escape(r['method'])}</td>"
        f"<td>{r['spp'] if r['spp'] else '-'}</td><td>{r['psnr_gray']:.1f}</td><td>{r['rmse']:.4f}</td>"
        f"<td>{r['flip']:.3f}</td></tr>"
        for r in rows
    )
    ses = ", ".join(f"{html.escape(k)} {v['ref_se']:.1e}" for k, v in refs.items())
    spp = next(iter(refs.values()))["spp"] if refs else 0
    return (
        "<h2>Screen-space Burley SSS by Monte Carlo sampling (Xie et al. 2020)</h2>"
        f"<p class=note>Skin1's Burley profile, the scenes lit from the front ({html.escape(', '.join(refs))}; the "
        "scenes lit only from behind, black without the transmittance pass, are left out: the transmission section "
        "measures that pass) at 160x120 (Mitsuba "
        "G-buffers). Per pixel, radii "
        "from Eq. 21 (c = 2.5715) in the channel with the largest d, the bilateral self-normalised estimator "
        "(Eq. 24), prefiltered mips (Eqs. 22-23, a = 1/16 in Xie's units), at 8, 16 and 64 samples per pixel, "
        f"on the {html.escape(backend)} backend. Errors of the composited image inside the SSS mask against "
        f"the converged pass (exact sampler, {spp} spp, no mips): gray-scale PSNR (dB, as Xie reports; peak = "
        "the reference's), RGB RMSE and FLIP; beside it the separable pass with the kernel fitted to Burley "
        "(appendix A.1). The references are Xie's 2k spp; their own error (RMS over the mask of the difference of two references "
        f"with different seeds, over &radic;2): {ses}. Built in {seconds:.0f} s (references cached "
        "afterwards).</p>"
        "<table><tr><th>scene</th><th>method</th><th>spp</th><th>PSNR gray</th><th>RMSE</th><th>FLIP</th></tr>"
        f"{body}</table><img src='figures/{png.name}'>"
    )
