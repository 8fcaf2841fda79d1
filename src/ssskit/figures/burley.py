"""Xie et al. 2020 Fig. 6: the analytic inverse of Eq. 20 against the approximation of Eq. 21, and a
beam-light disk of 1 cm radius rendered with both samplers by the screen-space Burley pass; and the
demo's Burley comparison (:func:`burley_comparison`, :func:`demo_section`).

Parameters: the figure's ``profile`` when it is a Burley profile (``--model burley``), else Xie's
Fig. 5 albedo A = 0.9 with diffuse mean free paths 20, 10, 5 mm (Eq. 5, configuration 3: d = 1.42,
0.71, 0.36 mm; Fig. 5's ell = 1 mm would scatter less than a pixel here). The disk: a fronto-parallel
plane of one profile id at 500 mm, 8 pixels per mm (256 x 256 pixels, 32 x 32 mm), irradiance 1
inside r <= 10 mm and 0 outside; the pass runs with 256 samples
per pixel, no mips, the same seed for both samplers, and is compared with its exact limit
(:func:`ssskit.pipeline.burley.burley_exact`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..backends import DEFAULT_BACKEND
from .plots import pyplot, save_figure

#: c values of the inverse panel: Xie's least-squares 2.5715 and Unreal's 2.6
CS = (2.5715, 2.6)


def _params(profile):
    from ..screenspace import BurleyParams

    if getattr(profile, "model", "") == "burley":
        return BurleyParams.from_profile(profile)
    return BurleyParams.from_dmfp(0.9, (20.0, 10.0, 5.0))


def beam_disk(size: int = 256, px_per_mm: float = 8.0, radius_mm: float = 10.0):
    """The beam-light G-buffer: a plane at 500 mm, irradiance 1 inside ``radius_mm`` of the centre."""
    from ..screenspace import Camera, GBuffer

    z = 500.0
    yy, xx = (np.mgrid[0:size, 0:size] + 0.5 - size / 2) / px_per_mm
    lit = (xx**2 + yy**2 <= radius_mm**2).astype(np.float32)
    e = np.repeat(lit[..., None], 3, axis=2)
    f = px_per_mm * z
    return GBuffer(diffuse=e, albedo=np.ones_like(e), depth=np.full((size, size), z, np.float32),
                   profile_id=np.ones((size, size), np.uint32), camera=Camera(size, size, f, f, size / 2, size / 2))


def fig6_xie_inverse(out: Path, profile, progress=None, spp: int = 256, backend: str = DEFAULT_BACKEND) -> list[Path]:
    """Xie 2020 Fig. 6 (module docstring): ``xie_fig6.png``; the Burley pass runs on ``backend``."""
    from ..metrics import tonemap
    from ..pipeline.burley import burley_exact
    from ..profiles.burley import burley_inverse_cdf
    from ..sampling.burley import xie_g
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
    common = dict(spp=spp, mips=False, seed=3, backend=backend)
    images = {"exact sampler": burley_sss(gb, params, sampler="exact", **common),
              f"xie sampler, c = {CS[0]}": burley_sss(gb, params, sampler="xie", c=CS[0], **common)}
    ref = burley_exact(gb, params)
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


#: samples per pixel of the Burley pass shown per scene (issue 13: 8/16/64 spp)
DEMO_SPPS = (8, 16, 64)


def _gray_psnr(reference: np.ndarray, test: np.ndarray, mask: np.ndarray) -> float:
    """Gray-scale PSNR inside the mask (Xie 2020 Sec. 6 reports gray-scale PSNR): the channel mean."""
    from ..metrics import psnr

    r = np.repeat(reference[mask].mean(axis=-1)[None, :, None], 3, axis=2)
    t = np.repeat(test[mask].mean(axis=-1)[None, :, None], 3, axis=2)
    return psnr(r, t)


def burley_comparison(out: Path, material: str = "skin1", scenes=None, width: int = 160, height: int = 120,
                      spp: int = 16, spps=DEMO_SPPS, reference_spp: int = 4096, burley=None,
                      progress=None):
    """Every scene with the Burley pass at ``spps`` samples per pixel beside its converged reference
    (:func:`ssskit.pipeline.burley.burley_reference`: exact sampler, ``reference_spp``, no mips) and the
    separable pass with the ``burley_fit`` kernel (Xie 2020 appendix A.1); writes ``burley.png``.

    ``burley``: the pass's :class:`BurleySettings` (default: Xie's pass, the xie sampler with mips).
    Errors against the converged reference on the composited images inside the SSS mask: gray-scale
    PSNR (as Xie reports), RGB RMSE and FLIP. Returns (png path, rows) with rows =
    [{scene, method, spp, psnr_gray, rmse, flip}].
    """
    from ..metrics import region_metrics, tonemap
    from ..pipeline import RenderSettings, render
    from ..pipeline.burley import burley_reference
    from ..scenes import SCENES
    from ..screenspace import BurleySettings, burley_sss
    from ..screenspace.burley import burley_params_for_material

    say = progress or (lambda msg: None)
    burley = BurleySettings(sampler="xie") if burley is None else burley
    params = burley_params_for_material(material)
    rows, grid = [], []
    for scene in list(scenes or SCENES.names()):
        say(f"Burley pass: {scene}, G-buffer and separable burley_fit")
        sep = render(scene, RenderSettings(material=material, model="burley", kernel="burley_fit", width=width,
                                           height=height, spp=spp, exact=False, perceptual=False))
        gb = sep.gbuffer
        mask = gb.mask
        say(f"Burley pass: {scene}, converged reference ({reference_spp} spp, cached)")
        ref = gb.composite(burley_reference(gb, params, spp=reference_spp, backend=burley.backend))
        line = [("separable, burley_fit", sep.image)]
        for n in spps:
            img = gb.composite(burley_sss(gb, params, burley.replace(spp=n)))
            line.append((f"Burley, {n} spp", img))
            rows.append(_row(scene, f"Burley {burley.sampler}{' + mips' if burley.mips else ''}", n, ref, img, mask,
                             region_metrics))
        rows.append(_row(scene, "separable burley_fit", None, ref, sep.image, mask, region_metrics))
        line.append((f"converged ({reference_spp} spp)", ref))
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
    fig.suptitle(f"Screen-space Burley SSS (Xie 2020), {material}; tone-mapped to each converged reference's peak",
                 fontsize=9)
    path = Path(out) / "burley.png"
    save_figure(fig, path)
    return path, rows


def _row(scene, method, n, ref, img, mask, region_metrics) -> dict:
    m = region_metrics(ref, img, mask)
    return {"scene": scene, "method": method, "spp": n, "psnr_gray": _gray_psnr(ref, img, mask), "rmse": m["rmse"],
            "flip": m["flip"]}


def demo_section(out: Path, progress, ctx: dict) -> str:
    """The demo report's Burley section (``ssskit.report.SECTIONS`` signature): :func:`burley_comparison`
    as a table and the figure."""
    import html

    png, rows = burley_comparison(Path(out) / "figures", progress=progress)
    body = "".join(
        f"<tr><td class=name>{html.escape(r['scene'])}</td><td class=name>{html.escape(r['method'])}</td>"
        f"<td>{r['spp'] if r['spp'] else '-'}</td><td>{r['psnr_gray']:.1f}</td><td>{r['rmse']:.4f}</td>"
        f"<td>{r['flip']:.3f}</td></tr>"
        for r in rows
    )
    return (
        "<h2>Screen-space Burley SSS by Monte Carlo sampling (Xie et al. 2020)</h2>"
        "<p class=note>Skin1's Burley profile. Per pixel, radii from Eq. 21 (c = 2.5715) in the channel with "
        "the largest d, bilateral self-normalised estimator (Eq. 24), prefiltered mips (Eqs. 22-23). Errors "
        "inside the SSS mask against the converged pass (exact sampler, 4096 spp, no mips): gray-scale PSNR "
        "(dB, as Xie reports), RMSE and FLIP; beside it the separable pass with the kernel fitted to Burley "
        "(appendix A.1).</p>"
        "<table><tr><th>scene</th><th>method</th><th>spp</th><th>PSNR gray</th><th>RMSE</th><th>FLIP</th></tr>"
        f"{body}</table><img src='figures/{png.name}'>"
    )
