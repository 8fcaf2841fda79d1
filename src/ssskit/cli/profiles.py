"""``ssskit profile``, ``ssskit simulate`` and ``ssskit xie-c``: diffusion profiles and their sampling."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import click

from ..errors import SsskitError
from ..quantities import LENGTH_MM, refuse_unused

if TYPE_CHECKING:
    from ..materials import LayeredMaterial, Material
    from ..profiles.base import RGBProfile
from .options import (
    DEFAULT_MODEL,
    DEFAULT_PHOTONS,
    RegistryName,
    echo_json,
    examples,
    given,
    json_option,
    material_option,
    model_option,
    option_name,
    out_option,
    photons_option,
)

#: the largest radius ``profile --r-max`` takes (mm): ten of the longest mean free path any model takes
R_MAX_MM = 1e7


def resolve_profile(ctx: click.Context, material: str | Material | LayeredMaterial | None, model: str,
                    options: dict[str, tuple[str, object]], needed_by: str = "") -> Callable[[], RGBProfile]:
    """The profile of ``model`` for ``material``, passing each option the model takes: every command's one
    statement of the model's rules.

    --material is refused by a material-free model (deon2007) and required by every other one (``needed_by``: what
    needs it, ``--model M`` by default). ``options``: {click parameter name: (factory parameter, value)}. An option
    applies to the models whose factory (the MODELS registry) takes its parameter; given for another model, it is
    refused. Returns a function that computes the profile (all checks are done first).
    """
    from ..export.readers import model_parameters
    from ..profiles import MATERIAL_FREE_MODELS, MODELS, profile_for_material, refuse_material

    free = model.lower() in MATERIAL_FREE_MODELS
    refuse_material(model, material if given(ctx, "material") else None, f"--model {model}", "--material",
                    SsskitError)
    if not free and material is None:
        raise SsskitError(f"--material is required for {needed_by or f'--model {model}'}")
    params = model_parameters(model)
    kwargs = {}
    for name, (param, value) in options.items():
        if param in params:
            kwargs[param] = value
        elif given(ctx, name):
            refuse_unused([option_name(ctx, name)], "--model", [m for m in MODELS.names() if param in model_parameters(m)],
                          model)
    return lambda: profile_for_material(None if free else material, model, **kwargs)


@click.command(epilog=examples(
    "ssskit profile --material skin1 --model dipole --json",
    "ssskit profile --material my_material.toml --model burley --out skin.csv --plot skin.png",
    "ssskit profile --model deon2007 --out deon.npz",
    "ssskit profile --material marble --model montecarlo --photons 1000000 --plot m.png"))
@material_option(help="Preset name or .toml/.json material file (not for fixed presets such as deon2007).")
@model_option(DEFAULT_MODEL, help="Profile model (deon2007 is a fixed skin preset and takes no material).")
@click.option("--configuration", default="searchlight", show_default=True,
              help="--model burley: d from Xie 2020 Eq. 5: searchlight, diffuse-transmission or dmfp.")
@click.option("--albedo-source", type=click.Choice(("montecarlo", "dipole")), default="montecarlo", show_default=True,
              help="--model burley: A from MCML's total diffuse reflectance (--photons) or the dipole's.")
@click.option("--gaussians", "n_gaussians", type=click.IntRange(1, 16), default=6, show_default=True,
              help="--model gaussians: number of Gaussians.")
@photons_option(DEFAULT_PHOTONS, help="--model montecarlo (and burley's A): photons per channel (shipped for the presets at 10^7, else cached).")
@click.option("--grid-fraction", type=click.FloatRange(0, 1, min_open=True, max_open=True), default=None,
              help="--model montecarlo: lengthen the 32-MFP grid until it holds this fraction of the light (e.g. 0.999).")
@click.option("--roughness", type=click.FloatRange(0, 1), default=0.0, show_default=True,
              help="--model montecarlo: Beckmann alpha of a rough surface (0: MCML's smooth one; "
                   "the 3D scenes use 0.15).")
@click.option("--points", type=click.IntRange(2, 1_000_000), default=256, show_default=True, help="Number of radii (bin centres).")
@click.option("--r-max", "r_max", type=float, default=None,
              help=f"Largest radius in mm, at most {R_MAX_MM:g} [default: where every channel holds 99.9% of its energy].")
@json_option("Print one JSON object: r_mm and channels R/G/B with Rd (mm^-2) and total_Rd.")
@out_option((".csv", ".npz"), "Write the table to FILE.csv or FILE.npz.")
@out_option((".png", ".pdf", ".svg"), "Write a plot to FILE.png (or .pdf/.svg).", name="--plot")
@click.pass_context
def profile(ctx: click.Context, material: str | None, model: str, configuration: str, albedo_source: str,
            n_gaussians: int, photons: int, grid_fraction: float | None, roughness: float, points: int,
            r_max: float | None, as_json: bool, out: str | None, plot: str | None) -> None:
    """Diffuse reflectance profile R(r) of a material, per RGB channel."""
    import numpy as np

    from ..io import save_profile_table

    if albedo_source == "dipole" and model.lower() == "burley" and given(ctx, "photons"):  # (A: the dipole's closed form)
        refuse_unused(["--photons"], "--albedo-source", ("montecarlo",), albedo_source)
    if r_max is not None:
        LENGTH_MM.within(hi=R_MAX_MM, reason="10 times the longest mean free path a model takes").check(r_max, "--r-max")
    make = resolve_profile(ctx, material, model, {"configuration": ("configuration", configuration),
                                                  "albedo_source": ("albedo_source", albedo_source),
                                                  "n_gaussians": ("n", n_gaussians),
                                                  "photons": ("photons", photons),
                                                  "grid_fraction": ("grid_fraction", grid_fraction),
                                                  "roughness": ("roughness", roughness)})
    prof = make()
    if r_max is None:
        r_max = float(max(prof.radius_at_fraction(0.999)))
    # bin centres: (i + 1/2) r_max / points, so 1/r profiles stay finite
    r = (np.arange(points) + 0.5) * (r_max / points)
    data = prof.to_dict(r)
    data["material"] = material
    if out:
        save_profile_table(out, r, prof.eval(r), {k: v for k, v in data.items() if k not in ("r_mm", "channels")}
                           | {"total_Rd": [c["total_Rd"] for c in data["channels"].values()]})
    if plot:
        from ..figures.plots import plot_profiles

        plot_profiles([prof], f"{prof.name} ({prof.model})", plot)
    if as_json:
        echo_json(data)
        return
    click.echo(f"# {prof.model} profile of {prof.name}; r in mm, Rd in mm^-2")
    click.echo("# total Rd (R, G, B): " + ", ".join(f"{c['total_Rd']:.6f}" for c in data["channels"].values()))
    from ..profiles.montecarlo import MonteCarloProfile

    mc = [c for c in prof.channels if isinstance(c, MonteCarloProfile)]
    if len(mc) == len(prof.channels):
        # a Monte Carlo profile: R(r) integrates to the light inside the grid; MCML's Rd adds the rest
        click.echo("# total Rd in grid (R, G, B): " + ", ".join(f"{c.total_rd():.6f}" for c in mc)
                   + "   with overflow: " + ", ".join(f"{c.total_rd_with_overflow():.6f}" for c in mc)
                   + "   beyond the grid (" + ", ".join(f"{c.edges[-1]:.4g}" for c in mc) + " mm): "
                   + ", ".join(f"{c.overflow:.2e}" for c in mc))
    if not out:
        click.echo("r_mm,Rd_R,Rd_G,Rd_B")
        for ri, row in zip(r, prof.eval(r)):
            click.echo(f"{ri:.6g}," + ",".join(f"{v:.6e}" for v in row))
    else:
        click.echo(f"# wrote {out}")


def _channels():
    from ..materials import CHANNELS

    return (*CHANNELS, "all")


@click.command(epilog=examples(
    "ssskit simulate --material skin1 --photons 1000000 --json",
    "ssskit simulate --material skin1,marble,ketchup --jobs 2",
    "ssskit simulate --material skin1,marble --scheduler tcp://host:8786",
    "ssskit simulate --material skin1 --resume      # continue a run stopped by Ctrl-C",
    "ssskit simulate --material skin1 --restart     # discard it and start over"))
@material_option(required=True, split=True, help="Preset name or material file; repeat or comma-separate for a sweep.")
@click.option("--channel", type=RegistryName(_channels), default="all", show_default=True, help="Channel(s) to simulate.")
@photons_option(10_000_000, help="Photons per channel (supplement F: 10^7).")
@click.option("--seed", type=int, default=1, show_default=True, help="Random seed (0 <= seed < 2^63).")
@click.option("--threads", type=click.IntRange(min=1), default=None, help="numba threads [default: all cores].")
@click.option("--backend", type=click.Choice(["numba", "gl"]), default="numba", show_default=True,
              help="Monte Carlo engine: numba on the CPU, or gl (GLSL compute through EGL: a GPU, or llvmpipe); single material.")
@click.option("--jobs", type=click.IntRange(1, 1024), default=1, show_default=True, help="Local processes for a sweep of several materials.")
@click.option("--scheduler", default=None, metavar="ADDRESS", help="Run a sweep on a dask.distributed cluster (extra: ssskit[cluster]).")
@click.option("--batch-size", type=click.IntRange(min=1), default=10_000, show_default=True,
              help="Photons per random stream / standard-error batch.")
@click.option("--grid-fraction", type=click.FloatRange(0, 1, min_open=True, max_open=True), default=None,
              help="Lengthen the 32-MFP grid until it holds this fraction of the reflected light (e.g. 0.999); single material.")
@click.option("--roughness", type=click.FloatRange(0, 1), default=0.0, show_default=True,
              help="Beckmann alpha of a rough top surface, Mitsuba's roughdielectric (0: MCML's smooth one; "
                   "the 3D scenes use 0.15).")
@click.option("--resume", is_flag=True, help="Continue the partial result of an interrupted run with the same inputs.")
@click.option("--restart", is_flag=True, help="Discard the partial result of an interrupted run and start over.")
@click.option("--no-cache", is_flag=True, help="Neither read nor write the on-disk cache.")
@out_option((".npz",), "Write FILE.npz (one material) with r_mm, Rd, Rd_se per channel.")
@json_option()
def simulate(material: list[str], channel: str, photons: int, seed: int, threads: int | None, backend: str, jobs: int,
             scheduler: str | None, batch_size: int, grid_fraction: float | None, roughness: float, resume: bool,
             restart: bool, no_cache: bool, out: str | None, as_json: bool) -> None:
    """Monte Carlo (MCML) diffuse reflectance profiles with the supplement's settings.

    An interrupted run (Ctrl-C) keeps its finished batches: run it again with --resume to continue
    them or --restart to discard them.
    """
    import numpy as np

    from ..io import save_arrays
    from ..materials import get_material
    from ..profiles.montecarlo import config_for_material, simulate_many, simulate_material
    from ..profiles.montecarlo.run import check_resume

    names = [n for group in material for n in group]  # (MaterialRef refuses a --material that names none)
    mats = [get_material(n) for n in names]
    check_resume(resume, restart)  # the engine's rule, before any bar is shown
    if no_cache and (resume or restart):
        raise SsskitError(f"{'--resume' if resume else '--restart'} acts on the on-disk cache; it cannot be "
                          "combined with --no-cache")
    single = len(mats) == 1 and scheduler is None
    if out and len(mats) > 1:
        raise SsskitError("--out takes a single material; use --json for a sweep")
    if not single:  # (a sweep runs one numba thread per job)
        refuse_unused([f for f, on in (("--no-cache", no_cache), ("--threads", threads is not None), ("--backend", backend
                       != "numba"), ("--grid-fraction", grid_fraction is not None)) if on], "a", ("single material",),
                      "sweep (one numba thread per job)")
    if backend == "gl" and threads is not None:  # (the GLSL engine runs on the GPU or llvmpipe, not numba's threads)
        refuse_unused(["--threads"], "--backend", ("numba",), backend)
    for m in mats:  # photons, seed and batch size checked by the engine's own configuration, before any work
        config_for_material(m, 0, photons, seed, batch_size, roughness=roughness)
    if single:
        runs = {mats[0].name: simulate_material(mats[0], channel, photons=photons, seed=seed, threads=threads,
                                                progress=True, resume=resume, restart=restart,
                                                use_cache=not no_cache, batch_size=batch_size,
                                                grid_fraction=grid_fraction, roughness=roughness,
                                                backend=backend)}
    else:
        runs = simulate_many(mats, channel, photons=photons, seed=seed, jobs=jobs, batch_size=batch_size,
                             progress=True, resume=resume, restart=restart, scheduler=scheduler,
                             roughness=roughness)

    def one(results):
        first = next(iter(results.values()))
        seconds = sum(r.seconds for r in results.values())
        total = sum(r.photons for r in results.values())
        return {
            "r_mm": first.r_mm.tolist(),
            "channels": {ch: r.to_dict() for ch, r in results.items()},
            "photons": first.photons,
            "roughness": first.config.roughness,
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
                    total_Rd_in_grid=np.array([r.total_rd_in_grid for r in res.values()]),
                    overflow=np.array([r.overflow for r in res.values()]),
                    Rsp=np.array([r.rsp for r in res.values()]))
    if as_json:
        echo_json(data[mats[0].name] if len(mats) == 1 else {"materials": data})
        return
    for name, d in data.items():
        for ch, c in d["channels"].items():
            se = c["total_Rd_se"]  # the batches' spread: none from a single batch (JSON null)
            se_text = (f"{se:.5f}" if se is not None and math.isfinite(se) else
                       "n/a (one batch: give --photons > --batch-size)")
            click.echo(f"{name:<10} {ch}  total Rd with overflow = {c['total_Rd']:.5f} ± {se_text}, "
                       f"in grid = {c['total_Rd_in_grid']:.5f}, beyond {c['grid_mm']:.4g} mm = {c['overflow']:.2e}   "
                       f"Rsp = {c['Rsp']:.4f}")
        rate = d["photons_per_second"]
        click.echo(f"{name:<10}    {d['photons']} photons/channel, {d['seconds']:.1f} s"
                   + (f", rough surface (Beckmann alpha {roughness:g})" if roughness else "")
                   + (f", {rate:,.0f} photons/s" if rate else "") + (" (cached)" if d["cached"] else ""))
    if out:
        click.echo(f"wrote {out}")


@click.command("xie-c", short_help="Refit c of Xie 2020 Eq. 21; report the CDF errors.", epilog=examples("ssskit xie-c", "ssskit xie-c --points 20000 --json"))
@click.option("--points", type=click.IntRange(100, 10_000_000), default=100_000, show_default=True, help="Number of xi samples.")
@json_option()
def xie_c(points: int, as_json: bool) -> None:
    """Refit c of Xie 2020 Eq. 21 (least squares and minimax) and report the CDF errors."""
    import numpy as np

    from ..sampling import XIE_C, fit_xie_c, xie_cdf_error

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
        echo_json(data)
        return
    for name, d in data.items():
        click.echo(f"{name:<14} c = {d['c']:.6f}   max |cdf(g(xi)) - xi| = {d['max_cdf_error']:.6f}")
