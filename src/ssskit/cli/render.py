"""``ssskit render``: screen-space SSS of a scene or a G-buffer file, against ground truth.

The options build one :class:`~ssskit.pipeline.settings.RenderSettings` tree (on top of a settings file,
``--settings FILE.toml|json``: options given on the command line override it;
:mod:`ssskit.cli.render_options`), which validates every value before any work starts; then
:func:`ssskit.pipeline.render` runs the pass it names (``--pass separable|burley|burley-adaptive``, or
the file's; ``--method`` is the deprecated alias) and this command writes the files and prints the
result. An adaptive run's frames reach ``--frames-dir`` through the pipeline's frame callback.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click

from ..errors import SsskitError
from ..quantities import refuse_unused
from ..pipeline.settings import PASSES, AdaptivePass, BurleyPass, RenderSettings, SeparablePass
from .options import (
    BACKEND,
    DEPTH_MODE,
    DEPTH_MODE_HELP,
    MODEL,
    TAP_METHOD,
    OutputDir,
    RegistryName,
    Size,
    echo_json,
    given,
    examples,
    json_option,
    kernel_spec_option,
    material_option,
    out_option,
    progress,
    resolve_scene_value,
    say_notes,
    scene_mesh_options,
    scene_option,
    setting_option,
)
from .render_options import (SIGMA0, Budget, FrameWriter, _member, _sigma0_sq, build_settings, check_inputs,
                             load_settings, pass_of)

_D = RenderSettings()
_A = AdaptivePass()
_PASS = RegistryName(lambda: PASSES)


@click.command(epilog=examples(
    "ssskit render --scene slab --material skin1 --kernel preintegrated --taps 7 --out slab.png",
    "ssskit render --scene slab --pass burley --sampler xie --spp 32 --out burley.png",
    "ssskit render --scene slab --pass burley-adaptive --size 128x96 --frames 16 --sigma0 0.01 --kappa 0.2 "
    "--frames-dir ssskit-out/adaptive --json",
    "ssskit render --scene bumpy --pass burley-adaptive --size 128x96 --frames 16 --static --budget 4:32",
    "ssskit render --scene sphere --kernel artist --jitter 0.3 --size 256x192 --out s.exr --reference",
    "ssskit render --scene my_gbuffer.exr --kernel svd:2 --json",
    "ssskit render --scene head.glb --units m --material-map skin=skin1,lips=skin2 --view ear --out head.png",
    "ssskit render --scene bust --view close --pass burley --reference --save-gbuffer bust-gbuffer.exr",
    "ssskit render --scene slab --settings frame.toml --taps 11 --backend numpy",
    "ssskit render --scene ear --transmission on --save-gbuffer ear-light.exr --out ear.exr"))
@scene_option()
@scene_mesh_options()
@click.option("--pass", "pass_name", type=_PASS, default=None,
              help="The screen-space pass: separable (kernel taps; the default), burley (Monte Carlo, Xie 2020) or "
                   "burley-adaptive (its variance-guided sample counts over --frames frames, Xie 2020 Sec. 4.1); "
                   "default: the settings file's, else separable.")
@click.option("--method", "method", type=_PASS, default=None, help="Deprecated alias of --pass.")
@_member(AdaptivePass, "frames", help="frames along the scene's camera and light paths from --frame")
@_member(AdaptivePass, "static", help="keep the camera and lights at --frame (a G-buffer file is always static).")
@_member(AdaptivePass, "taa", "--taa/--no-taa", show_default=True,
         help="resolve every frame with the global TAA (Karis 2014) and report psnr_taa.")
@click.option("--frames-dir", type=OutputDir(), default=None,
              help="--pass burley-adaptive: write per-frame images and sample-count heatmaps (PNG) into DIR.")
@_member(AdaptivePass, ("b_min", "b_max"), "--budget", type=Budget(),
         help="samples per pixel and frame, b_min <= b_max.")
@_member(AdaptivePass, "disocclusion_spp",
         help="on a moving camera: samples where the history is missing (new pixels; default b_min, Xie 2020 Sec. "
              "4.1.4; a larger value is ssskit's variant), within --budget")
@_member(AdaptivePass, "limit_spp",
         help="on a moving camera: samples per pixel of each frame's converged reference (exact sampler, no mips; "
              f"two cached halves give its standard error; default {_A.reference_spp})")
@_member(AdaptivePass, "sigma0_sq", "--sigma0", type=float, default=math.sqrt(_A.sigma0_sq), show_default=False,
         convert=_sigma0_sq,
         help=f"target standard deviation sigma0 of a frame's gamma-corrected luminance, in [{SIGMA0.lo:g}, "
              f"{SIGMA0.hi:g}] (Xie: sigma0^2 = 1e-3, i.e. --sigma0 0.0316).  [default: {math.sqrt(_A.sigma0_sq):.4g}, "
              f"sigma0^2 = {_A.sigma0_sq:.3g}]")
@_member(AdaptivePass, "kappa", help="correction factor kappa of Eq. 14")
@_member(AdaptivePass, "alpha", help="EMA weight alpha of the history (Eqs. 6, 8, 9)")
@_member(AdaptivePass, "correction", help="Eq. 15 with variances, or as printed with standard deviations.")
@_member(BurleyPass, "sampler", help="radius sampler (exact inverse CDF, Xie Eq. 21, Golubev 2018).")
@_member(BurleyPass, "c", help="Eq. 21's c for --sampler xie (Unreal ships 2.6)")
@_member(BurleyPass, "mips", "--no-mips", invert=True,
         help="fetch every sample at full resolution (no prefiltered pyramid, Xie Eqs. 22-23).")
@_member(BurleyPass, "albedo", help="surface albedo A (one or R,G,B), with --dmfp: parameters instead of the material's "
                                    "Burley profile (the material still gives a built-in scene its eta)")
@_member(BurleyPass, "dmfp_mm", "--dmfp", help="diffuse mean free path (one or R,G,B), with --albedo")
@click.option("--settings", "settings_file", type=click.Path(exists=True, dir_okay=False), default=None,
              metavar="FILE.toml|json", help="Render settings file (RenderSettings); options given here override it.")
@material_option(default=_D.material, help="Preset name or material file.")
@setting_option(RenderSettings, "model", type=MODEL, help="Profile the kernel approximates.")
@setting_option(RenderSettings, "photons", help="--model montecarlo: photons per channel (cached)")
@kernel_spec_option(default=_D.kernel, help="Kernel method spec name[:value] (preintegrated, svd:2, artist:production, "
                                            "jimenez2012...); an engine tap kernel is built with --taps taps.")
@setting_option(RenderSettings, "taps", help="Taps per 1D pass")
@setting_option(RenderSettings, "tap_method", type=TAP_METHOD, help="Tap placement.")
@setting_option(SeparablePass, "jitter", help="Jitter radius as a fraction of the kernel size (paper: 0.1, 0.3 for "
                                              "close-ups)")
@setting_option(SeparablePass, "depth_mode", type=DEPTH_MODE, help=DEPTH_MODE_HELP)
@setting_option(RenderSettings, "backend", type=BACKEND,
                help="Who runs the screen-space pass ('ssskit backends' lists them and whether they run here).")
@setting_option(RenderSettings, ("width", "height"), "--size", type=Size(),
                help="Image size of a built-in or mesh scene (a G-buffer file has its own).")
@setting_option(RenderSettings, "spp", help="Samples per pixel of a scene's G-buffer; with --pass burley, of the Burley "
                                            "pass (not with burley-adaptive: --budget)")
@setting_option(RenderSettings, "frame", help="Frame along the scene's camera orbit (and of the pass's random numbers)")
@setting_option(RenderSettings, "seed", help="Random seed (renders, jitter, samples)")
@setting_option(RenderSettings, "reference", help="Also path-trace the scene, built-in or mesh (Mitsuba volpathmis; "
                                                  "cached) and compare.")
@setting_option(RenderSettings, "reference_spp", help="Samples per pixel of the path-traced reference (at least)")
@setting_option(RenderSettings, "reference_max_spp",
                help="Sample budget of the reference: it renders until --reference-rel-se is reached or this is spent")
@setting_option(RenderSettings, "reference_rel_se",
                help="Target relative standard error of the reference's mean over the SSS mask")
@setting_option(RenderSettings, "transmission",
                help="The transmittance pass (light through thin parts, lit from behind; docs/transmission.md), added "
                     "to the separable or Burley pass (each frame of burley-adaptive): auto runs it where the G-buffer "
                     "has the light layers (a G-buffer file that carries them; a scene renders without them), on "
                     "renders a scene's G-buffer with them (a G-buffer file without them is an error), off never.")
@setting_option(RenderSettings, "transmission_model",
                help="The transmittance T(t): mcml (the fit of the material's MCML slab tables), jimenez2010 "
                     "(Jimenez et al. 2010's skin Gaussians, thickness in mm) or unreal (Unreal Engine 5's "
                     "subsurface-profile transmission with its defaults for the material's Burley profile).")
@setting_option(RenderSettings, "transmission_spread",
                help="The lateral spread of the transmitted light: mcml (a Gaussian per pixel as wide as MCML's Tt(r) "
                     "at its thickness, where wider than half a pixel; several times the separable pass's cost on the "
                     "CPU) or off (each pixel keeps the light that crossed the medium behind it).")
@setting_option(RenderSettings, "exact", "--no-exact", invert=True, help="Skip the exact 2D convolution.")
@setting_option(RenderSettings, "perceptual", "--no-perceptual", invert=True, help="Skip FLIP in the metrics.")
@out_option((".exr",), "Also write the G-buffer as a multi-layer EXR.", name="--save-gbuffer", dest="save_gbuffer")
@out_option((".exr", ".png"), "Write the image: FILE.exr (linear, with sss/exact/reference layers) or FILE.png (tone-mapped).")
@json_option("Print one JSON object with settings and error metrics.")
@click.pass_context
def render(ctx: click.Context, scene: str | Path, settings_file: str | None, save_gbuffer: str | None, out: str | None,
           as_json: bool, pass_name: str | None, method: str | None, frames_dir: str | None, units: tuple[str, ...],
           material_map: str | None, view: str | None, **params: Any) -> None:
    """Screen-space SSS (separable, or Burley Monte Carlo) of a scene (built-in, generated, a mesh or a scene
    file), with errors against the exact 2D convolution; --pass burley-adaptive: a sequence of frames with
    adaptive sample counts, each against its converged reference."""
    base = load_settings(settings_file) if settings_file else None
    name = pass_of(ctx, pass_name, method, base)
    s = build_settings(ctx, base, name)
    check_inputs(ctx, scene, s, settings_file, out, save_gbuffer, frames_dir)
    if base is not None and isinstance(scene, Path) and scene.suffix.lower() == ".exr":
        d = RenderSettings()
        if (base.width, base.height) != (d.width, d.height):  # (a G-buffer file keeps its own size)
            refuse_unused([f"the settings file's width x height {base.width}x{base.height} ({settings_file})"], "a",
                          ("built-in scene",), f"G-buffer file {str(scene)!r}", SsskitError)
    import contextlib

    from ..io import staged_folder
    from ..pipeline import plan
    from ..pipeline import render as run

    # a mesh or scene file is read and checked once; its notes go to stderr when every check has passed
    resolved = resolve_scene_value(scene, units, material_map, view, s.width, s.height, say=False)
    planned = plan(resolved, s)
    if (planned.transmission and s.transmission_model in ("mcml", "unreal") and given(ctx, "albedo")
            and not given(ctx, "material") and not (base is not None and base.material != RenderSettings().material)):
        raise SsskitError(f"the {s.transmission_model} transmission model reads a material's MCML slab table (unreal: its "
                          "Burley fit); --albedo/--dmfp give Burley parameters and no material: give --material for "
                          "the light through thin parts, --transmission-model jimenez2010, or --transmission off")
    say_notes(planned.notes)
    # an adaptive run's frames go to a staging folder that becomes --frames-dir only when every frame is done: an
    # interrupted run leaves no partial folder
    with staged_folder(frames_dir) if frames_dir is not None else contextlib.nullcontext() as stage:
        writer = FrameWriter(stage) if stage is not None else None
        res = run(resolved, s, progress=progress, on_frame=writer)  # checks everything first; progress on stderr
    if save_gbuffer:
        res.gbuffer.save(save_gbuffer)
    if out:
        res.save(out)
    about = dict(resolved.spec.about) if resolved.spec is not None else {}
    if as_json:
        echo_json({**res.to_dict(), **({"scene_about": about} if about else {})})
        return
    for line in res.lines():
        click.echo(line)
    for key, value in about.items():
        click.echo(f"# {key}: {value}")
    if frames_dir:
        click.echo(f"# wrote frames and sample-count heatmaps to {frames_dir}")
    if out:
        click.echo(f"# wrote {out}")


__all__ = ["render"]
