"""``ssskit figures`` and ``ssskit demo``: the papers' figures and the demo report."""

from __future__ import annotations

from pathlib import Path

import click

from ..errors import SsskitError
from .options import FIGURE, examples, material_option, model_option, out_dir_option, photons_option, progress
from .profiles import check_material_for_model, resolve_profile


@click.command(epilog=examples(
    "ssskit figures fig7 figS5 --material skin1 --out ssskit-out/figures",
    "ssskit figures --model dipole"))
@click.argument("names", nargs=-1, type=FIGURE, metavar="[NAME]...")
@material_option(default="skin1", help="Material of the figures.")
@model_option("montecarlo", help="Profile model of the figures.")
@photons_option(200_000, help="--model montecarlo: photons per channel (cached).")
@out_dir_option("ssskit-out/figures")
@click.pass_context
def figures(ctx, names, material, model, photons, out) -> None:
    """Regenerate the papers' figures (NAMES: any of the registered figures; all by default)."""
    from ..figures import make_figures

    check_material_for_model(ctx, material, model)
    prof = resolve_profile(ctx, material, model, {"photons": ("photons", photons)})()
    written = make_figures(list(names), out, prof, progress=progress)
    for paths in written.values():
        for p in paths:
            click.echo(str(p))


@click.command(epilog=examples("ssskit demo", "ssskit demo --out report --photons 20000", "ssskit demo --full"))
@out_dir_option("ssskit-out/demo")
@photons_option(None, help="Monte Carlo photons per channel [default: 200,000].")
@click.option("--full", is_flag=True, help="Monte Carlo with the supplement's 10^7 photons per channel (slow the first time, then cached).")
def demo(out: str, photons: int | None, full: bool) -> None:
    """The main job: build the report (figures + index.html) on built-in defaults."""
    from ..profiles.montecarlo import DEFAULT_PHOTONS
    from ..report import DEMO_PHOTONS, build_report

    if full and photons is not None:
        raise SsskitError("give either --full or --photons, not both")
    n = DEFAULT_PHOTONS if full else (photons or DEMO_PHOTONS)
    click.echo(f"ssskit demo: writing the report to {out}/", err=True)
    index = build_report(Path(out), progress=progress, photons=n, progress_bars=True)
    click.echo(str(index))
