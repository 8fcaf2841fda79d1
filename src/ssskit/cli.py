"""The ``ssskit`` command line: a thin click layer over the Python API.

stdout carries only the result (``--json`` prints exactly one JSON object); progress and errors go
to stderr. Errors a user can cause print one line ``ssskit: error: ...`` and exit with status 2.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from .errors import SimulationInterrupted, SsskitError

EXIT_USAGE = 2


def _echo_json(data) -> None:
    click.echo(json.dumps(data))


def _progress(msg: str) -> None:
    click.echo(f"  {msg}", err=True)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="ssskit")
def cli() -> None:
    """ssskit: diffusion profiles, separable kernels and screen-space subsurface scattering."""


@cli.command()
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def materials(as_json: bool) -> None:
    """List the preset materials with their coefficients (mm^-1)."""
    from .materials import ARTIST_PRESETS, MATERIALS

    if as_json:
        _echo_json(
            {
                "materials": {name: m.summary() for name, m in MATERIALS.items()},
                "artist_presets": {
                    name: {"sigma_near": p.sigma_near, "sigma_far": p.sigma_far, "weight": p.weight, "source": p.source}
                    for name, p in ARTIST_PRESETS.items()
                },
            }
        )
        return
    click.echo(f"{'material':<10} {'sigma_a [R G B] (mm^-1)':<26} {'sigma_s [R G B] (mm^-1)':<26} {'eta':>4}  mfp [R G B] (mm)")
    for name, m in MATERIALS.items():
        sa = " ".join(f"{v:.4f}" for v in m.sigma_a)
        ss = " ".join(f"{v:.4f}" for v in m.sigma_s)
        mfp = " ".join(f"{v:.3f}" for v in m.mfp_mm)
        click.echo(f"{name:<10} {sa:<26} {ss:<26} {m.eta:>4.2f}  {mfp}")
    click.echo("\nartist-friendly two-Gaussian presets (paper Table 2): " + ", ".join(ARTIST_PRESETS.names()))


@cli.command()
@click.option("--material", "material", metavar="NAME|FILE", help="Preset name or .toml/.json material file.")
@click.option(
    "--model",
    type=click.Choice(["dipole", "burley", "gaussians", "deon2007", "montecarlo"], case_sensitive=False),
    default="dipole",
    show_default=True,
    help="Profile model (deon2007 is a fixed skin preset and needs no material).",
)
@click.option("--configuration", default="searchlight", show_default=True, help="Burley d from Xie 2020 Eq. 5: searchlight, diffuse-transmission or dmfp.")
@click.option("--gaussians", "n_gaussians", type=click.IntRange(1, 16), default=6, show_default=True, help="Number of Gaussians for --model gaussians.")
@click.option("--photons", type=click.IntRange(1, 10**12), default=200_000, show_default=True, help="Photons per channel for --model montecarlo (cached).")
@click.option("--points", type=click.IntRange(2, 1_000_000), default=256, show_default=True, help="Number of radii (bin centres).")
@click.option("--r-max", "r_max", type=float, default=None, help="Largest radius in mm [default: where every channel holds 99.9% of its energy].")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object: r_mm and channels R/G/B with Rd (mm^-2) and total_Rd.")
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="Write the table to FILE.csv or FILE.npz.")
@click.option("--plot", type=click.Path(dir_okay=False), default=None, help="Write a plot to FILE.png (or .pdf/.svg).")
def profile(material, model, configuration, n_gaussians, photons, points, r_max, as_json, out, plot) -> None:
    """Diffuse reflectance profile R(r) of a material, per RGB channel."""
    from .io import check_suffix, save_profile_table
    from .profiles import MATERIAL_FREE_MODELS, profile_for_material

    if out:
        check_suffix(out, (".csv", ".npz"), "--out")
    if plot:
        check_suffix(plot, (".png", ".pdf", ".svg"), "--plot")
    if material is None and model.lower() not in MATERIAL_FREE_MODELS:
        raise SsskitError(f"--material is required for --model {model}")
    options = {}
    if model.lower() == "burley":
        options["configuration"] = configuration
    elif model.lower() == "gaussians":
        options["n"] = n_gaussians
    elif model.lower() == "montecarlo":
        options["photons"] = photons
    prof = profile_for_material(material, model, **options)
    if r_max is None:
        r_max = float(max(prof.radius_at_fraction(0.999)))
    elif not (r_max > 0 and r_max < float("inf")):
        raise SsskitError(f"--r-max must be a positive number of mm, got {r_max}")
    # bin centres: (i + 1/2) r_max / points, so 1/r profiles stay finite
    import numpy as np

    r = (np.arange(points) + 0.5) * (r_max / points)
    data = prof.to_dict(r)
    data["material"] = material
    if out:
        save_profile_table(out, r, prof.eval(r), {k: v for k, v in data.items() if k not in ("r_mm", "channels")}
                           | {"total_Rd": [c["total_Rd"] for c in data["channels"].values()]})
    if plot:
        from .plots import plot_profiles

        plot_profiles([prof], f"{prof.name} ({prof.model})", plot)
    if as_json:
        _echo_json(data)
        return
    click.echo(f"# {prof.model} profile of {prof.name}; r in mm, Rd in mm^-2")
    click.echo("# total Rd (R, G, B): " + ", ".join(f"{v:.6f}" for v in prof.total_rd()))
    if not out:
        click.echo("r_mm,Rd_R,Rd_G,Rd_B")
        for ri, row in zip(r, prof.eval(r)):
            click.echo(f"{ri:.6g}," + ",".join(f"{v:.6e}" for v in row))
    else:
        click.echo(f"# wrote {out}")


@cli.command()
@click.option("--material", "materials_", metavar="NAME|FILE", multiple=True, required=True,
              help="Preset name or material file; repeat or comma-separate for a sweep.")
@click.option("--channel", type=click.Choice(["R", "G", "B", "all"], case_sensitive=False), default="all", show_default=True)
@click.option("--photons", type=click.IntRange(1, 10**12), default=10_000_000, show_default=True, help="Photons per channel (supplement F: 10^7).")
@click.option("--seed", type=click.IntRange(0, 2**63 - 1), default=1, show_default=True)
@click.option("--threads", type=click.IntRange(1, 1024), default=None, help="numba threads [default: all cores].")
@click.option("--jobs", type=click.IntRange(1, 1024), default=1, show_default=True, help="Local processes for a sweep of several materials.")
@click.option("--scheduler", default=None, metavar="ADDRESS", help="Run a sweep on a dask.distributed cluster (extra: ssskit[cluster]).")
@click.option("--batch-size", type=click.IntRange(1, 10**9), default=10_000, show_default=True, help="Photons per random stream / standard-error batch.")
@click.option("--resume", is_flag=True, help="Continue an interrupted run with the same inputs.")
@click.option("--no-cache", is_flag=True, help="Neither read nor write the on-disk cache.")
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="Write FILE.npz (one material) with r_mm, Rd, Rd_se per channel.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def simulate(materials_, channel, photons, seed, threads, jobs, scheduler, batch_size, resume, no_cache, out, as_json) -> None:
    """Monte Carlo (MCML) diffuse reflectance profiles with the supplement's settings."""
    import numpy as np

    from .io import check_suffix, save_arrays
    from .materials import get_material
    from .profiles.montecarlo import simulate_many, simulate_material

    names = [n.strip() for item in materials_ for n in item.split(",") if n.strip()]
    mats = [get_material(n) for n in names]
    if out:
        check_suffix(out, (".npz",), "--out")
        if len(mats) > 1:
            raise SsskitError("--out takes a single material; use --json for a sweep")
    if len(mats) == 1 and scheduler is None:
        runs = {mats[0].name: simulate_material(mats[0], channel, photons=photons, seed=seed, threads=threads,
                                                progress=True, resume=resume, use_cache=not no_cache,
                                                batch_size=batch_size)}
    else:
        if resume or no_cache or threads is not None:
            raise SsskitError("--resume, --no-cache and --threads apply to a single material (a sweep runs one thread per job)")
        runs = simulate_many(mats, channel, photons=photons, seed=seed, jobs=jobs, batch_size=batch_size, progress=True,
                             scheduler=scheduler)

    def one(results):
        first = next(iter(results.values()))
        seconds = sum(r.seconds for r in results.values())
        total = sum(r.photons for r in results.values())
        return {
            "r_mm": first.r_mm.tolist(),
            "channels": {ch: r.to_dict() for ch, r in results.items()},
            "photons": first.photons,
            "seconds": seconds,
            "photons_per_second": total / seconds if seconds > 0 else None,
            "cached": all(r.extra.get("cached", False) for r in results.values()),
        }

    data = {name: one(res) | {"material": name} for name, res in runs.items()}
    if out:
        res = runs[mats[0].name]
        save_arrays(out, r_mm=next(iter(res.values())).r_mm, channels=np.array(list(res)),
                    Rd=np.stack([r.rd for r in res.values()], axis=-1),
                    Rd_se=np.stack([r.rd_se for r in res.values()], axis=-1),
                    total_Rd=np.array([r.total_rd for r in res.values()]),
                    total_Rd_se=np.array([r.total_rd_se for r in res.values()]),
                    Rsp=np.array([r.rsp for r in res.values()]))
    if as_json:
        _echo_json(data[mats[0].name] if len(mats) == 1 else {"materials": data})
        return
    for name, d in data.items():
        for ch, c in d["channels"].items():
            click.echo(f"{name:<10} {ch}  total Rd = {c['total_Rd']:.5f} ± {c['total_Rd_se']:.5f}   Rsp = {c['Rsp']:.4f}")
        rate = d["photons_per_second"]
        click.echo(f"{name:<10}    {d['photons']} photons/channel, {d['seconds']:.1f} s"
                   + (f", {rate:,.0f} photons/s" if rate else "") + (" (cached)" if d["cached"] else ""))
    if out:
        click.echo(f"wrote {out}")


@cli.command("xie-c")
@click.option("--points", type=click.IntRange(100, 10_000_000), default=100_000, show_default=True, help="Number of xi samples.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def xie_c(points: int, as_json: bool) -> None:
    """Refit c of Xie 2020 Eq. 21 (least squares and minimax) and report the CDF errors."""
    import numpy as np

    from .sampling import XIE_C, fit_xie_c, xie_cdf_error

    c_lsq, e_lsq = fit_xie_c("lsq", points)
    c_mm, e_mm = fit_xie_c("minimax", points)
    xi = (np.arange(points) + 0.5) / points
    e_paper = float(np.max(np.abs(xie_cdf_error(XIE_C, xi))))
    data = {
        "paper": {"c": XIE_C, "max_cdf_error": e_paper},
        "least_squares": {"c": c_lsq, "max_cdf_error": e_lsq},
        "minimax": {"c": c_mm, "max_cdf_error": e_mm},
    }
    if as_json:
        _echo_json(data)
        return
    for name, d in data.items():
        click.echo(f"{name:<14} c = {d['c']:.6f}   max |cdf(g(xi)) - xi| = {d['max_cdf_error']:.6f}")


_PROFILE_MODELS = click.Choice(["montecarlo", "dipole", "burley", "gaussians"], case_sensitive=False)


def _kernel_profile(material: str, model: str, photons: int):
    from .profiles import profile_for_material

    options = {"photons": photons} if model.lower() == "montecarlo" else {}
    return profile_for_material(material, model, **options)


@cli.command()
@click.option("--material", metavar="NAME|FILE", default=None, help="Preset name or material file (not needed for jimenez2012 / artist presets).")
@click.option("--method", required=True, metavar="METHOD", help="Kernel method: svd, svd_l1, gaussians, preintegrated, preintegrated_svd, artist, guided, jimenez2012, burley_fit.")
@click.option("--model", type=_PROFILE_MODELS, default="montecarlo", show_default=True, help="Profile the kernel approximates.")
@click.option("--photons", type=click.IntRange(1000, 10**12), default=200_000, show_default=True, help="Monte Carlo photons per channel (cached).")
@click.option("--rank", type=click.IntRange(1, 64), default=None, help="Rank N (svd, svd_l1, preintegrated_svd) or number of Gaussians (gaussians).")
@click.option("--k", "k_guide", type=click.FloatRange(0, 8), default=None, help="Guide exponent k for guided (paper: 0..4) [default: 2].")
@click.option("--taps", type=click.IntRange(3, 255), default=None, help="Odd number of taps for jimenez2012 [default: 11; presets 11, 17, 25].")
@click.option("--preset", default=None, help="Artist preset: 'close fit', 'production' or 'fit' [default: close fit].")
@click.option("--error", "error_fn", type=click.Choice(["difference", "ratio", "derivative"]), default=None, help="burley_fit error function (Xie 2020 Eqs. 25-27) [default: difference].")
@click.option("--size", "grid_n", type=click.IntRange(3, 2001), default=201, show_default=True, help="Cells across the kernel grid (odd).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="Write FILE.npz or FILE.json.")
def kernel(material, method, model, photons, rank, k_guide, taps, preset, error_fn, grid_n, as_json, out) -> None:
    """A separable kernel approximation of a material's profile."""
    from .io import check_suffix
    from .kernels import METHODS, build_kernel, save_kernel

    if out:
        check_suffix(out, (".npz", ".json"), "--out")
    m = METHODS.get(method)
    params: dict = {}
    given = {"--rank": rank, "--k": k_guide, "--taps": taps, "--preset": preset, "--error": error_fn}
    allowed = {"svd": {"--rank": "rank"}, "svd_l1": {"--rank": "rank"}, "preintegrated_svd": {"--rank": "rank"},
               "gaussians": {"--rank": "count"}, "guided": {"--k": "k"}, "jimenez2012": {"--taps": "taps"},
               "artist": {"--preset": "preset"}, "burley_fit": {"--error": "error"}}.get(m.name, {})
    for opt, value in given.items():
        if value is None:
            continue
        if opt not in allowed:
            raise SsskitError(f"{opt} does not apply to --method {m.name}")
        params[allowed[opt]] = value
    if grid_n % 2 == 0:
        raise SsskitError(f"--size must be odd (the origin sits at a cell centre), got {grid_n}")
    prof = None
    if material is not None:
        prof = _kernel_profile(material, model, photons)
    elif m.needs_profile or (m.name == "artist" and str(params.get("preset", "")).lower() == "fit"):
        raise SsskitError(f"--material is required for --method {m.name}")
    k = build_kernel(m.name, prof, n=grid_n, **params)
    if out:
        save_kernel(k, out)
    if as_json:
        d = k.to_dict()
        d["material"] = material
        _echo_json(d)
        return
    click.echo(f"# {m.name} kernel ({m.description})" + (f" of {prof.name} ({prof.model})" if prof else ""))
    click.echo(f"# rank {k.rank}, {k.convolutions_1d} 1D convolutions; total per channel: "
               + ", ".join(f"{v:.6f}" for v in k.total()))
    if hasattr(k, "offsets_mm"):
        click.echo("offset_mm,w_R,w_G,w_B")
        for o, w in zip(k.offsets_mm, k.weights):
            click.echo(f"{o:.6f}," + ",".join(f"{v:.6f}" for v in w))
    elif prof is not None:
        cmp = k.compare(prof)
        click.echo("# relative Frobenius error vs the discrete Rd: " + ", ".join(f"{v:.4g}" for v in cmp["relative_frobenius"]))
    if out:
        click.echo(f"# wrote {out}")


@cli.command()
@click.option("--material", required=True, metavar="NAME|FILE", help="Preset name or material file.")
@click.option("--signal", default="edge", show_default=True, help="edge, edge-rotated, disk, line or texture.")
@click.option("--methods", default="svd:1,svd:3,gaussians:1,gaussians:6,preintegrated,guided:2,artist:close fit,jimenez2012",
              show_default=True, help="Comma-separated method specs name[:value] (svd:3, guided:0, artist:production...).")
@click.option("--model", type=_PROFILE_MODELS, default="montecarlo", show_default=True, help="Profile giving the ground truth.")
@click.option("--photons", type=click.IntRange(1000, 10**12), default=200_000, show_default=True, help="Monte Carlo photons per channel (cached).")
@click.option("--size", type=click.IntRange(32, 4096), default=256, show_default=True, help="Image size in pixels.")
@click.option("--no-perceptual", is_flag=True, help="Skip SSIM and FLIP.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object: method -> metrics.")
def evaluate(material, signal, methods, model, photons, size, no_perceptual, as_json) -> None:
    """Each method's error against the exact 2D convolution on a test signal."""
    from .evaluate import evaluate as run
    from .scenes import SIGNALS

    SIGNALS.get(signal)
    specs = [s for s in (x.strip() for x in methods.split(",")) if s]
    from .kernels import parse_method_spec

    for s in specs:
        parse_method_spec(s)
    prof = _kernel_profile(material, model, photons)
    ev = run(prof, signal, specs, size=size, perceptual=not no_perceptual,
             progress=None if as_json else (lambda m: _progress(f"method {m}")))
    if as_json:
        _echo_json(ev.to_json())
        return
    click.echo(f"# {prof.name} ({prof.model}), signal {signal}, {size}x{size} px at {ev.pixel_mm:.4g} mm/px")
    cols = ["relative_rmse", "psnr"] + ([] if no_perceptual else ["ssim", "flip"])
    click.echo(f"{'method':24s} conv1d " + " ".join(f"{c:>13s}" for c in cols))
    for label, r in ev.results.items():
        click.echo(f"{label:24s} {r['convolutions_1d']:6d} " + " ".join(f"{r[c]:13.5g}" for c in cols))


@cli.command()
@click.argument("names", nargs=-1)
@click.option("--material", default="skin1", show_default=True, metavar="NAME|FILE", help="Material of the figures.")
@click.option("--model", type=_PROFILE_MODELS, default="montecarlo", show_default=True)
@click.option("--photons", type=click.IntRange(1000, 10**12), default=200_000, show_default=True, help="Monte Carlo photons per channel (cached).")
@click.option("--out", type=click.Path(file_okay=False), default="ssskit-out/figures", show_default=True)
def figures(names, material, model, photons, out) -> None:
    """Regenerate the papers' figures (fig2 fig4 fig5 fig7 figS5; all by default)."""
    from .figures import FIGURES, make_figures

    for n in names:
        FIGURES.get(n)
    prof = _kernel_profile(material, model, photons)
    written = make_figures(list(names), out, prof, progress=_progress)
    for paths in written.values():
        for p in paths:
            click.echo(str(p))


@cli.command()
@click.option("--scene", required=True, metavar="NAME|GBUFFER.exr", help="Built-in scene (sphere, slab, ear, bumpy) or a G-buffer EXR.")
@click.option("--material", default="skin1", show_default=True, metavar="NAME|FILE", help="Preset name or material file.")
@click.option("--kernel", "kernel_spec", default="preintegrated", show_default=True, metavar="METHOD", help="Kernel method spec name[:value] (preintegrated, svd:2, artist:production, jimenez2012...).")
@click.option("--taps", type=click.IntRange(1, 255), default=7, show_default=True, help="Taps per 1D pass (odd).")
@click.option("--tap-method", type=click.Choice(["importance", "uniform", "quadratic"]), default="importance", show_default=True, help="Tap placement.")
@click.option("--jitter", type=click.FloatRange(0, 1), default=0.1, show_default=True, help="Jitter radius as a fraction of the kernel size (paper: 0.1, 0.3 for close-ups).")
@click.option("--depth-mode", type=click.Choice(["gaussian", "follow", "none"]), default=None, help="Depth test [default: gaussian for artist kernels, follow otherwise].")
@click.option("--size", default="256x192", show_default=True, metavar="WxH", help="Image size of a built-in scene.")
@click.option("--spp", type=click.IntRange(1, 4096), default=32, show_default=True, help="Samples per pixel of the G-buffer render.")
@click.option("--frame", type=click.IntRange(0, 100000), default=0, show_default=True, help="Frame along the scene's camera orbit (and jitter seed).")
@click.option("--seed", type=click.IntRange(0, 2**31 - 1), default=0, show_default=True, help="Random seed (renders and jitter).")
@click.option("--model", type=_PROFILE_MODELS, default="dipole", show_default=True, help="Profile the kernel approximates.")
@click.option("--reference", is_flag=True, help="Also path-trace the scene (Mitsuba volpathmis; cached) and compare.")
@click.option("--reference-spp", type=click.IntRange(1, 1 << 20), default=64, show_default=True, help="Samples per pixel of the path-traced reference.")
@click.option("--save-gbuffer", type=click.Path(dir_okay=False), default=None, help="Also write the G-buffer as a multi-layer EXR.")
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="Write the image: FILE.exr (linear, with sss/exact/reference layers) or FILE.png (tone-mapped).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object with settings and error metrics.")
def render(scene, material, kernel_spec, taps, tap_method, jitter, depth_mode, size, spp, frame, seed, model, reference,
           reference_spp, save_gbuffer, out, as_json) -> None:
    """Screen-space separable SSS of a scene, with errors against the exact 2D convolution."""
    from .io import check_suffix
    from .kernels import parse_method_spec
    from .render import render as run
    from .render import save_image

    if out:
        check_suffix(out, (".exr", ".png"), "--out")
    if save_gbuffer:
        check_suffix(save_gbuffer, (".exr",), "--save-gbuffer")
    if taps % 2 == 0:
        raise SsskitError(f"--taps must be odd (a centre tap), got {taps}")
    try:
        width, height = (int(v) for v in size.lower().split("x"))
    except ValueError:
        raise SsskitError(f"--size must look like 256x192, got {size!r}") from None
    parse_method_spec(kernel_spec)
    if str(scene).lower().endswith(".exr") and not Path(scene).is_file():
        raise SsskitError(f"G-buffer file {scene!r} does not exist")
    res = run(scene, material=material, kernel=kernel_spec, taps=taps, tap_method=tap_method, jitter=jitter,
              width=width, height=height, spp=spp, seed=seed, frame=frame, model=model, depth_mode=depth_mode,
              reference=reference, reference_spp=reference_spp, progress=None if as_json else _progress)
    if save_gbuffer:
        res.gbuffer.save(save_gbuffer)
    if out:
        layers = {"sss": res.sss, "diffuse": res.gbuffer.diffuse}
        if res.exact is not None:
            layers["exact"] = res.gbuffer.composite(res.exact)
        if res.reference is not None:
            layers["reference"] = res.reference
        save_image(out, res.image, layers)
    if as_json:
        _echo_json({"settings": res.settings, "metrics": _jsonable_metrics(res.metrics),
                    "taps": res.taps.to_dict()})
        return
    s = res.settings
    click.echo(f"# {s['scene']}: {s['material']} ({s['model']}), {s['kernel']} with {s['taps']} {s['tap_method']} taps, "
               f"jitter {s['jitter']:g}, {s['size'][0]}x{s['size'][1]}")
    for against, m in res.metrics.items():
        click.echo(f"vs {against:12s} " + "  ".join(f"{k} {v:.4g}" for k, v in m.items() if isinstance(v, float)))
    if out:
        click.echo(f"# wrote {out}")


def _jsonable_metrics(metrics: dict) -> dict:
    import math

    def fix(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: fix(x) for k, x in v.items()}
        return v

    return fix(metrics)


@cli.command()
@click.option("--out", type=click.Path(file_okay=False), default="ssskit-out/demo", show_default=True, help="Output folder.")
@click.option("--photons", type=click.IntRange(1000, 10**10), default=None, help="Monte Carlo photons per channel [default: 200,000].")
@click.option("--full", is_flag=True, help="Monte Carlo with the supplement's 10^7 photons per channel (slow the first time, then cached).")
def demo(out: str, photons: int | None, full: bool) -> None:
    """The main job: build the report (figures + index.html) on built-in defaults."""
    from .report import DEMO_PHOTONS, build_report

    if full and photons is not None:
        raise SsskitError("give either --full or --photons, not both")
    n = 10_000_000 if full else (photons or DEMO_PHOTONS)
    click.echo(f"ssskit demo: writing the report to {out}/", err=True)
    index = build_report(Path(out), progress=_progress, photons=n, progress_bars=True)
    click.echo(str(index))


def main(argv: list[str] | None = None) -> int:
    """Entry point: runs the CLI, turning user errors into one line on stderr and exit status 2."""
    try:
        cli.main(args=argv, prog_name="ssskit", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except SimulationInterrupted as exc:
        click.echo(f"ssskit: {exc} (--resume)", err=True)
        return 130
    except click.exceptions.Abort:
        click.echo("ssskit: aborted", err=True)
        return 130
    except click.ClickException as exc:
        message = exc.format_message().replace("\n", " ")
        click.echo(f"ssskit: error: {message}", err=True)
        return EXIT_USAGE
    except SsskitError as exc:
        click.echo(f"ssskit: error: {exc}", err=True)
        return EXIT_USAGE
    except KeyboardInterrupt:
        click.echo("ssskit: interrupted", err=True)
        return 130
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
