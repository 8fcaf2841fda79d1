"""Xie et al. 2020 Fig. 6: the analytic inverse of Eq. 20 against the approximation of Eq. 21, and a
beam-light disk of 1 cm radius rendered with both samplers by the screen-space Burley pass.

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


def fig6_xie_inverse(out: Path, profile, progress=None, spp: int = 256) -> list[Path]:
    """Xie 2020 Fig. 6 (module docstring): ``xie_fig6.png``."""
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
    images = {"exact sampler": burley_sss(gb, params, spp=spp, sampler="exact", mips=False, seed=3),
              f"xie sampler, c = {CS[0]}": burley_sss(gb, params, spp=spp, sampler="xie", c=CS[0], mips=False, seed=3)}
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
