"""``ssskit figures`` and ``ssskit demo``: the papers' figures and the demo report."""

from __future__ import annotations

from pathlib import Path

import click

from ..backends import DEFAULT_BACKEND
from ..errors import SsskitError
from ..quantities import refuse_unused
from .options import (
    DEFAULT_MODEL,
    DEFAULT_PHOTONS,
    FIGURE,
    SceneRef,
    backend_option,
    examples,
    material_option,
    model_option,
    out_dir_option,
    photons_option,
    progress,
    resolve_scene_value,
    scene_mesh_options,
)
from .profiles import resolve_profile


class _FiguresCommand(click.Command):
    """``ssskit figures``: its help lists the registered figure names (the argument's metavar is
    ``[NAME]...``, so the usage line does not)."""

    def format_help_text(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        super().format_help_text(ctx, formatter)
        import textwrap

        with formatter.section("Figures (NAME)"):
            width = max(formatter.width - formatter.current_indent, 20)
            for line in textwrap.wrap(", ".join(FIGURE.names()), width, break_on_hyphens=False):
                formatter.write(" " * formatter.current_indent + line + "\n")


@click.command(cls=_FiguresCommand, epilog=examples(
    "ssskit figures fig7 figS5 --material skin1 --out ssskit-out/figures",
    "ssskit figures --model dipole",
    "ssskit figures xie-fig6 --backend gl"))
@click.argument("names", nargs=-1, type=FIGURE, metavar="[NAME]...")
@material_option(default="skin1", help="Material of the figures.")
@model_option(DEFAULT_MODEL, help="Profile model of the figures.")
@photons_option(DEFAULT_PHOTONS, help="--model montecarlo: photons per channel (shipped for the presets at 10^7, else cached).")
@backend_option(DEFAULT_BACKEND)
@click.option("--scene", type=SceneRef(), default=None,
              help="The figures that render a scene (xie-fig1: the bust by default): a generated mesh, a mesh "
                   "file or a scene .toml.")
@scene_mesh_options(view=False)
@out_dir_option("ssskit-out/figures")
@click.pass_context
def figures(ctx: click.Context, names: tuple[str, ...], material: str | None, model: str, photons: int, backend: str,
            scene: str | Path | None, units: tuple[str, ...], material_map: str | None, out: str) -> None:
    """Regenerate the papers' figures (NAME: any of the figures listed below; all by default). The
    figures that run a screen-space pass run it on --backend; those that render a scene (xie-fig1) take
    --scene, --units and --material-map."""
    from ..backends import get_backend
    from ..figures import FIGURES, make_figures, renders_a_scene

    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise SsskitError(f"figure {', '.join(twice)} named more than once; name each figure once")
    get_backend(backend)  # can it run here? checked before any work
    scene_kw = None
    if scene is not None or units or material_map:
        chosen = list(names) or FIGURES.names()
        takers = [n for n in chosen if renders_a_scene(FIGURES.get(n))]
        if not takers:  # the figures that render a scene take them
            refuse_unused([f for f, v in (("--scene", scene), ("--units", units), ("--material-map", material_map)) if v],
                          "figure", [n for n in FIGURES.names() if renders_a_scene(FIGURES.get(n))], ", ".join(chosen))
        value = "bust" if scene is None else scene
        resolve_scene_value(value, units, material_map, view="front")  # every check before any work
        scene_kw = {"scene": str(value), "units": units[0] if units else None, "material_map": material_map,
                    "material": material}
    prof = resolve_profile(ctx, material, model, {"photons": ("photons", photons)})()
    from ..io import staged_folder

    with staged_folder(out) as stage:  # all figures or none: a failure leaves no partial output
        written = make_figures(list(names), stage, prof, progress=progress, backend=backend, scene=scene_kw)
    for paths in written.values():
        for p in paths:
            click.echo(str(Path(out) / Path(p).relative_to(stage)))


@click.command(epilog=examples("ssskit demo", "ssskit demo --material skin2,apple", "ssskit demo --full",
                               "ssskit demo --backend gl", "ssskit demo --jobs 1"))
@out_dir_option("ssskit-out/demo")
@photons_option(None, help="Monte Carlo photons per channel, simulated [default: the shipped profiles, 10^7].")
@click.option("--full", is_flag=True, help="Simulate the Monte Carlo profiles at the supplement's 10^7 photons instead "
                                           "of reading the shipped ones (an hour or more on 2 cores the first time, then cached).")
@backend_option(DEFAULT_BACKEND)
@material_option(split=True, help="The materials whose kernels the report ranks [default: all 11 measured]; "
                                  "comma-separated presets or material files.")
@click.option("--scene", type=SceneRef(), default=None,
              help="Add a section on your model (a mesh file, scene .toml or generated mesh): the three views of "
                   "Xie 2020 Fig. 1 with every Burley method and the separable pass.")
@scene_mesh_options(view=False)
@click.option("--jobs", type=click.IntRange(1, 64), default=None,
              help="Processes building the report's sections at once [default: 2, or 1 on a single core].")
def demo(out: str, photons: int | None, full: bool, backend: str, material: tuple[list[str], ...],
         scene: str | Path | None, units: tuple[str, ...], material_map: str | None, jobs: int | None) -> None:
    """The main job: build the report (figures + index.html) on built-in defaults; --scene adds your model."""
    from ..backends import get_backend
    from ..materials import get_material
    from ..profiles.domain import check_montecarlo
    from ..report import DEMO_PHOTONS, build_report

    if full and photons is not None:  # (--full simulates at the supplement's 10^7 photons)
        refuse_unused(["--photons"], "a", ("demo without --full",), "--full demo")
    names = [n for group in material for n in group] or None
    for n in names or []:
        check_montecarlo(get_material(n))  # the ranking's profiles are Monte Carlo ones
    get_backend(backend)  # can it run here? checked before any work
    scene_kw = None
    if scene is not None or units or material_map:
        if scene is None:  # (--scene: the model of the demo's last section)
            refuse_unused([f for f, v in (("--units", units), ("--material-map", material_map)) if v], "a",
                          ("demo with --scene",), "demo without one")
        resolve_scene_value(scene, units, material_map, view="front")  # every check before any work
        scene_kw = {"scene": str(scene), "units": units[0] if units else None, "material_map": material_map}
    click.echo(f"ssskit demo: writing the report to {out}/", err=True)
    if jobs is None:
        import os

        jobs = min(2, os.cpu_count() or 1)
    index = build_report(Path(out), progress=progress, photons=photons or DEMO_PHOTONS, progress_bars=True,
                         backend=backend, recompute=full, materials=names, scene=scene_kw, jobs=jobs)
    click.echo(str(index))
