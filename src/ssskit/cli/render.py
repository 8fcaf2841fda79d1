"""``ssskit render``: screen-space SSS of a scene or a G-buffer file, against ground truth.

The options build a :class:`~ssskit.pipeline.settings.RenderSettings` (optionally on top of a
settings file, ``--settings FILE.toml|json``: options given on the command line override it),
which validates every value before any work starts. ``--method burley`` runs the Burley Monte Carlo
pass instead of the separable one (:func:`ssskit.pipeline.burley.render_burley`): ``--sampler``,
``--spp`` (then the pass's samples per pixel), ``--c``, ``--albedo``/``--dmfp`` build its
:class:`~ssskit.screenspace.BurleySettings` and parameters (on top of a settings file's ``[burley]``
table; a file with ``method = "burley"`` runs the Burley pass without ``--method``); the separable
pass's own options are refused.
``--method burley-adaptive`` runs ``--frames`` frames of the Burley pass with the variance-guided sample
counts of Xie 2020 Sec. 4.1 (``--sigma0``, ``--kappa``, ``--budget B_MIN:B_MAX``, ``--alpha``,
``--correction``): along a built-in scene's camera and light paths (:func:`_render_moving`,
:func:`ssskit.pipeline.sequence.run_sequence`: each frame against its converged reference, beside the same
loop at a fixed B_MAX spp, both through the same TAA), or with ``--static`` (always for a G-buffer file)
on one camera (:func:`ssskit.screenspace.adaptive.adaptive_frames`: every frame and their average against
the pass's limit, beside one frame at a fixed B_MAX spp).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import click
import numpy as np

from ..errors import OutputError, SettingsError, SsskitError
from ..pipeline.settings import TAP_RANGE, RenderSettings
from .options import (
    OutputDir,
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


def _adaptive_defaults():
    from ..screenspace.adaptive import AdaptiveSettings

    return AdaptiveSettings()


_A = _adaptive_defaults()

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
#: options of the adaptive sampler, refused unless --method burley-adaptive
ADAPTIVE_ONLY = ("frames", "sigma0", "kappa", "budget", "alpha", "correction", "static", "taa", "frames_dir",
                 "limit_spp", "disocclusion_spp")


class Budget(click.ParamType):
    """``B_MIN:B_MAX``: the adaptive sampler's samples per pixel and frame (two integers)."""

    name = "B_MIN:B_MAX"

    def get_metavar(self, param, ctx=None) -> str:
        return "B_MIN:B_MAX"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        try:
            lo, hi = (int(v) for v in str(value).split(":"))
        except ValueError:
            self.fail(f"must look like 8:64 (two integers), got {value!r}", param, ctx)
        return lo, hi


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


def _burley_inputs(ctx, params: dict, base=None):
    """BurleySettings and optional BurleyParams from the Burley options (each error names its option):
    the options the user gave applied to ``base`` (a settings file's ``[burley]`` table; default
    :class:`BurleySettings`, whose defaults are the options' defaults)."""
    from ..screenspace import BurleyParams, BurleySettings

    values = {"sampler": params["sampler"], "c": params["c"], "frame": params["frame"], "seed": params["seed"],
              "mips": not params["no_mips"], "spp": params["spp"], "backend": params["backend"]}
    option = {"mips": "no_mips"}
    kw = {key: v for key, v in values.items() if given(ctx, option.get(key, key))}
    flags = {"sampler": "--sampler", "c": "--c", "spp": "--spp", "frame": "--frame", "seed": "--seed",
             "backend": "--backend", "mips": "--no-mips"}
    b = BurleySettings() if base is None else base
    for key, value in kw.items():
        try:
            b = b.replace(**{key: value})
        except SsskitError as exc:
            raise SettingsError(f"{flags[key]}: {exc}") from None
    if "c" in kw and b.sampler != "xie":
        raise SettingsError(f"--c: c is the xie sampler's constant (Xie 2020 Eq. 21), unused by the {b.sampler} "
                            "sampler; add --sampler xie")
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
    "ssskit render --scene slab --method burley-adaptive --size 128x96 --frames 16 --sigma0 0.01 --kappa 0.2 "
    "--frames-dir ssskit-out/adaptive --json",
    "ssskit render --scene bumpy --method burley-adaptive --size 128x96 --frames 16 --static --budget 4:32",
    "ssskit render --scene sphere --kernel artist --jitter 0.3 --size 256x192 --out s.exr --reference",
    "ssskit render --scene my_gbuffer.exr --kernel svd:2 --json",
    "ssskit render --scene slab --settings frame.toml --taps 11 --backend numpy"))
@scene_option()
@click.option("--method", type=click.Choice(["separable", "burley", "burley-adaptive"], case_sensitive=False),
              default="separable", show_default=True,
              help="The screen-space pass: separable (kernel taps), burley (Monte Carlo, Xie 2020) or burley-adaptive "
                   "(its variance-guided sample counts over --frames frames, Xie 2020 Sec. 4.1).")
@click.option("--frames", type=int, default=16, show_default=True,
              help="--method burley-adaptive: frames along the scene's camera and light paths from --frame "
                   "(1..100000).")
@click.option("--static", is_flag=True,
              help="--method burley-adaptive: keep the camera and lights at --frame (a G-buffer file is always "
                   "static).")
@click.option("--taa/--no-taa", default=True, show_default=True,
              help="--method burley-adaptive: resolve every frame with the global TAA (Karis 2014) and report "
                   "psnr_taa.")
@click.option("--frames-dir", type=OutputDir(), default=None,
              help="--method burley-adaptive: write per-frame images and sample-count heatmaps (PNG) into DIR.")
@click.option("--disocclusion-spp", type=int, default=None,
              help="--method burley-adaptive on a moving camera: samples where the history is missing (new pixels; "
                   "default b_min, Xie 2020 Sec. 4.1.4; a larger value is ssskit's variant), in [b_min, b_max].")
@click.option("--limit-spp", type=int, default=2048, show_default=True,
              help="--method burley-adaptive on a moving camera: samples per pixel of each frame's converged "
                   "reference (exact sampler, no mips; two cached halves give its standard error).")
@click.option("--sigma0", type=float, default=math.sqrt(_A.sigma0_sq),
              help="--method burley-adaptive: target standard deviation sigma0 of a frame's gamma-corrected "
                   f"luminance, > 0 (Xie: sigma0^2 = 1e-3, i.e. --sigma0 0.0316).  [default: "
                   f"{math.sqrt(_A.sigma0_sq):.4g}, sigma0^2 = {_A.sigma0_sq:.3g}]")
@click.option("--kappa", type=float, default=_A.kappa, show_default=True,
              help="--method burley-adaptive: correction factor kappa of Eq. 14, in [0, 1].")
@click.option("--budget", type=Budget(), default=f"{_A.b_min}:{_A.b_max}", show_default=True,
              help="--method burley-adaptive: samples per pixel and frame, b_min <= b_max.")
@click.option("--alpha", type=float, default=_A.alpha, show_default=True,
              help="--method burley-adaptive: EMA weight alpha of the history (Eqs. 6, 8, 9), in (0, 1].")
@click.option("--correction", type=click.Choice(["variance", "sigma"], case_sensitive=False), default=_A.correction,
              show_default=True,
              help="--method burley-adaptive: Eq. 15 with variances, or as printed with standard deviations.")
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
              help="Samples per pixel of a built-in scene's G-buffer; with --method burley, of the Burley pass "
                   "(not with burley-adaptive: --budget).")
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
def render(ctx, scene, settings_file, save_gbuffer, out, as_json, method, **params) -> None:
    """Screen-space SSS (separable, or Burley Monte Carlo) of a scene, with errors against the exact 2D
    convolution; --method burley-adaptive: a sequence of frames with adaptive sample counts, each against
    its converged reference."""
    gbuffer_file = isinstance(scene, Path)
    method = method.lower()
    if settings_file and not given(ctx, "method"):  # the file's method, unless --method says otherwise
        method = RenderSettings.load(settings_file).method
    burley = method in ("burley", "burley-adaptive")
    for name in BURLEY_ONLY if not burley else SEPARABLE_ONLY:
        if given(ctx, name):
            raise SsskitError(f"{option_name(ctx, name)} applies to --method {'burley' if not burley else 'separable'}")
    if method != "burley-adaptive":
        for name in ADAPTIVE_ONLY:
            if given(ctx, name):
                flag = "--taa/--no-taa" if name == "taa" else option_name(ctx, name)
                raise SsskitError(f"{flag} applies to --method burley-adaptive")
    if method == "burley-adaptive":
        _render_adaptive(ctx, scene, settings_file, save_gbuffer, out, as_json, params)
        return
    for name in ADAPTIVE_ONLY:
        params.pop(name)
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
    s = build_settings(ctx, settings_file, params).replace(method="separable")
    _check_files(scene, s, settings_file, out, save_gbuffer)
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


def _check_size(ctx, scene) -> None:
    if isinstance(scene, Path) and given(ctx, "size"):
        raise SsskitError(f"--size applies to a built-in scene; the G-buffer file {str(scene)!r} has its own")


def _check_files(scene, s, settings_file, out, save_gbuffer) -> None:
    """A G-buffer file has no scene to path-trace; no output may be one of the inputs."""
    gbuffer_file = isinstance(scene, Path)
    if gbuffer_file and s.reference:
        raise SsskitError("--reference needs a built-in scene (a G-buffer file has no scene to path-trace)")
    material_file = Path(s.material) if Path(s.material).is_file() else None
    check_distinct({"--out": out, "--save-gbuffer": save_gbuffer},
                   {"--scene": scene if gbuffer_file else None, "--settings": settings_file,
                    "--material": material_file})


def _render_burley(ctx, scene, settings_file, save_gbuffer, out, as_json, params) -> None:
    _check_size(ctx, scene)
    s = build_settings(ctx, settings_file, params, skip=("spp",))
    b, burley_params = _burley_inputs(ctx, params, base=s.burley)
    s = s.replace(method="burley", burley=b)
    _check_files(scene, s, settings_file, out, save_gbuffer)
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


def _adaptive_inputs(ctx, params: dict):
    """AdaptiveSettings and the frame count from the adaptive options (each error names its option)."""
    from ..screenspace.adaptive import AdaptiveSettings

    sigma0 = params["sigma0"]
    if not (math.isfinite(sigma0) and sigma0 > 0):
        raise SettingsError(f"--sigma0: the target standard deviation sigma0 must be > 0, got {sigma0!r}")
    if not (0 < sigma0 * sigma0 < math.inf):  # the history works with sigma0^2 (float64)
        raise SettingsError(f"--sigma0: sigma0^2 must be a positive finite float64, but {sigma0!r}^2 "
                            f"{'underflows to 0' if sigma0 < 1 else 'overflows'}; give sigma0 in [1e-150, 1e150]")
    b_min, b_max = params["budget"]
    steps = (("--sigma0", {"sigma0_sq": sigma0 * sigma0}), ("--kappa", {"kappa": params["kappa"]}),
             ("--budget", {"b_min": b_min, "b_max": b_max}), ("--alpha", {"alpha": params["alpha"]}),
             ("--correction", {"correction": params["correction"]}))
    a = AdaptiveSettings()
    for flag, change in steps:
        try:
            a = a.replace(**change)
        except SsskitError as exc:
            raise SettingsError(f"{flag}: {exc}") from None
    frames = params["frames"]
    if not 1 <= frames <= 100_000:
        raise SettingsError(f"--frames: the number of frames must lie in [1, 100000], got {frames}")
    if params["frame"] + frames - 1 > 2**31 - 1:
        raise SettingsError(f"--frames: {frames} frames from --frame {params['frame']} pass frame 2^31 - 1")
    return a, frames


#: the files :class:`_FrameWriter` writes into --frames-dir
FRAME_FILE = re.compile(r"(frame_\d{4,}(_taa)?|counts_\d{4,})\.png")


def _check_frames_dir(frames_dir, outputs: dict) -> None:
    """No other output (``{option: path}``, None skipped) may be the --frames-dir folder or one of the
    frame files written into it (``frame_NNNN.png``, ``frame_NNNN_taa.png``, ``counts_NNNN.png``)."""
    if frames_dir is None:
        return
    folder = Path(frames_dir).resolve()
    for opt, path in outputs.items():
        if path is None:
            continue
        p = Path(path).resolve()
        if p == folder:
            raise OutputError(f"--frames-dir {str(frames_dir)!r} is also the {opt} file; choose another folder")
        if p.parent == folder and FRAME_FILE.fullmatch(p.name):
            raise OutputError(f"{opt} {str(path)!r} is one of the frame files --frames-dir writes; choose another "
                              "name or folder")


def _render_adaptive(ctx, scene, settings_file, save_gbuffer, out, as_json, params) -> None:
    """--method burley-adaptive: a sequence of the Burley pass with adaptive counts, along the scene's
    camera and light paths (:func:`_render_moving`) or on a static camera."""
    import dataclasses

    from ..metrics import region_metrics

    _check_size(ctx, scene)
    if given(ctx, "spp"):
        raise SsskitError("--spp: the adaptive pass chooses its samples per pixel; give --budget B_MIN:B_MAX")
    static = bool(params.pop("static")) or isinstance(scene, Path)
    taa_on, frames_dir, limit_spp = params.pop("taa"), params.pop("frames_dir"), params.pop("limit_spp")
    disocclusion_spp = params.pop("disocclusion_spp")
    s = build_settings(ctx, settings_file, params, skip=("spp",))
    b, burley_params = _burley_inputs(ctx, params, base=s.burley)  # the file's [burley] table, then the options
    s = s.replace(method="burley", burley=b)  # the frame's pass (the JSON's settings say so, not "separable")
    a, frames = _adaptive_inputs(ctx, params)
    _check_files(scene, s, settings_file, out, save_gbuffer)
    _check_frames_dir(frames_dir, {"--out": out, "--save-gbuffer": save_gbuffer})
    if not static:
        if disocclusion_spp is not None and not a.b_min <= disocclusion_spp <= a.b_max:
            raise SettingsError(f"--disocclusion-spp must lie in the budget [{a.b_min}, {a.b_max}], "
                                f"got {disocclusion_spp}")
        _render_moving(ctx, scene, s, b, burley_params, a, frames, taa_on, frames_dir, limit_spp, out, save_gbuffer,
                       as_json, disocclusion_spp)
        return
    if disocclusion_spp is not None:
        raise SsskitError("--disocclusion-spp applies to a moving camera (a static run has no new pixels)")
    if given(ctx, "limit_spp"):
        raise SsskitError("--limit-spp applies to a moving camera; a static run compares with the exact limit "
                          "(burley_exact)")
    from ..pipeline.burley import render_burley
    from ..screenspace.adaptive import adaptive_frames

    from ..screenspace.taa import TAASettings, TemporalAA

    say = None if as_json else progress
    # one frame at a fixed b_max spp: the G-buffer, the pass's limit (exact) and the fixed-count comparison
    fixed = render_burley(scene, s, b.replace(spp=a.b_max), progress=say, params=burley_params)
    gb, mask = fixed.gbuffer, fixed.gbuffer.mask
    exact = None if fixed.exact is None else gb.composite(fixed.exact)
    rows: list[dict] = []
    taa = TemporalAA(TAASettings()) if taa_on else None
    writer = _FrameWriter(frames_dir, a, exact if exact is not None else gb.composite(fixed.sss))

    def on_frame(f, sss, counts):
        image = gb.composite(sss)
        image_taa = None if taa is None else taa.resolve(image)
        psnr = region_metrics(exact, image, mask, False)["psnr"] if exact is not None and mask.any() else None
        psnr_taa = None
        if image_taa is not None and exact is not None and mask.any():
            psnr_taa = region_metrics(exact, image_taa, mask, False)["psnr"]
        rows.append({"frame": b.frame + f, "mean_spp": float(counts[mask].mean()) if mask.any() else 0.0,
                     "psnr": psnr, "psnr_taa": psnr_taa})
        writer(b.frame + f, image, image_taa, counts)

    every = max(1, frames // 8)
    say_some = None if say is None else (lambda msg: say(msg) if len(rows) % every == 0 else None)
    run = adaptive_frames(gb, fixed.params, a, frames, burley=b, progress=say_some, on_frame=on_frame)
    for row, ms, ms_update in zip(rows, run.ms_pass, run.ms_update):
        row["ms"], row["ms_update"] = ms, ms_update
    image = gb.composite(run.last)
    res = dataclasses.replace(fixed, burley=b, sss=run.last, image=image, metrics={})
    if exact is not None:
        res.metrics["exact_2d"] = region_metrics(exact, image, mask, s.perceptual)
        res.metrics["average_exact_2d"] = region_metrics(exact, gb.composite(run.mean.astype(np.float32)), mask, False)
    if fixed.reference is not None:
        res.metrics["path_traced"] = region_metrics(fixed.reference, image, mask, s.perceptual)
    if save_gbuffer:
        gb.save(save_gbuffer)
    if out:
        res.save(out)
    total = int(run.counts.sum())
    if as_json:
        data = res.to_dict()
        data["method"] = "burley-adaptive"
        data["burley"].pop("spp", None)
        data["adaptive"] = {**a.to_dict(), "sigma0": math.sqrt(a.sigma0_sq), "frames": frames,
                            "history": "(H, W, 4) float32: n_bar, mu, sigma^2, available"}
        data["static"] = True
        data["taa"] = TAASettings().to_dict() if taa_on else None
        data["frames"] = rows
        data["mean_spp"] = float(np.mean([r["mean_spp"] for r in rows]))
        data["total_samples"] = total
        data["fixed"] = {"spp": a.b_max, "metrics": fixed.to_dict()["metrics"]}
        echo_json(data)
        return
    h, w = gb.shape
    click.echo(f"# {res.scene}: Burley adaptive, sigma0 {math.sqrt(a.sigma0_sq):.4g} (sigma0^2 {a.sigma0_sq:.3g}), "
               f"kappa {a.kappa:g}, budget {a.b_min}:{a.b_max}, {frames} frames, {b.sampler} sampler, "
               f"{'mips' if b.mips else 'no mips'}, {w}x{h}, {b.backend} backend, TAA {'on' if taa_on else 'off'}")
    spp = [r["mean_spp"] for r in rows]
    click.echo(f"mean spp per frame: first {spp[0]:.1f}, last {spp[-1]:.1f}, average {np.mean(spp):.1f} "
               f"(fixed: {a.b_max}); median ms: pass {np.median(run.ms_pass):.3g}, "
               f"update {np.median(run.ms_update):.3g}")
    for against, m in res.metrics.items():
        click.echo(f"vs {against:16s} " + "  ".join(f"{k} {v:.4g}" for k, v in m.items() if isinstance(v, float)))
    for against, m in fixed.metrics.items():
        click.echo(f"fixed {a.b_max} spp vs {against:12s} "
                   + "  ".join(f"{k} {v:.4g}" for k, v in m.items() if isinstance(v, float)))
    if frames_dir:
        click.echo(f"# wrote frames and sample-count heatmaps to {frames_dir}")
    if out:
        click.echo(f"# wrote {out}")


class _FrameWriter:
    """Writes ``frame_NNNN.png`` (the pass's composite), ``frame_NNNN_taa.png`` (after TAA) and
    ``counts_NNNN.png`` (sample-count heatmap, colour bar 0..b_max) into ``folder`` (None: nothing),
    tone-mapped with one peak for the whole sequence (the 99.5th percentile of ``like``)."""

    def __init__(self, folder, a, like) -> None:
        self.folder = None if folder is None else Path(folder)
        finite = np.asarray(like)[np.isfinite(like)]
        self.peak = float(np.percentile(finite, 99.5)) if finite.size else 1.0
        self.b_max = a.b_max
        if self.folder is not None:
            self.folder.mkdir(parents=True, exist_ok=True)

    def __call__(self, frame, image, image_taa, counts, label: str = "adaptive") -> None:
        if self.folder is None:
            return
        from ..figures.sequence import save_frame_png, save_heatmap_png

        save_frame_png(self.folder / f"frame_{frame:04d}.png", image, self.peak)
        if image_taa is not None:
            save_frame_png(self.folder / f"frame_{frame:04d}_taa.png", image_taa, self.peak)
        mask = counts > 0
        mean = float(counts[mask].mean()) if mask.any() else 0.0
        save_heatmap_png(self.folder / f"counts_{frame:04d}.png", counts, self.b_max,
                         f"{label} frame {frame}: mean {mean:.1f} spp")


def _render_moving(ctx, scene, s, b, burley_params, a, frames, taa_on, frames_dir, limit_spp, out, save_gbuffer,
                   as_json, disocclusion_spp=None) -> None:
    """--method burley-adaptive along the scene's camera and light paths (:mod:`ssskit.pipeline.sequence`):
    the adaptive pass and the fixed b_max pass through the same loop and the same TAA, each frame against
    its converged reference."""
    from ..pipeline.burley import plan_burley
    from ..pipeline.sequence import run_sequence, sequence_gbuffers, sequence_references
    from ..screenspace.taa import TAASettings

    if save_gbuffer:
        raise SsskitError("--save-gbuffer applies to one frame; add --static")
    if s.reference:
        raise SsskitError("--reference applies to one frame; add --static (a moving sequence compares each frame "
                          "with its converged Burley reference)")
    for name in ("reference_spp", "reference_max_spp", "reference_rel_se", "no_exact"):  # else silently unused
        if given(ctx, name):
            raise SsskitError(f"{option_name(ctx, name)} applies to one frame; add --static (a moving sequence "
                              "compares each frame with its converged Burley reference of --limit-spp spp)")
    if isinstance(limit_spp, bool) or not 2 <= limit_spp <= 131072:
        raise SettingsError(f"--limit-spp: the reference's samples per pixel must lie in [2, 131072], got {limit_spp}")
    if b.frame + frames - 1 > 2**31 - 1:
        raise SettingsError(f"--frames: {frames} frames from --frame {b.frame} pass frame 2^31 - 1")
    plan, params = plan_burley(scene, s, b, burley_params)  # checks the scene, material and backend first
    say = None if as_json else progress
    gbs = sequence_gbuffers(plan.builtin, plan.material, frames, b.frame, width=s.width, height=s.height, spp=s.spp,
                            seed=s.seed, progress=say)
    refs = sequence_references(gbs, params, spp=limit_spp, backend=b.backend, progress=say)
    taa = TAASettings() if taa_on else None
    writer = _FrameWriter(frames_dir, a, gbs[0].composite(refs[0].sss))
    every = max(1, frames // 8)

    def some(label):  # "frame k/N" messages, every frames // 8-th
        if say is None:
            return None
        return lambda msg: say(f"{label} {msg}") if (int(msg.split()[1].split("/")[0]) - 1) % every == 0 else None

    run = run_sequence(gbs, params, b, adaptive=a, taa=taa, references=refs, disocclusion_spp=disocclusion_spp,
                       progress=some("adaptive"),
                       on_frame=lambda f, img, img_taa, counts: writer(b.frame + f, img, img_taa, counts))
    fixed = run_sequence(gbs, params, b, spp=a.b_max, taa=taa, references=refs, progress=some(f"fixed {a.b_max} spp"))
    last = min(20, frames)
    if out:
        from ..io import save_image

        gb = gbs[-1]
        image = run.last_taa if run.last_taa is not None else run.last
        save_image(out, image, {"frame": run.last, "reference": gb.composite(refs[-1].sss)}, what="output image")
    rows = run.rows()
    for row in rows:
        row["frame"] += b.frame
    ref_noise = [float(np.sqrt(np.mean((g.albedo * r.stderr)[g.mask] ** 2))) if g.mask.any() else 0.0
                 for g, r in zip(gbs, refs)]
    def finals(r):
        return {"final_psnr_taa": r.final_psnr(last) if taa_on else None, "final_psnr": r.final_psnr(last, taa=False),
                "final_psnr_gray_taa": r.final_psnr(last, gray=True) if taa_on else None,
                "final_psnr_gray": r.final_psnr(last, taa=False, gray=True), "total_samples": r.samples,
                "mean_spp": float(np.mean(r.mean_spp)), "median_ms": float(np.median(r.ms)),
                "median_ms_update": float(np.median(r.ms_update)), "median_ms_frame": float(np.median(r.ms_frame)),
                "total_ms_frame": float(np.sum(r.ms_frame))}

    summary = {**finals(run), "fixed": {"spp": a.b_max, **finals(fixed),
                                        "frames": [{**r, "frame": r["frame"] + b.frame} for r in fixed.rows()]}}
    summary["sample_ratio"] = fixed.samples / run.samples if run.samples else None
    h, w = gbs[0].shape
    if as_json:
        echo_json({"scene": plan.scene, "method": "burley-adaptive", "static": False,
                   "material": getattr(plan.material, "name", str(plan.material)), "size": [int(w), int(h)],
                   "burley": {k: v for k, v in b.to_dict().items() if k != "spp"},
                   "adaptive": {**a.to_dict(), "sigma0": math.sqrt(a.sigma0_sq), "frames": frames,
                                "history": "(H, W, 4) float32: n_bar, mu, sigma^2, available",
                                "disocclusion_spp": disocclusion_spp if disocclusion_spp is not None else a.b_min},
                   "taa": taa.to_dict() if taa is not None else None,
                   "reference": {"spp": refs[0].spp, "sampler": "exact", "mips": False,
                                 "noise_rms_max": max(ref_noise)},
                   "final_frames": last, "frames": rows, **summary})
        return
    click.echo(f"# {plan.scene}: Burley adaptive along the camera/light path, frames "
               f"{b.frame}..{b.frame + frames - 1}, "
               f"sigma0^2 {a.sigma0_sq:.3g}, kappa {a.kappa:g}, budget {a.b_min}:{a.b_max}, {b.sampler} sampler, "
               f"{'mips' if b.mips else 'no mips'}, {w}x{h}, {b.backend} backend, TAA {'on' if taa_on else 'off'}")
    click.echo(f"# reference per frame: exact sampler, {refs[0].spp} spp, no mips (noise RMS <= {max(ref_noise):.3g})")
    for name, r in (("adaptive", run), (f"fixed {a.b_max} spp", fixed)):
        taa_txt = f", with TAA {r.final_psnr(last):.2f} ({r.final_psnr(last, gray=True):.2f})" if taa_on else ""
        click.echo(f"{name:14s} mean spp {np.mean(r.mean_spp):6.2f}  samples {r.samples}  final PSNR, gray in () "
                   f"(last {last} frames): {r.final_psnr(last, taa=False):.2f} ({r.final_psnr(last, False, True):.2f})"
                   f"{taa_txt} dB  median ms: pass {np.median(r.ms):.3g}, guiding {np.median(r.ms_update):.3g}, "
                   f"whole loop {np.median(r.ms_frame):.3g}")
    click.echo(f"samples: fixed / adaptive = {summary['sample_ratio']:.2f}x")
    if frames_dir:
        click.echo(f"# wrote frames and sample-count heatmaps to {frames_dir}")
    if out:
        click.echo(f"# wrote {out}")


__all__ = ["FIELDS", "build_settings", "render"]
