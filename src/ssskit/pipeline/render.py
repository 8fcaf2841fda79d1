"""Render one frame with screen-space separable SSS and compare it with ground truth.

    >>> from ssskit.pipeline import RenderSettings, render
    >>> r = render("slab", RenderSettings(material="skin1", kernel="preintegrated", taps=7))  # doctest: +SKIP
    >>> r.metrics["exact_2d"]["psnr"]                                                          # doctest: +SKIP

The steps: material -> profile (``settings.model``) -> kernel (``settings.kernel``, on the profile's
default grid) -> taps (``settings.taps`` placed by ``settings.tap_method``) -> G-buffer -> separable
pass (``settings.sss``, one pass over every profile id) -> composite albedo * sss + specular
(separable-SSS paper section 6) -> ground truths and their metrics.

``scene`` is a built-in scene name (:data:`ssskit.scenes.SCENES`, rendered by Mitsuba at
``settings.width`` x ``settings.height`` with ``settings.spp`` and ``settings.seed``), a G-buffer
``.exr`` file, or a :class:`GBuffer` in memory (to run several kernels on one render). The frame
(``settings.sss.frame``) also moves a built-in scene's camera and lights along their paths.

Every check happens before any work (no profile, render or convolution starts on bad input):

* a G-buffer (file or in memory) keeps its own size: a ``width`` x ``height`` that differs from the
  default and from the G-buffer's size is an error (``--size`` does not apply to a G-buffer file);
  ``reference`` needs a built-in scene and is refused for a G-buffer;
* an engine tap kernel (a method whose parameter is its tap count: ``jimenez2012``) is built with
  ``settings.taps`` taps unless the spec names its count (``jimenez2012:17``); a spec count that
  differs from a non-default ``settings.taps`` is an error, and so is a non-default ``tap_method``
  (the engine ships its placement);
* a built-in scene needs a homogeneous material (its eta makes the boundary); the reference also
  needs one Henyey-Greenstein g for all channels (Mitsuba's hg phase function);
* the backend must be able to run here.

A profile model that takes no material (``deon2007``) is used as is; the material still gives the
scene's boundary and the reference's medium. One material serves every profile id of a G-buffer.

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
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..backends import get_backend
from ..errors import SceneError, SettingsError
from ..io import check_distinct, save_image
from ..kernels import KernelMethod, TapKernel, build_kernel, check_params, default_grid, parse_method_spec
from ..materials import get_material
from ..metrics import region_metrics
from ..profiles import MATERIAL_FREE_MODELS, profile_for_material
from ..sampling.taps import SeparableTaps, make_taps
from ..scenes import SCENES, reference_phase_g, render_gbuffer, render_reference
from ..scenes.scenes import mitsuba
from ..screenspace import GBuffer, load_gbuffer, separable_sss
from ..truth import exact_screen_space
from .settings import RenderSettings

if TYPE_CHECKING:
    from .burley import BurleyResult

Progress = Callable[[str], None]


def _default(name: str):
    return {f.name: f.default for f in dataclasses.fields(RenderSettings)}[name]


class ImageLayers:
    """What a rendered result writes: its ``image`` with the extra EXR layers (shared by the separable
    and the Burley results; they hold ``gbuffer``, ``sss``, ``image``, ``exact``, ``reference``, ``source``)."""

    def layers(self) -> dict[str, np.ndarray]:
        """The extra EXR layers of :meth:`save`: ``sss``, ``diffuse``, and ``exact`` (composited) and
        ``reference`` when computed."""
        out = {"sss": self.sss, "diffuse": self.gbuffer.diffuse}
        if self.exact is not None:
            out["exact"] = self.gbuffer.composite(self.exact)
        if self.reference is not None:
            out["reference"] = self.reference
        return out

    def save(self, path: str | Path) -> None:
        """Write the image: ``.exr`` (linear, with :meth:`layers`) or ``.png`` (tone-mapped); never over
        the G-buffer file it was rendered from."""
        check_distinct(path, self.source, what="output image")
        save_image(path, self.image, self.layers(), what="output image")


@dataclass
class RenderResult(ImageLayers):
    """One rendered frame: its inputs, the pass's output, the ground truths and the errors."""

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


    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: scene, material, size [W, H], tap count, settings, taps and metrics
        (non-finite numbers, e.g. the PSNR of an exact match, become None)."""
        h, w = self.gbuffer.shape
        return {"scene": self.scene, "material": getattr(self.material, "name", str(self.material)),
                "size": [int(w), int(h)], "taps": int(self.taps.taps), "settings": self.settings.to_dict(),
                "tap_table": self.taps.to_dict(), "metrics": _finite(self.metrics)}


def _finite(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


@dataclass(frozen=True)
class _Plan:
    """What :func:`render` will do, resolved and checked before any work."""

    material: Any
    method: KernelMethod
    params: dict[str, Any]
    tap_count: int | None  # None: an engine tap kernel's own count
    scene: str  # label
    builtin: str | None  # a built-in scene's canonical name
    gbuffer: GBuffer | None  # a G-buffer given in memory or read from a file
    source: Path | None


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
        raise SettingsError(f"kernel {label!r} names {named} taps but taps is {settings.taps}; give the count once")
    if settings.tap_method != _default("tap_method"):
        raise SettingsError(f"tap_method {settings.tap_method!r} does not apply to the {method.name} kernel "
                            "(an engine tap kernel ships its own tap placement)")
    return method, params, None


def _scene_plan(scene, settings: RenderSettings, material) -> tuple[str, str | None, GBuffer | None, Path | None]:
    if isinstance(scene, GBuffer):
        return str(scene.meta.get("scene", "G-buffer")), None, scene, None
    if not isinstance(scene, (str, os.PathLike)):
        raise SceneError(f"scene must be a built-in scene name, a G-buffer .exr file or a GBuffer, "
                         f"got {type(scene).__name__}")
    text = os.fspath(scene)
    if text.strip().lower().endswith(".exr"):
        if settings.reference:
            raise SettingsError("reference needs a built-in scene (a G-buffer file has no scene to path-trace)")
        path = Path(text)
        return path.name, None, load_gbuffer(path), path
    if text not in SCENES and (Path(text).suffix or os.sep in text or Path(text).exists()):
        raise SceneError(f"scene {text!r} is neither a built-in scene ({', '.join(SCENES.names())}) "
                         "nor a G-buffer .exr file")
    spec = SCENES.get(text)  # an unknown name fails here with the list of scenes
    if not hasattr(material, "eta"):
        raise SettingsError(f"a built-in scene needs a homogeneous material (its eta makes the boundary); "
                            f"{material.name!r} is a {type(material).__name__}")
    if settings.reference:
        reference_phase_g(material)
    mitsuba()  # the renderer must be importable
    return spec.name, spec.name, None, None


def plan_render(scene, settings: RenderSettings) -> _Plan:
    """Resolve and check everything :func:`render` needs, doing no work (module docstring); reads a
    G-buffer file. Raises the first problem as an :class:`~ssskit.errors.SsskitError`."""
    if not isinstance(settings, RenderSettings):
        raise SettingsError(f"settings must be RenderSettings, got {type(settings).__name__}")
    material = get_material(settings.material)
    method, params, tap_count = _kernel_plan(settings)
    get_backend(settings.sss.backend)
    if isinstance(scene, GBuffer) and settings.reference:
        raise SettingsError("reference needs a built-in scene (a G-buffer in memory has no scene to path-trace)")
    label, builtin, gb, source = _scene_plan(scene, settings, material)
    if gb is not None:
        h, w = gb.shape
        size = (settings.width, settings.height)
        if size not in ((_default("width"), _default("height")), (w, h)):
            raise SettingsError(f"the image size {size[0]}x{size[1]} (--size) does not apply to a G-buffer file: "
                                f"{label} is {w}x{h} and keeps its size")
    return _Plan(material, method, params, tap_count, label, builtin, gb, source)


def render(scene: str | Path | GBuffer = "slab", settings: RenderSettings | None = None,
           progress: Progress | None = None) -> RenderResult | BurleyResult:
    """Render ``scene`` with separable SSS under ``settings`` and compare it with ground truth (module
    docstring). ``progress`` receives one message per step. With ``settings.method == "burley"`` the
    Burley pass runs instead (:func:`ssskit.pipeline.burley.render_burley` with ``settings.burley``;
    a :class:`~ssskit.pipeline.burley.BurleyResult`)."""
    settings = RenderSettings() if settings is None else settings
    if isinstance(settings, RenderSettings) and settings.method == "burley":  # plan_render checks the type
        from .burley import render_burley

        return render_burley(scene, settings, progress=progress)
    plan = plan_render(scene, settings)
    say = progress or (lambda msg: None)
    mat = plan.material
    model = settings.model.strip().lower()
    opts = {"photons": settings.photons} if model == "montecarlo" else {}
    say(f"profile: {settings.model}" + ("" if model in MATERIAL_FREE_MODELS else f" of {mat.name}")
        + (f" ({settings.photons:,} photons per channel)" if opts else ""))
    profile = profile_for_material(None if model in MATERIAL_FREE_MODELS else mat, settings.model, **opts)
    say(f"kernel: {settings.kernel}")
    cell, n = default_grid(profile)
    kernel = build_kernel(plan.method.name, profile, cell, n, **plan.params)
    taps = make_taps(kernel, None if isinstance(kernel, TapKernel) else plan.tap_count, settings.tap_method)
    gb = plan.gbuffer
    if gb is None:
        say(f"rendering the {plan.builtin} G-buffer ({settings.width}x{settings.height}, {settings.spp} spp, "
            "Mitsuba scalar_rgb)")
        gb = render_gbuffer(plan.builtin, np.clip(profile.total_rd(), 0.0, 1.0), eta=mat.eta, width=settings.width,
                            height=settings.height, spp=settings.spp, seed=settings.seed, frame=settings.sss.frame,
                            material=mat.name)
    placement = "engine" if isinstance(kernel, TapKernel) else settings.tap_method
    say(f"separable pass: {settings.kernel}, {taps.taps} {placement} taps, jitter {settings.sss.jitter:g}, "
        f"{settings.sss.backend} backend")
    sss = separable_sss(gb, taps, settings.sss)
    res = RenderResult(plan.scene, settings, mat, profile, kernel, taps, gb, sss, gb.composite(sss),
                       source=plan.source)
    mask = gb.mask
    if settings.exact and mask.any():
        say("exact 2D convolution (FFT)")
        res.exact = exact_screen_space(gb, profile)
        if res.exact is not None:
            res.metrics["exact_2d"] = region_metrics(gb.composite(res.exact), res.image, mask, settings.perceptual)
    if settings.reference:
        say(f"path tracing {plan.builtin} (Mitsuba volpathmis, {settings.reference_spp} to {settings.reference_max_spp} "
            f"spp until the SSS mask's relative standard error is {settings.reference_rel_se:.1%}; cached)")
        ref = render_reference(plan.builtin, mat, width=gb.shape[1], height=gb.shape[0], spp=settings.reference_spp,
                               max_spp=settings.reference_max_spp, target_rel_se=settings.reference_rel_se,
                               region=mask if mask.any() else None, seed=settings.seed, frame=settings.sss.frame,
                               progress=progress is not None)
        res.reference = ref.image
        res.reference_info = ref
        m = region_metrics(res.reference, res.image, mask, settings.perceptual)
        m["mean_ratio_in_mask"] = ((res.image[mask].mean(axis=0) / np.maximum(res.reference[mask].mean(axis=0), 1e-12))
                                   .tolist() if mask.any() else None)
        m["pixels_with_surface"] = int(np.isfinite(gb.depth).sum())
        m["reference"] = ref.summary()
        res.metrics["path_traced"] = m
    if (settings.reference or res.exact is not None) and mask.any():
        from .regions import compare_regions

        res.metrics["regions"] = compare_regions(gb, profile, sss, res.exact, res.reference_info)
    return res
