"""Render a scene with screen-space SSS and compare it with ground truth: :func:`render` runs the pass the
settings name (``settings.pass_``: the separable pass here, :func:`render_separable`; the Burley pass,
:func:`ssskit.pipeline.burley_frame.render_burley`; the adaptive run over frames,
:func:`ssskit.pipeline.adaptive.render_adaptive`).

    >>> from ssskit.pipeline import RenderSettings, render
    >>> r = render("slab", RenderSettings(material="skin1", kernel="preintegrated", taps=7))  # doctest: +SKIP
    >>> r.metrics["exact_2d"]["psnr"]                                                          # doctest: +SKIP

The separable frame:

The steps: material -> profile (``settings.model``) -> kernel (``settings.kernel``, on the profile's
default grid) -> taps (``settings.taps`` placed by ``settings.tap_method``) -> G-buffer -> separable
pass (``settings.pass_``, one pass over every profile id) -> composite albedo * sss + specular
(separable-SSS paper section 6) -> ground truths and their metrics.

``scene`` is a built-in scene name (:data:`ssskit.scenes.SCENES`, rendered by Mitsuba at
``settings.width`` x ``settings.height`` with ``settings.spp`` and ``settings.seed``), a mesh scene
(a generated mesh such as ``bust``, a mesh file .obj/.ply/.glb/.gltf or a scene .toml, or a
:class:`~ssskit.scenes.ResolvedScene` from :func:`ssskit.scenes.resolve_scene` with units, material
map and view; docs/meshes.md), a G-buffer ``.exr`` file, or a :class:`GBuffer` in memory (to run
several kernels on one render). The frame (``settings.frame``) also moves a scene's camera and lights
along their paths.

Every check happens before any work (no profile, render or convolution starts on bad input):

* a G-buffer (file or in memory) keeps its own size: a ``width`` x ``height`` that differs from the
  default and from the G-buffer's size is an error (``--size`` does not apply to a G-buffer file);
  ``reference`` needs a scene and is refused for a G-buffer; a mesh scene's checks
  (:func:`ssskit.scenes.resolve_scene`: the file, its size in memory, NaN vertices, the material map,
  the units) all run here, and the reference refuses an open or non-manifold SSS mesh with the reason;
* an engine tap kernel (a method whose parameter is its tap count: ``jimenez2012``) is built with
  ``settings.taps`` taps unless the spec names its count (``jimenez2012:17``); a spec count that
  differs from a non-default ``settings.taps`` is an error, and so is a non-default ``tap_method``
  (the engine ships its placement);
* a built-in scene needs a homogeneous material (its eta makes the boundary); the reference also
  needs one Henyey-Greenstein g for all channels (Mitsuba's hg phase function);
* the backend must be able to run here.

A profile model that takes no material (``deon2007``) is used as is; the material still gives the
scene's boundary and the reference's medium. One material serves every profile id of a G-buffer; a
scene whose objects carry their own materials (a material map) gets one profile, kernel and set of
taps per profile id (``RenderResult.profile`` is then a mapping id -> profile; ``kernel`` and ``taps``
are id 1's), and the reference one medium per object.

Two ground truths:

* ``exact``: the full 2D convolution of the diffuse layer with the profile (paper Eq. 1) on each SSS
  region, with the pass's own boundary rule (:func:`ssskit.truth.exact_screen_space`); exact for a
  fronto-parallel surface (the slab scene);
* ``reference``: a volumetric path-traced image of the same scene (Mitsuba ``volpathmis``;
  :func:`ssskit.scenes.render_reference`), which also contains what no screen-space method has;
  every non-SSS surface is black in it, so it is lit by the lights alone, like the G-buffer's
  diffuse layer; rendered until the SSS mask's mean has a relative standard error of at most
  ``reference_rel_se`` or ``reference_max_spp`` is spent (``metrics["path_traced"]["reference"]``
  says which, with the spp and the standard errors).

Metrics (:func:`ssskit.metrics.region_metrics`) are taken inside the SSS mask on the composited
images: ``metrics["exact_2d"]`` and ``metrics["path_traced"]`` (plus the ratio of mean values inside
the mask, per channel, and the number of pixels with a surface).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..backends import warm_up_in_background
from ..errors import SettingsError
from ..quantities import check_instance, refuse_twice, refuse_unused
from ..kernels import KernelMethod, TapKernel, build_kernel, check_params, default_grid, parse_method_spec
from ..profiles import MATERIAL_FREE_MODELS, profile_for_material
from ..sampling.taps import SeparableTaps, make_taps
from ..screenspace import BurleyParams, GBuffer, default_depth_mode, separable_sss
from ..truth import exact_screen_space
from .adaptive import AdaptiveResult, FrameCallback, render_adaptive
from .burley_frame import BurleyResult, render_burley
from .frame import (BurleyInput, ImageLayers, Progress, SceneInput, ScenePlan, finite, frame_gbuffer, ground_truths,
                    material_label, metric_lines, per_id, plan_scene, reference_line)
from .settings import RenderSettings, SeparablePass
from .transmission import TransmissionInfo, transmission_passes, with_transmission


def _default(name: str) -> Any:
    return {f.name: f.default for f in dataclasses.fields(RenderSettings)}[name]


@dataclass
class RenderResult(ImageLayers):
    """One rendered frame of the separable pass: its inputs, the pass's output, the ground truths and the
    errors."""

    scene: str  # the built-in scene's name, the G-buffer file's name, or the G-buffer's meta["scene"]
    settings: RenderSettings
    material: Any
    profile: Any
    kernel: Any
    taps: SeparableTaps
    gbuffer: GBuffer
    sss: np.ndarray  # blurred diffuse layer (H, W, 3)
    image: np.ndarray  # composite albedo * sss + specular (H, W, 3)
    exact: np.ndarray | None = None  # blurred diffuse layer by the exact 2D convolution
    reference: np.ndarray | None = None  # path-traced image
    reference_info: Any = None  # the path trace's ssskit.scenes.Reference (standard errors, spp, convergence)
    metrics: dict[str, Any] = field(default_factory=dict)
    source: Path | None = None  # the G-buffer file read, if any
    transmitted: np.ndarray | None = None  # the transmitted radiance in the image (H, W, 3), when the pass ran
    transmission: TransmissionInfo = field(default_factory=lambda: TransmissionInfo("off", False))
    #: profile id -> material name where a material map gives the ids different materials (else empty)
    id_materials: dict[int, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: scene, material (:func:`~ssskit.pipeline.frame.material_label`; ``materials``:
        profile id -> name where the ids differ), size [W, H], tap count (profile id 1's), settings, taps and
        metrics (non-finite numbers, e.g. the PSNR of an exact match, become None)."""
        h, w = self.gbuffer.shape
        return {"scene": self.scene, "pass": "separable", "material": material_label(self.material, self.id_materials),
                **({"materials": {str(k): v for k, v in self.id_materials.items()}} if self.id_materials else {}),
                "size": [int(w), int(h)], "taps": int(self.taps.taps), "settings": self.settings.replace(width=int(w), height=int(h)).to_dict(),
                "tap_table": self.taps.to_dict(), "transmission": self.transmission.to_dict(),
                "metrics": finite(self.metrics)}

    def lines(self) -> list[str]:
        """The human-readable summary ``ssskit render`` prints: the set-up, the metrics against each ground
        truth, the levels per region and the reference's convergence."""
        from .regions import format_regions

        s = self.settings
        h, w = self.gbuffer.shape
        what = (f"{material_label(self.material, self.id_materials)}; {s.model} profiles" if self.id_materials
                else f"{self.material.name} ({s.model})")
        out = [f"# {self.scene}: {what}, {s.kernel} with {self.taps.taps} taps, "
               f"jitter {s.pass_settings().jitter:g}, {w}x{h}, {s.backend} backend"]
        out.append(self.transmission.line())
        out += metric_lines(self.metrics)
        out += format_regions(self.metrics.get("regions"))
        if self.reference_info is not None:
            out.append(reference_line(self.reference_info))
        return out


@dataclass(frozen=True)
class _Plan:
    """What :func:`render_separable` will do, resolved and checked before any work."""

    scene: ScenePlan
    method: KernelMethod
    params: dict[str, Any]
    tap_count: int | None  # None: an engine tap kernel's own count


def _kernel_plan(settings: RenderSettings) -> tuple[KernelMethod, dict[str, Any], int | None]:
    method, params, label = parse_method_spec(settings.kernel)
    if method.primary != "taps":
        return method, params, settings.taps
    # an engine tap kernel: its tap count is a kernel parameter, and it ships its own placement
    named = params.get("taps")
    if named is None:
        params = {**params, "taps": settings.taps}
        check_params(method, params)
    elif named != settings.taps and settings.taps != _default("taps"):
        refuse_twice(f"kernel {label!r}", f"taps {settings.taps}", "the number of taps", SettingsError)
    if settings.tap_method != _default("tap_method"):
        refuse_unused([f"tap_method {settings.tap_method!r}"], "a", ("tabulated kernel",),
                      f"{method.name} kernel (an engine tap kernel ships its own tap placement)", SettingsError)
    return method, params, None


def plan_render(scene: SceneInput, settings: RenderSettings) -> _Plan:
    """Resolve and check everything :func:`render_separable` needs, doing no work (module docstring); reads
    a G-buffer file. Raises the first problem as an :class:`~ssskit.errors.SsskitError`."""
    check_instance(settings, RenderSettings, 'settings', SettingsError)
    settings.pass_as(SeparablePass, "the separable one")  # (plan_render plans the separable pass)
    method, params, tap_count = _kernel_plan(settings)
    return _Plan(plan_scene(scene, settings), method, params, tap_count)


def render_separable(scene: SceneInput = "slab", settings: RenderSettings | None = None,
                     progress: Progress | None = None) -> RenderResult:
    """Render ``scene`` with the separable pass under ``settings`` and compare it with ground truth
    (module docstring). ``progress`` receives one message per step."""
    settings = RenderSettings() if settings is None else settings
    plan = plan_render(scene, settings)
    say = progress or (lambda msg: None)
    mat = plan.scene.material
    model = settings.model.strip().lower()
    opts = {"photons": settings.photons} if model == "montecarlo" else {}
    say(f"profile: {settings.model}" + ("" if model in MATERIAL_FREE_MODELS else
                                        f" of {material_label(mat, plan.scene.id_materials)}")
        + (f" ({settings.photons:,} photons per channel)" if opts else ""))
    # one profile, kernel and taps, or one per profile id where a material map gives ids their own materials
    profile = per_id(plan.scene, lambda m: profile_for_material(None if model in MATERIAL_FREE_MODELS else m,
                                                                 settings.model, **opts))
    say(f"kernel: {settings.kernel}")

    def taps_of(prof):
        cell, n = default_grid(prof)
        k = build_kernel(plan.method.name, prof, cell, n, **plan.params)
        return k, make_taps(k, None if isinstance(k, TapKernel) else plan.tap_count, settings.tap_method)

    if isinstance(profile, Mapping):
        built = {pid: taps_of(p) for pid, p in profile.items()}
        kernel, taps = built[1]
        pass_taps: Any = {pid: t for pid, (_, t) in built.items()}
        albedo: Any = {pid: p.total_rd() for pid, p in profile.items()}
    else:
        kernel, taps = taps_of(profile)
        pass_taps, albedo = taps, profile.total_rd()
    sss_settings = settings.pass_settings()
    # the pass's kernels compile (a fresh machine: seconds, one thread) while Mitsuba renders the G-buffer
    warming = warm_up_in_background(settings.backend, [  # several ids' slot map after the pass: not waited for
        f"separable:{sss_settings.depth_mode or default_depth_mode(pass_taps)}", "separable:ids"]
        + transmission_passes(settings, plan.scene.transmission))
    gb = frame_gbuffer(plan.scene, settings, albedo, say, beside=warming)
    exact: Callable[[], np.ndarray | None] = functools.cache(lambda: exact_screen_space(gb, profile))
    if warming is not None and warming.is_alive() and settings.exact and gb.mask.any():
        exact()  # the exact convolution (ground_truths' first step) while the pass still compiles
    placement = "engine" if isinstance(kernel, TapKernel) else settings.tap_method
    say(f"separable pass: {settings.kernel}, {taps.taps} {placement} taps, jitter {sss_settings.jitter:g}, "
        f"{settings.backend} backend")
    sss = separable_sss(gb, pass_taps, sss_settings)
    transmitted, info = None, TransmissionInfo(settings.transmission, False)
    if plan.scene.transmission:
        sss, transmitted, info, exact = with_transmission(gb, sss, settings, plan.scene.materials,
                                                  plan.scene.material, exact, say)
    res = RenderResult(plan.scene.label, settings, mat, profile, kernel, taps, gb, sss, gb.composite(sss),
                       source=plan.scene.source, transmitted=transmitted, transmission=info,
                       id_materials=plan.scene.id_materials)
    ground_truths(res, settings, plan.scene, profile, exact, say, progress is not None)
    if warming is not None:  # the several ids' slot map (a fraction of a second): a process that exits next must
        warming.join()  # not leave a daemon thread inside LLVM while the interpreter shuts down
    return res


def plan(scene: SceneInput, settings: RenderSettings, *, params: BurleyInput | None = None) -> ScenePlan:
    """Every check :func:`render` makes for the pass ``settings`` names, doing no work; returns the scene's
    plan (its ``notes``: what resolving a mesh scene assumed). A caller that reports those notes runs this
    first, so a bad input is its only message."""
    check_instance(settings, RenderSettings, 'settings', SettingsError)
    _refuse_unused(settings.pass_name, params)
    if settings.pass_name == "burley-adaptive":
        from .adaptive import plan_adaptive

        return plan_adaptive(scene, settings, params)[0]
    if settings.pass_name == "burley":
        from .burley_frame import plan_burley

        return plan_burley(scene, settings, params)[0]
    return plan_render(scene, settings).scene


def _refuse_unused(name: str, params: BurleyInput | None, on_frame: FrameCallback | None = None) -> None:
    """The options of :func:`render` given that the pass ``name`` does not use, refused in the one wording:
    ``params`` (Burley parameters) for the Burley passes, ``on_frame`` for the adaptive run's frames."""
    for option, given, passes in (("params", params, ("burley", "burley-adaptive")),
                                  ("on_frame", on_frame, ("burley-adaptive",))):
        if given is not None and name not in passes:
            refuse_unused([option], "pass", passes, name, SettingsError)


def render(scene: SceneInput = "slab", settings: RenderSettings | None = None,
           progress: Progress | None = None, *, params: BurleyInput | None = None,
           on_frame: FrameCallback | None = None) -> RenderResult | BurleyResult | AdaptiveResult:
    """Render ``scene`` with the pass ``settings.pass_`` names and compare it with ground truth:
    :func:`render_separable` (a :class:`RenderResult`), :func:`~ssskit.pipeline.burley_frame.render_burley`
    (a :class:`~ssskit.pipeline.burley_frame.BurleyResult`) or
    :func:`~ssskit.pipeline.adaptive.render_adaptive` (an :class:`~ssskit.pipeline.adaptive.AdaptiveResult`).
    ``progress`` receives one message per step; ``params`` (Burley passes only): the Burley parameters of
    every profile id instead of the material's; ``on_frame`` (the adaptive run only): called with every
    frame it renders (:class:`~ssskit.pipeline.adaptive.AdaptiveFrame`), e.g. to write it."""
    settings = RenderSettings() if settings is None else settings
    check_instance(settings, RenderSettings, 'settings', SettingsError)
    name = settings.pass_name
    _refuse_unused(name, params, on_frame)
    if name == "burley-adaptive":
        return render_adaptive(scene, settings, progress=progress, params=params, on_frame=on_frame)
    if name == "burley":
        return render_burley(scene, settings, progress=progress, params=params)
    return render_separable(scene, settings, progress)


__all__ = ["RenderResult", "plan", "plan_render", "render", "render_separable"]
