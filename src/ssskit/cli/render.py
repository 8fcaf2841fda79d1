"""``ssskit render``: screen-space SSS of a scene or a G-buffer file, against ground truth.

The options build a :class:`~ssskit.pipeline.settings.RenderSettings` (optionally on top of a
settings file, ``--settings FILE.toml|json``: options given on the command line override it),
which validates every value before any work starts. ``--method burley`` runs the Burley Monte Carlo
pass instead of the separable one (:func:`ssskit.pipeline.burley.render_burley`): ``--sampler``,
``--spp`` (then the pass's samples per pixel), ``--c``, ``--albedo``/``--dmfp`` build its
:class:`~ssskit.screenspace.BurleySettings` and parameters; the separable pass's own options are refused.
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


def build_settings(ctx: click.Context, settings_file: str | None, params: dict, skip=()) -> RenderSettings:
    """RenderSettings from the settings file (or the defaults) with the options the user gave applied,
    each validated and named in the error when wrong (parameters in ``skip`` left out)."""
    s = RenderSettings.load(settings_file) if settings_file else RenderSettings()
    for name, fields in FIELDS.items():
        if not given(ctx, name) or name in skip:
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


#: options of the separable pass, refused with --method burley
SEPARABLE_ONLY = ("model", "photons", "kernel_spec", "taps", "tap_method", "jitter", "depth_mode")
#: options of the Burley pass, refused with --method separable
BURLEY_ONLY = ("sampler", "c", "albedo", "dmfp", "no_mips")


class RGBFloats(click.ParamType):
    """One number or three comma-separated numbers (R,G,B)."""

    name = "V[,V,V]"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        try:
            vals = tuple(float(v) for v in str(value).split(","))
        except ValueError:
            self.fail(f"{value!r} is not a number or three comma-separated numbers", param, ctx)
        if len(vals) not in (1, 3):
            self.fail(f"{value!r}: give one number or three (R,G,B)", param, ctx)
        return vals if len(vals) == 3 else vals * 3


def _burley_inputs(ctx, params: dict):
    """BurleySettings and optional BurleyParams from the Burley options (each error names its option)."""
    from ..screenspace import BurleyParams, BurleySettings

    kw = {"sampler": params["sampler"], "c": params["c"], "frame": params["frame"], "seed": params["seed"],
          "mips": not params["no_mips"]}
    if given(ctx, "spp"):
        kw["spp"] = params["spp"]
    if given(ctx, "backend"):
        kw["backend"] = params["backend"]
    flags = {"sampler": "--sampler", "c": "--c", "spp": "--spp", "frame": "--frame", "seed": "--seed",
             "backend": "--backend", "mips": "--no-mips"}
    b = BurleySettings()
    for key, value in kw.items():
        try:
            b = b.replace(**{key: value})
        except SsskitError as exc:
            raise SettingsError(f"{flags[key]}: {exc}") from None
    albedo, dmfp = params["albedo"], params["dmfp"]
    if (albedo is None) != (dmfp is None):
        raise SsskitError("--albedo and --dmfp go together (Burley parameters from albedo and diffuse mean free "
                          "path, Xie 2020 Eq. 5); give both or neither")
    burley_params = None
    if albedo is not None:
        try:
            burley_params = BurleyParams.from_dmfp(albedo, dmfp)
        except SsskitError as exc:
            raise SettingsError(f"--albedo/--dmfp: {exc}") from None
    return b, burley_params


@click.command(epilog=examples(
    "ssskit render --scene slab --material skin1 --kernel preintegrated --taps 7 --out slab.png",
    "ssskit render --scene slab --method burley --sampler xie --spp 32 --out burley.png",
    "ssskit render --scene sphere --kernel artist --jitter 0.3 --size 256x192 --out s.exr --reference",
    "ssskit render --scene my_gbuffer.exr --kernel svd:2 --json",
    "ssskit render --scene slab --settings frame.toml --taps 11 --backend numpy"))
@scene_option()
@click.option("--method", type=click.Choice(["separable", "burley"], case_sensitive=False), default="separable",
              show_default=True,
              help="The screen-space pass: separable (kernel taps) or burley (Monte Carlo, Xie 2020).")
@click.option("--sampler", type=click.Choice(["exact", "xie", "golubev"], case_sensitive=False), default="exact",
              show_default=True, help="--method burley: radius sampler (exact inverse CDF, Xie Eq. 21, Golubev 2018).")
@click.option("--c", "c", type=float, default=2.5715, show_default=True,
              help="--method burley: Eq. 21's c for --sampler xie, in (2, 3) (Unreal ships 2.6).")
@click.option("--no-mips", is_flag=True,
              help="--method burley: fetch every sample at full resolution (no prefiltered pyramid, Xie Eqs. 22-23).")
@click.option("--albedo", type=RGBFloats(), default=None,
              help="--method burley: surface albedo A in [0, 1] (one or R,G,B), with --dmfp: parameters instead of "
                   "the material's Burley profile (the material still gives a built-in scene its eta).")
@click.option("--dmfp", type=RGBFloats(), default=None,
              help="--method burley: diffuse mean free path in mm (> 0; one or R,G,B), with --albedo.")
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
@click.option("--spp", type=int, default=_D.spp, show_default=True,
              help="Samples per pixel of a built-in scene's G-buffer; with --method burley, of the Burley pass.")
@click.option("--frame", type=int, default=_D.sss.frame, show_default=True,
              help="Frame along the scene's camera orbit (and of the jitter pattern).")
@click.option("--seed", type=int, default=_D.seed, show_default=True, help="Random seed (renders and jitter).")
@click.option("--reference", is_flag=True, help="Also path-trace the built-in scene (Mitsuba volpathmis; cached) and compare.")
@click.option("--reference-spp", type=int, default=_D.reference_spp, show_default=True,
              help="Samples per pixel of the path-traced reference.")
@click.option("--no-exact", is_flag=True, help="Skip the exact 2D convolution.")
@click.option("--no-perceptual", is_flag=True, help="Skip FLIP in the metrics.")
@out_option((".exr",), "Also write the G-buffer as a multi-layer EXR.", name="--save-gbuffer", dest="save_gbuffer")
@out_option((".exr", ".png"), "Write the image: FILE.exr (linear, with sss/exact/reference layers) or FILE.png (tone-mapped).")
@json_option("Print one JSON object with settings and error metrics.")
@click.pass_context
def render(ctx, scene, settings_file, save_gbuffer, out, as_json, method, **params) -> None:
    """Screen-space SSS (separable, or Burley Monte Carlo) of a scene, with errors against the exact 2D
    convolution."""
    gbuffer_file = isinstance(scene, Path)
    burley = method.lower() == "burley"
    for name in BURLEY_ONLY if not burley else SEPARABLE_ONLY:
        if given(ctx, name):
            raise SsskitError(f"{option_name(ctx, name)} applies to --method {'burley' if not burley else 'separable'}")
    if burley:
        _render_burley(ctx, scene, settings_file, save_gbuffer, out, as_json, params)
        return
    for name in BURLEY_ONLY:
        params.pop(name)
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
        click.echo(f"vs {against:12s} " + "  ".join(f"{k} {v:.4g}" for k, v in m.items() if isinstance(v, float)))
    if out:
        click.echo(f"# wrote {out}")


def _render_burley(ctx, scene, settings_file, save_gbuffer, out, as_json, params) -> None:
    gbuffer_file = isinstance(scene, Path)
    if gbuffer_file and given(ctx, "size"):
        raise SsskitError(f"--size applies to a built-in scene; the G-buffer file {str(scene)!r} has its own")
    s = build_settings(ctx, settings_file, params, skip=("spp",))
    b, burley_params = _burley_inputs(ctx, params)
    if gbuffer_file and s.reference:
        raise SsskitError("--reference needs a built-in scene (a G-buffer file has no scene to path-trace)")
    material_file = Path(s.material) if Path(s.material).is_file() else None
    check_distinct({"--out": out, "--save-gbuffer": save_gbuffer},
                   {"--scene": scene if gbuffer_file else None, "--settings": settings_file,
                    "--material": material_file})
    from ..pipeline.burley import render_burley

    res = render_burley(scene, s, b, progress=None if as_json else progress, params=burley_params)
    if save_gbuffer:
        res.gbuffer.save(save_gbuffer)
    if out:
        res.save(out)
    if as_json:
        echo_json(res.to_dict())
        return
    h, w = res.gbuffer.shape
    click.echo(f"# {res.scene}: Burley d = {', '.join(f'{d:.3g}' for d in res.params.d_mm)} mm, {b.sampler} sampler, "
               f"{b.spp} spp, {'mips' if b.mips else 'no mips'}, {w}x{h}, {b.backend} backend")
    for against, m in res.metrics.items():
        click.echo(f"vs {against:12s} " + "  ".join(f"{k} {v:.4g}" for k, v in m.items() if isinstance(v, float)))
    if out:
        click.echo(f"# wrote {out}")


__all__ = ["FIELDS", "build_settings", "render"]
