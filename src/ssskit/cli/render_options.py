"""The options of ``ssskit render`` turned into one :class:`~ssskit.pipeline.settings.RenderSettings` tree,
and the checks between options and outputs that only the command line has.

:func:`build_settings` starts from the settings file (``--settings``; the defaults without one) and
applies the options the user gave, each validated by the settings classes and named in the error: the
top-level values, the pass (``--pass``, or the file's), and the pass member's options. The options of the settings
fields are generated from them (:class:`~ssskit.cli.options.SettingOption`: name, type, default, range), so the
option knows its settings class and fields: :func:`own` derives which pass each belongs to (an option of another
pass is refused) and :func:`build_settings` which field it sets. The frame writer (:class:`FrameWriter`) writes an
adaptive run's frames through the pipeline's callback.
"""

from __future__ import annotations

import dataclasses
import re
import warnings
from pathlib import Path
from collections.abc import Iterable
from typing import Any, TypeVar

import click
import numpy as np

from ..backends.burley_plan import XIE_C
from ..errors import OutputError, SettingsError, SsskitError
from ..pipeline.adaptive import AdaptiveFrame
from ..pipeline.settings import (PASSES, AdaptivePass, BurleyPass, PassMember, RenderSettings, SeparablePass,
                                 SettingsMigrated)
from ..quantities import Quantity, refuse_twice, refuse_unused
from ..settings import Settings
from ..io import check_distinct, same_file
from .options import IntPair, SettingOption, given, named, option_name, setting_option
from .profiles import resolve_profile

_S = TypeVar("_S", bound=Settings)

#: options that set a top-level field but are not generated from it (a field its class checks itself)
FIELDS: dict[str, tuple[str, ...]] = {"material": ("material",), "kernel_spec": ("kernel",)}
#: options of a pass that set no settings field (what the pass writes)
PASS_OPTIONS = {"frames_dir": "burley-adaptive"}
#: the target standard deviation of the adaptive pass, whose square (sigma0_sq) the history works with in float64
SIGMA0 = Quantity("sigma0", 1e-150, 1e150, "", "the target standard deviation of a frame's luminance; its square "
                  "must be a positive float64")


def _member(cls: type, field: Any, *decls: str, help: str = "", **attrs: Any) -> Any:
    """The option of a pass member's field (:func:`~ssskit.cli.options.setting_option`), its help naming the pass."""
    return setting_option(cls, field, *decls, help=f"--pass {cls.name}: {help}", **attrs)  # type: ignore[attr-defined]


def _sigma0_sq(sigma0: float) -> tuple[float]:
    return (SIGMA0.check(sigma0, "sigma0", SettingsError) ** 2,)


def own(params: Iterable[click.Parameter]) -> dict[str, tuple[str, ...]]:
    """The options among ``params`` (the command's) each pass owns, derived from the settings: a generated
    option of a pass member's field is its pass's (the Burley sampler's fields, which the adaptive run takes too,
    are the burley pass's), one of a top-level field declared to apply to some passes
    (RenderSettings' ``applies=("pass", ...)``) theirs; :data:`FIELDS` and :data:`PASS_OPTIONS` the others."""
    top = {f.name: f.metadata["applies"][1] for f in dataclasses.fields(RenderSettings)
           if (f.metadata.get("applies") or ("",))[0] == "pass"}
    out: dict[str, list[str]] = {name: [] for name in PASSES.names()}
    for p in params:
        if isinstance(p, SettingOption):
            cls = p.settings_class
            passes = top.get(p.fields[0], ()) if cls is RenderSettings else (cls.name,)  # type: ignore[attr-defined]
        else:
            passes = top.get(FIELDS.get(p.name or "", ("",))[0], ()) or (PASS_OPTIONS.get(p.name or ""),)
        for name in passes:
            if name in out and p.name:
                out[name].append(p.name)
    return {name: tuple(v) for name, v in out.items()}


#: options that describe how a built-in scene's G-buffer is rendered: refused with a G-buffer file
SCENE_ONLY = ("size", "spp")


class Budget(IntPair):
    """``B_MIN:B_MAX``: the adaptive sampler's samples per pixel and frame (two integers; the settings check
    their range)."""

    name = "B_MIN:B_MAX"


def pass_of(ctx: click.Context, pass_name: str | None, method: str | None, base: RenderSettings | None) -> str:
    """The pass to run: ``--pass``, or ``--method`` (its deprecated alias: says so once), or the settings
    file's (``base``), or separable; and every option of another pass refused."""
    if method is not None:
        if pass_name is not None and pass_name.lower() != method.lower():  # the error alone: one line
            refuse_twice(f"--pass {pass_name}", f"--method {method}", "the pass (with --pass)", SettingsError)
        click.echo("ssskit: warning: --method is deprecated for render; use --pass (same values)", err=True)
        pass_name = pass_name or method
    name = PASSES.get(pass_name).name if pass_name is not None else (base.pass_name if base else "separable")
    burley = name in ("burley", "burley-adaptive")
    for other, options in own(ctx.command.params).items():
        mine = other == name or (other == "burley" and burley)
        for opt in () if mine else options:
            if given(ctx, opt):  # (the one wording of an option that what runs does not use)
                flag = "--taa/--no-taa" if opt == "taa" else option_name(ctx, opt)
                refuse_unused([flag], "--pass", ("burley" if other == "burley" else other,), name, SsskitError)
    return name


def load_settings(path: str) -> RenderSettings:
    """The settings file, with a one-line warning on stderr if it is in the old layout (it still loads)."""
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", SettingsMigrated)
        s = RenderSettings.load(path)
    for w in seen:
        if issubclass(w.category, SettingsMigrated):
            click.echo(f"ssskit: warning: --settings {path}: {str(w.message)}", err=True)
    assert isinstance(s, RenderSettings)
    return s


def _apply(obj: _S, flag: str, changes: dict[str, Any]) -> _S:
    with named(flag):
        return obj.replace(**changes)


def _member_of(base: PassMember, name: str) -> PassMember:
    """The pass member to start from: the settings file's when it is this pass's; a Burley member's sampler
    carried over to the other Burley pass; else the pass's defaults (the command line overrides the file)."""
    cls = PASSES.get(name)
    if isinstance(base, cls):
        return base
    if isinstance(base, (BurleyPass, AdaptivePass)) and cls in (BurleyPass, AdaptivePass):
        shared = {f.name: getattr(base, f.name) for f in dataclasses.fields(BurleyPass) if f.name != "spp"}
        return cls(**shared)
    return cls()


def _generated(ctx: click.Context, cls: type, skip: tuple[str, ...] = ()) -> list[tuple[str, dict[str, Any]]]:
    """(option, the fields it sets) of the generated options of ``cls``'s fields the user gave (but ``skip``), in
    the command's order."""
    out = []
    for p in ctx.command.params:
        if isinstance(p, SettingOption) and p.settings_class is cls and p.name and p.name not in skip \
                and given(ctx, p.name):
            with named(p.opts[0]):  # a conversion's own check (--sigma0)
                out.append((p.opts[0], p.changes(ctx.params[p.name])))
    return out


def _pass_options(ctx: click.Context, member: PassMember) -> PassMember:
    """The pass member with the pass's options the user gave applied one by one, each named in its error (the
    command's order: the budget before the counts inside it). The sampler and its c are one step, each checked
    against the other as asked for; --albedo with --dmfp another (they go together). A sampler other than xie
    asked for on the command line drops the file's c (Eq. 21's constant belongs to the xie sampler)."""
    params = ctx.params
    steps: list[tuple[str, dict[str, Any]]] = []
    if given(ctx, "sampler") or given(ctx, "c"):
        c = params["c"] if given(ctx, "c") else (None if str(params["sampler"]).lower() == "xie" else XIE_C)
        steps.append(("--c" if given(ctx, "c") else "--sampler", {**({"sampler": params["sampler"]} if
                      given(ctx, "sampler") else {}), **({} if c is None else {"c": c})}))
    if given(ctx, "albedo") or given(ctx, "dmfp"):
        steps.append(("--albedo/--dmfp", {"albedo": params["albedo"], "dmfp_mm": params["dmfp"]}))
    if isinstance(member, BurleyPass) and given(ctx, "spp"):
        steps.append(("--spp", {"spp": params["spp"]}))
    for cls in (SeparablePass, BurleyPass, AdaptivePass):
        if isinstance(member, cls) or (cls is BurleyPass and isinstance(member, AdaptivePass)):
            steps += _generated(ctx, cls, ("sampler", "c", "albedo", "dmfp"))
    for flag, change in steps:
        member = _apply(member, "--taa/--no-taa" if flag == "--taa" else flag, change)
    return member


def build_settings(ctx: click.Context, base: RenderSettings | None, pass_name: str) -> RenderSettings:
    """RenderSettings from the settings file's (``base``; None: the defaults) with the options the user gave
    applied, each validated and named in the error when wrong (module docstring)."""
    s = RenderSettings() if base is None else base
    member = _pass_options(ctx, _member_of(s.pass_, pass_name))
    steps = [(option_name(ctx, name), {f: ctx.params[name] for f in fields}) for name, fields in FIELDS.items()
             if given(ctx, name)]
    steps += _generated(ctx, RenderSettings, () if pass_name == "separable" else ("spp",))  # (the G-buffer's spp; the
    # Burley pass's is its member's)
    top = {k: v for _, change in steps for k, v in change.items()}
    try:
        s = s.replace(**top, pass_=member)
    except SsskitError as exc:
        # name the option: the top-level values applied one by one (all of them together are checked first, so a
        # rule between two options, reference_spp <= reference_max_spp, sees both before it refuses either)
        probe = s.replace(pass_=SeparablePass())
        for flag, change in steps:
            probe = _apply(probe, flag, change)
        raise SettingsError(str(exc)) from None
    return _engine_taps(ctx, s) if pass_name == "separable" else s


def _engine_taps(ctx: click.Context, s: RenderSettings) -> RenderSettings:
    """An engine tap kernel (a method whose parameter is its tap count, e.g. jimenez2012) is built with
    --taps taps (ssskit.pipeline.render); --kernel NAME:N and an explicit --taps must agree."""
    from ..kernels import parse_method_spec

    method, inline, _ = parse_method_spec(s.kernel)
    if method.primary == "taps" and inline.get("taps", s.taps) != s.taps:
        if given(ctx, "taps"):
            refuse_twice(f"--kernel {s.kernel}", f"--taps {s.taps}", "the number of taps", SettingsError)
        s = _apply(s, "--kernel", {"taps": inline["taps"]})
    return s


def check_inputs(ctx: click.Context, scene: str | Path, s: RenderSettings, settings_file: str | None, out: str | None,
                 save_gbuffer: str | None, frames_dir: str | None) -> None:
    """What only the command line can get wrong, before any work: options for a built-in scene given with
    a G-buffer file; the adaptive run's options of one kind of run given to the other; outputs that are
    inputs, or each other, or the frames --frames-dir writes."""
    gbuffer_file = isinstance(scene, Path) and scene.suffix.lower() == ".exr"
    still = gbuffer_file or _mesh_scene(scene)  # a G-buffer or a mesh scene: one still camera
    name = s.pass_name
    if gbuffer_file:  # (it has its own size and samples)
        refuse_unused([option_name(ctx, o) for o in (SCENE_ONLY if name == "separable" else ("size",)) if given(ctx, o)],
                      "a", ("built-in scene",), f"G-buffer file {str(scene)!r}", SsskitError)
    if name == "burley-adaptive":
        _check_adaptive(ctx, s, still, save_gbuffer, gbuffer_file)
    # options that would be accepted and silently ignored, refused by the model commands' one statement of the model's
    # rules (resolve_profile): --material with a fixed preset, --photons with a model that simulates nothing
    resolve_profile(ctx, s.material, s.model, {"photons": ("photons", s.photons)})
    material_file = Path(s.material) if Path(s.material).is_file() else None
    check_distinct({"--out": out, "--save-gbuffer": save_gbuffer, "--frames-dir": frames_dir},
                   scene if gbuffer_file else None, settings_file, material_file)
    for opt, path in (("--out", out), ("--save-gbuffer", save_gbuffer)):  # nor a frame file written into the folder
        if frames_dir and path and same_file(Path(path).parent, frames_dir) and FRAME_FILE.fullmatch(Path(path).name):
            raise OutputError(f"{opt} {str(path)!r} is one of the frame files --frames-dir writes; choose another "
                              "name or folder")


def _mesh_scene(scene: Any) -> bool:
    """Whether ``scene`` (a --scene value) is a mesh scene: a mesh or scene file, or a generated mesh."""
    from ..scenes import GENERATED_SCENES

    if isinstance(scene, Path):
        return scene.suffix.lower() != ".exr"
    return isinstance(scene, str) and scene in GENERATED_SCENES


def _check_adaptive(ctx: click.Context, s: RenderSettings, still: bool, save_gbuffer: str | None,
                    gbuffer_file: bool = False) -> None:
    p = s.pass_
    assert isinstance(p, AdaptivePass)
    if given(ctx, "spp"):
        raise SsskitError("--spp: the adaptive pass chooses its samples per pixel; give --budget B_MIN:B_MAX")
    if still and not p.static:  # (with --static, AdaptivePass refuses a moving camera's options itself)
        why = (" (a G-buffer file is always static)" if gbuffer_file else " (a mesh, scene file or generated mesh is "
               "always static under --pass burley-adaptive: its camera and lights stay at --frame; only the built-in "
               "scenes move)")
        for opt, tail in (("disocclusion_spp", "has no new pixels"),
                          ("limit_spp", "compares with the exact limit (burley_exact)")):
            if given(ctx, opt):
                raise SsskitError(f"{option_name(ctx, opt)} applies to a moving camera; this run is static{why} and "
                                  f"{tail}")
    moving = "a moving sequence compares each frame with its converged Burley reference"
    for flag, on, why in (("--save-gbuffer", save_gbuffer, ""), ("--reference", s.reference, f" ({moving})"),
                          ("--no-exact", given(ctx, "no_exact"), f" ({moving} of --limit-spp spp)")):
        if on and not (p.static or still):  # (the reference's options need --reference: RenderSettings)
            raise SsskitError(f"{flag} applies to one frame; add --static{why}")


#: the files :class:`FrameWriter` writes into --frames-dir
FRAME_FILE = re.compile(r"(frame_\d{4,}(_taa)?|counts_\d{4,})\.png")


class FrameWriter:
    """Writes an adaptive run's frames into ``folder``: ``frame_NNNN.png`` (the pass's composite),
    ``frame_NNNN_taa.png`` (after TAA) and ``counts_NNNN.png`` (sample-count heatmap, colour bar 0..b_max),
    tone-mapped with the sequence's one peak (:class:`~ssskit.pipeline.adaptive.AdaptiveFrame`)."""

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)

    def __call__(self, frame: AdaptiveFrame) -> None:
        from ..figures.sequence import save_frame_png, save_heatmap_png

        n = frame.number
        save_frame_png(self.folder / f"frame_{n:04d}.png", frame.image, frame.peak)
        if frame.image_taa is not None:
            save_frame_png(self.folder / f"frame_{n:04d}_taa.png", frame.image_taa, frame.peak)
        mask = frame.counts > 0
        mean = float(frame.counts[mask].mean()) if mask.any() else 0.0
        save_heatmap_png(self.folder / f"counts_{n:04d}.png", np.asarray(frame.counts), frame.b_max,
                         f"adaptive frame {n}: mean {mean:.1f} spp")


__all__ = ["FIELDS", "FRAME_FILE", "PASS_OPTIONS", "SIGMA0", "Budget", "FrameWriter", "build_settings", "check_inputs",
           "load_settings", "own", "pass_of"]
