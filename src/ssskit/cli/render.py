"""``ssskit render``: screen-space separable SSS of a scene or a G-buffer file, against ground truth.

The options build a :class:`~ssskit.pipeline.settings.RenderSettings` (optionally on top of a
settings file, ``--settings FILE.toml|json``: options given on the command line override it),
which validates every value before any work starts.
"""

from __future__ import annotations

from pathlib import Path

import click

from ..errors import SettingsError, SsskitError
from ..pipeline.settings import TAP_RANGE, RenderSettings
from .options import (
    Size,
    backend_option,
    check_distinct,
    depth_mode_option,
    echo_json,
    examples,
    given,
    json_option,
    kernel_spec_option,
    material_option,
    model_option,
    option_name,
    out_option,
    photons_option,
    progress,
    scene_option,
    tap_method_option,
)

_D = RenderSettings()

#: click parameter -> the settings field(s) it sets ("sss." for the pass settings)
FIELDS: dict[str, tuple[str, ...]] = {
    "material": ("material",),
    "model": ("model",),
    "photons": ("photons",),
    "kernel_spec": ("kernel",),
    "taps": ("taps",),
    "tap_method": ("tap_method",),
    "size": ("width", "height"),
    "spp": ("spp",),
    "seed": ("seed", "sss.seed"),
    "frame": ("sss.frame",),
    "jitter": ("sss.jitter",),
    "depth_mode": ("sss.depth_mode",),
    "backend": ("sss.backend",),
    "reference": ("reference",),
    "reference_spp": ("reference_spp",),
    "reference_max_spp": ("reference_max_spp",),
    "reference_rel_se": ("reference_rel_se",),
    "no_exact": ("exact",),
    "no_perceptual": ("perceptual",),
}

#: options that describe how a built-in scene's G-buffer is rendered: refused with a G-buffer file
SCENE_ONLY = ("size", "spp")


def _apply(s: RenderSettings, flag: str, fields: tuple[str, ...], values: tuple) -> RenderSettings:
    top = {f: v for f, v in zip(fields, values) if not f.startswith("sss.")}
    sub = {f[4:]: v for f, v in zip(fields, values) if f.startswith("sss.")}
    try:
        if sub:
            top["sss"] = s.sss.replace(**sub)
        return s.replace(**top)
    except SsskitError as exc:
        raise SettingsError(f"{flag}: {exc}") from None


def build_settings(ctx: click.Context, settings_file: str | None, params: dict) -> RenderSettings:
    """RenderSettings from the settings file (or the defaults) with the options the user gave applied,
    each validated and named in the error when wrong."""
    s = RenderSettings.load(settings_file) if settings_file else RenderSettings()
    for name, fields in FIELDS.items():
        if not given(ctx, name):
            continue
        value = params[name]
        if name == "size":
            values = tuple(value)
        elif name in ("no_exact", "no_perceptual"):
            values = (not value,)
        else:
            values = (value,) * len(fields)
        s = _apply(s, option_name(ctx, name), fields, values)
    # an engine tap kernel (a method whose parameter is its tap count, e.g. jimenez2012) is built with
    # --taps taps (ssskit.pipeline.render); --kernel NAME:N and an explicit --taps must agree
    from ..kernels import parse_method_spec

    method, inline, _ = parse_method_spec(s.kernel)
    if method.primary == "taps" and inline.get("taps", s.taps) != s.taps:
        if given(ctx, "taps"):
            raise SettingsError(f"--kernel {s.kernel} builds {inline['taps']} taps but --taps is {s.taps}; "
                                "give the number of taps once")
        s = _apply(s, "--kernel", ("taps",), (inline["taps"],))
    return s


@click.command(epilog=examples(
    "ssskit render --scene slab --material skin1 --kernel preintegrated --taps 7 --out slab.png",
    "ssskit render --scene sphere --kernel artist --jitter 0.3 --size 256x192 --out s.exr --reference",
    "ssskit render --scene my_gbuffer.exr --kernel svd:2 --json",
    "ssskit render --scene slab --settings frame.toml --taps 11 --backend numpy"))
@scene_option()
@click.option("--settings", "settings_file", type=click.Path(exists=True, dir_okay=False), default=None,
              metavar="FILE.toml|json", help="Render settings file (RenderSettings); options given here override it.")
@material_option(default=_D.material, help="Preset name or material file.")
@model_option(_D.model, help="Profile the kernel approximates.")
@photons_option(_D.photons, help="--model montecarlo: photons per channel (cached).")
@kernel_spec_option(default=_D.kernel, help="Kernel method spec name[:value] (preintegrated, svd:2, artist:production, "
                                            "jimenez2012...); an engine tap kernel is built with --taps taps.")
@click.option("--taps", type=click.IntRange(*TAP_RANGE), default=_D.taps, show_default=True, help="Taps per 1D pass (odd).")
@tap_method_option(_D.tap_method)
@click.option("--jitter", type=float, default=_D.sss.jitter, show_default=True,
              help="Jitter radius as a fraction of the kernel size, 0..1 (paper: 0.1, 0.3 for close-ups).")
@depth_mode_option()
@backend_option(_D.sss.backend)
@click.option("--size", type=Size(), default=f"{_D.width}x{_D.height}", show_default=True,
              help="Image size of a built-in scene (a G-buffer file has its own).")
@click.option("--spp", type=int, default=_D.spp, show_default=True, help="Samples per pixel of a built-in scene's G-buffer.")
@click.option("--frame", type=int, default=_D.sss.frame, show_default=True,
              help="Frame along the scene's camera orbit (and of the jitter pattern).")
@click.option("--seed", type=int, default=_D.seed, show_default=True, help="Random seed (renders and jitter).")
@click.option("--reference", is_flag=True, help="Also path-trace the built-in scene (Mitsuba volpathmis; cached) and compare.")
@click.option("--reference-spp", type=int, default=_D.reference_spp, show_default=True,
              help="Samples per pixel of the path-traced reference (at least).")
@click.option("--reference-max-spp", type=int, default=_D.reference_max_spp, show_default=True,
              help="Sample budget of the reference: it renders until --reference-rel-se is reached or this is spent.")
@click.option("--reference-rel-se", type=float, default=_D.reference_rel_se, show_default=True,
              help="Target relative standard error of the reference's mean over the SSS mask.")
@click.option("--no-exact", is_flag=True, help="Skip the exact 2D convolution.")
@click.option("--no-perceptual", is_flag=True, help="Skip FLIP in the metrics.")
@out_option((".exr",), "Also write the G-buffer as a multi-layer EXR.", name="--save-gbuffer", dest="save_gbuffer")
@out_option((".exr", ".png"), "Write the image: FILE.exr (linear, with sss/exact/reference layers) or FILE.png (tone-mapped).")
@json_option("Print one JSON object with settings and error metrics.")
@click.pass_context
def render(ctx, scene, settings_file, save_gbuffer, out, as_json, **params) -> None:
    """Screen-space separable SSS of a scene, with errors against the exact 2D convolution."""
    gbuffer_file = isinstance(scene, Path)
    if gbuffer_file:
        for name in SCENE_ONLY:
            if given(ctx, name):
                raise SsskitError(f"{option_name(ctx, name)} applies to a built-in scene; the G-buffer file "
                                  f"{str(scene)!r} has its own")
    s = build_settings(ctx, settings_file, params)
    if gbuffer_file and s.reference:
        raise SsskitError("--reference needs a built-in scene (a G-buffer file has no scene to path-trace)")
    material_file = Path(s.material) if Path(s.material).is_file() else None
    check_distinct({"--out": out, "--save-gbuffer": save_gbuffer},
                   {"--scene": scene if gbuffer_file else None, "--settings": settings_file,
                    "--material": material_file})
    from ..pipeline import render as run

    res = run(scene, s, progress=None if as_json else progress)  # checks everything before any work
    if save_gbuffer:
        res.gbuffer.save(save_gbuffer)
    if out:
        res.save(out)
    if as_json:
        echo_json(res.to_dict())
        return
    h, w = res.gbuffer.shape
    click.echo(f"# {res.scene}: {res.material.name} ({s.model}), {s.kernel} with {res.taps.taps} taps, "
               f"jitter {s.sss.jitter:g}, {w}x{h}, {s.sss.backend} backend")
    for against, m in res.metrics.items():
        if against != "regions":
            click.echo(f"vs {against:12s} " + "  ".join(f"{k} {v:.4g}" for k, v in m.items() if isinstance(v, float)))
    from ..pipeline.regions import format_regions

    for line in format_regions(res.metrics.get("regions")):
        click.echo(line)
    if res.reference_info is not None:
        ref = res.reference_info
        click.echo(f"# reference: {ref.spp} spp, relative standard error of the SSS mask's mean "
                   + ", ".join(f"{v:.2%}" for v in ref.rel_se) + f" (target {ref.target_rel_se:.1%}, budget "
                   f"{ref.max_spp} spp: {'converged' if ref.converged else 'budget spent, not converged'})")
    if out:
        click.echo(f"# wrote {out}")


__all__ = ["FIELDS", "build_settings", "render"]
