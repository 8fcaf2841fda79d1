"""What every rendered frame shares, whichever pass made it: the scene's plan (checked before any work), its
G-buffer, the ground truths and their metrics, and the image layers a result writes.

* :func:`plan_scene` resolves the material, the backend and the scene (a built-in scene name, a G-buffer
  ``.exr`` file or a :class:`~ssskit.screenspace.GBuffer` in memory) and checks them against the
  settings, doing no work (module docstring of :mod:`ssskit.pipeline.render` lists the checks);
* :func:`frame_gbuffer` renders a built-in scene's G-buffer (Mitsuba ``scalar_rgb``) at the settings'
  size, samples, seed and frame, or returns the G-buffer given;
* :func:`ground_truths` adds to a result the exact 2D convolution (the pass's own, given as a function)
  and the volumetric path-traced reference (:func:`ssskit.scenes.render_reference`, rendered until the
  SSS mask's mean has a relative standard error of at most ``reference_rel_se`` or ``reference_max_spp``
  is spent), their metrics inside the SSS mask (:func:`ssskit.metrics.region_metrics`), and the level
  per region (:func:`ssskit.pipeline.regions.compare_regions`);
* :class:`ImageLayers`: what a result writes (its image with the extra EXR layers).
"""

from __future__ import annotations

import dataclasses
import math
import os
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from ..backends import get_backend
from ..errors import SceneError, SettingsError, SsskitError
from ..io import check_distinct, save_image
from ..materials import LayeredMaterial, Material, get_material, homogeneous
from ..metrics import NO_LIGHT_TEXT, no_light, region_metrics
from ..scenes import SCENES, ResolvedScene, SceneSpec, reference_phase_g, render_gbuffer, render_reference, resolve_scene
from ..scenes.mitsuba_variant import leaving_a_core_to
from ..scenes.reference import check_reference_scene
from ..scenes.meshes import check_render_memory, shape_counts
from ..scenes.scenefile import BUILTIN_DIR
from ..scenes.scenes import mitsuba
from ..profiles import check_model_domain
from ..quantities import refuse_unused
from ..screenspace import BurleyParams, GBuffer, load_gbuffer
from ..profiles.base import RGBProfile
from ..scenes.reference import Reference
from .regions import compare_regions
from .settings import RenderSettings
from .transmission import transmission_runs

Progress = Callable[[str], None]
#: what a frame renders: a built-in scene name, a generated mesh, a mesh or scene .toml file, a G-buffer .exr
#: file (a name or path), a SceneSpec, a resolved scene (:func:`ssskit.scenes.resolve_scene`), or a GBuffer
SceneInput = str | os.PathLike[str] | GBuffer | SceneSpec | ResolvedScene
#: the Burley parameters of every profile id, or a mapping profile id -> parameters
BurleyInput = BurleyParams | Mapping[int, BurleyParams]


class ImageLayers:
    """What a rendered result writes: its ``image`` with the extra EXR layers (shared by the separable
    and the Burley results; they hold ``gbuffer``, ``sss``, ``image``, ``exact``, ``reference``, ``source``)."""

    gbuffer: GBuffer
    sss: np.ndarray
    image: np.ndarray
    exact: np.ndarray | None
    reference: np.ndarray | None
    source: Path | None
    transmitted: np.ndarray | None

    def layers(self) -> dict[str, np.ndarray]:
        """The extra EXR layers of :meth:`save`: ``sss``, ``diffuse``, ``transmission`` (the transmitted
        radiance the composite holds, :mod:`ssskit.pipeline.transmission`) when the pass ran, and ``exact``
        (composited) and ``reference`` when computed."""
        out = {"sss": self.sss, "diffuse": self.gbuffer.diffuse}
        if self.transmitted is not None:
            out["transmission"] = self.transmitted
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


class TruthResult(Protocol):
    """What :func:`ground_truths` fills in: a result's G-buffer, image and blurred diffuse layer, its ground
    truths and metrics."""

    gbuffer: GBuffer
    sss: np.ndarray
    image: np.ndarray
    exact: np.ndarray | None
    reference: np.ndarray | None
    reference_info: Any
    metrics: dict[str, Any]


def metric_lines(metrics: dict[str, Any], prefix: str = "vs ", width: int = 12) -> list[str]:
    """One line per ground truth (``exact_2d``, ``path_traced``...): its float metrics, or where the ground
    truth is black inside the SSS mask (:func:`ssskit.metrics.no_light`) its absolute ones and the reason the
    others are missing; the per-region table is left to :func:`ssskit.pipeline.regions.format_regions`."""
    def line(m: dict[str, Any]) -> str:
        dark = no_light(m)
        return "  ".join([f"{k} {v:.4g}" for k, v in m.items() if isinstance(v, float) and not (dark and math.isnan(v))]
                         + ([f"({NO_LIGHT_TEXT})"] if dark else []))

    return [f"{prefix}{against:{width}s} " + line(m) for against, m in metrics.items() if against != "regions"]


def reference_line(ref: Reference) -> str:
    """The path-traced reference's convergence (:class:`ssskit.scenes.Reference`) in one line."""
    return (f"# reference: {ref.spp} spp, relative standard error of the SSS mask's mean "
            + ", ".join(f"{v:.2%}" for v in ref.rel_se) + f" (target {ref.target_rel_se:.1%}, budget "
            f"{ref.max_spp} spp: {'converged' if ref.converged else 'budget spent, not converged'})")


def finite(value: Any) -> Any:
    """``value`` with every non-finite float (e.g. the PSNR of an exact match) replaced by None, through
    dicts, lists and tuples: JSON-ready."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    return value


@dataclass(frozen=True)
class ScenePlan:
    """What a frame renders, resolved and checked before any work: the ``material`` (the settings', or the
    scene's own where it names one for every SSS object: :func:`_scene_material`), the
    scene's ``label``, a built-in scene's canonical name (``builtin``), the ``spec`` of a built-in or mesh
    scene (:func:`ssskit.scenes.resolve_scene`) with one material per profile id (``materials``) and what
    resolving it assumed (``notes``), or the ``gbuffer`` given or read from the file ``source``."""

    material: Any
    label: str
    builtin: str | None
    gbuffer: GBuffer | None
    source: Path | None
    spec: SceneSpec | None = None
    materials: tuple[Any, ...] = ()
    notes: tuple[str, ...] = ()
    #: whether the frame runs the transmittance pass (:func:`ssskit.pipeline.transmission.transmission_runs`)
    transmission: bool = False

    @property
    def per_id(self) -> bool:
        """Whether the scene's profile ids carry different materials (a material map)."""
        return len({getattr(m, "name", m) for m in self.materials}) > 1

    @property
    def id_materials(self) -> dict[int, str]:
        """Profile id -> material name where the ids carry different materials (:attr:`per_id`), else empty."""
        return {i: str(getattr(m, "name", m)) for i, m in enumerate(self.materials, 1)} if self.per_id else {}


def material_label(material: Any, id_materials: Mapping[int, str]) -> str:
    """The frame's material in a summary: its name, or where a material map gives the profile ids different
    materials, each material with its ids (``Skin1 (id 1), Marble (ids 2, 3)``): the settings' material then
    names no object, so it must not stand for the frame."""
    if not id_materials:
        return str(getattr(material, "name", material))
    ids: dict[str, list[int]] = {}
    for pid, name in sorted(id_materials.items()):
        ids.setdefault(name, []).append(pid)
    return ", ".join(f"{name} ({'id' if len(v) == 1 else 'ids'} {', '.join(map(str, v))})" for name, v in ids.items())


def _scene(scene: SceneInput, settings: RenderSettings, material: Material | LayeredMaterial) -> ScenePlan:
    # (any other value: resolve_scene's SceneError naming what a scene may be)
    resolved = scene if isinstance(scene, (GBuffer, ResolvedScene)) else resolve_scene(
        scene, width=settings.width, height=settings.height)
    if settings.reference and (isinstance(resolved, GBuffer) or resolved.kind == "gbuffer"):
        refuse_unused(["reference"], "a", ("built-in or mesh scene",), "G-buffer (it has no scene to path-trace)",
                      SettingsError)
    if isinstance(resolved, GBuffer):
        return ScenePlan(material, str(resolved.meta.get("scene", "G-buffer")), None, resolved, None)
    if resolved.kind == "gbuffer":
        path = resolved.path
        assert path is not None
        return ScenePlan(material, path.name, None, load_gbuffer(path), path)
    spec = resolved.spec
    assert spec is not None
    mats: list[Material] = []
    for m in (material, *(get_material(name) for name in spec.shape_materials(settings.material))):
        mats.append(homogeneous(m, "a scene's object (its material's eta makes the boundary)", SettingsError))
    mats = mats[1:]
    material = _scene_material(spec, resolved.kind, settings, material, mats)
    if settings.reference:
        check_reference_scene(spec)
        for m in mats:
            reference_phase_g(m)
    # the memory a render of this size needs, for every scene kind (a mesh file was checked before it was read)
    kinds = {"builtin": "built-in scene", "generated": "generated scene", "file": "scene file"}
    kind = kinds.get(resolved.kind, "scene")
    check_render_memory(f"{kind} {spec.name!r}",
                        shape_counts([o.shape for o in resolved.objects]), settings.width, settings.height)
    mitsuba()  # the renderer must be importable
    builtin = spec.name if resolved.kind == "builtin" and spec.name in SCENES else None
    return ScenePlan(material, spec.name, builtin, None, None, spec, tuple(mats), resolved.notes)


def _scene_material(spec: SceneSpec, kind: str, settings: RenderSettings, material: Material | LayeredMaterial,
                    mats: list[Material]) -> Material | LayeredMaterial:
    """The frame's material (its labels, and the adaptive run's G-buffers) for a scene that names a material for
    every SSS object (the built-in ``leaf``: Apple): that material where all name the same one, the settings'
    otherwise. The settings' material then applies to no object: one that is not the default (an explicit
    ``--material``) and not the scene's own is refused rather than ignored (a scene file's ``material`` wins over
    ``--material``, which is the material of the objects naming none; ``--material-map`` overrides a mesh or
    scene file's, and a built-in scene's are fixed)."""
    own = spec.sss_materials
    if not own or not all(own):
        return material
    names = sorted({m.name for m in mats})
    default = get_material(RenderSettings().material)
    if material.name != default.name and names != [material.name]:
        held = ", ".join(f"{sid} = {m.name}" for sid, m in zip(spec.sss_shapes, mats))
        how = (f"a built-in scene's are fixed (its scene file {BUILTIN_DIR / (spec.name + '.toml')} takes --material-map "
               f"{spec.sss_shapes[0]}=MATERIAL)" if kind == "builtin" else "--material-map NAME=MATERIAL changes an object's")
        raise SettingsError(f"--material {settings.material} applies to no object of the scene {spec.name!r}: each names "
                            f"its own material ({held}); {how}")
    return mats[0] if len(names) == 1 else material


def _default_size() -> tuple[int, int]:
    d = RenderSettings()
    return d.width, d.height


def plan_scene(scene: SceneInput, settings: RenderSettings) -> ScenePlan:
    """Resolve and check the material, the backend and the scene of a frame, doing no work; reads a
    G-buffer file. ``scene``: a built-in scene name, a generated mesh, a mesh or scene .toml file (resolved
    with the defaults: no units, no material map, the scene's view), a :class:`~ssskit.scenes.ResolvedScene`
    (:func:`ssskit.scenes.resolve_scene` with the user's units, material map and view), a G-buffer ``.exr``
    file or a :class:`~ssskit.screenspace.GBuffer`. A G-buffer keeps its own size: a ``width`` x ``height``
    that differs from the default and from the G-buffer's is an error. Raises the first problem as an
    :class:`~ssskit.errors.SsskitError`. (``settings``: a RenderSettings, as its callers plan_render and
    plan_burley check.)"""
    material = get_material(settings.material)
    check_model_domain(material, settings.model)  # the model's valid domain, before any work
    get_backend(settings.backend)
    plan = _scene(scene, settings, material)
    if plan.gbuffer is not None:
        h, w = plan.gbuffer.shape
        size = (settings.width, settings.height)
        if size not in (_default_size(), (w, h)):
            refuse_unused([f"the image size {size[0]}x{size[1]} (--size)"], "a", ("built-in or mesh scene",),
                          f"G-buffer {plan.label} ({w}x{h}: it keeps its size)", SettingsError)
        _refuse_no_sss(plan.gbuffer, f"the G-buffer {plan.label}", "its profile_id is 0 everywhere", SettingsError)
        _check_named_materials(plan.gbuffer, material, plan.label)
    for mat in plan.materials:  # a scene's own materials (a material map) are held to the model's domain too
        check_model_domain(mat, settings.model)
    runs = transmission_runs(settings, plan.gbuffer, plan.label, plan.spec is not None,
                             len(plan.spec.lights()) if plan.spec is not None else 0, plan.materials or (material,),
                             plan.spec is not None and plan.spec.lit_from_behind)
    return dataclasses.replace(plan, transmission=runs)


def _check_named_materials(gb: GBuffer, material: Any, label: str) -> None:
    """A G-buffer that names its materials (header ``ssskit_materials``) names ones ssskit knows: a preset,
    a material file, or the material the frame is rendered with (one material serves every id)."""
    from ..errors import MaterialError

    for k, name in enumerate(gb.materials, 1):
        if name == material.name:
            continue
        try:
            get_material(name)
        except MaterialError:
            raise SettingsError(f"the G-buffer {label} names material {name!r} for profile id {k}, which is neither a "
                                f"preset nor a material file nor the material rendered ({material.name!r}); give "
                                "--material for it (one material serves every profile id)") from None


def per_id(plan: ScenePlan, make: Callable[[Any], Any]) -> Any:
    """``make(material)`` for the plan's one material, or a mapping profile id -> ``make`` of that id's
    material when the scene's ids carry different materials (each distinct material made once)."""
    if not plan.per_id:
        return make(plan.materials[0] if plan.materials else plan.material)
    made: dict[str, Any] = {}
    out = {}
    for pid, mat in enumerate(plan.materials, start=1):
        if mat.name not in made:
            made[mat.name] = make(mat)
        out[pid] = made[mat.name]
    return out


def frame_gbuffer(plan: ScenePlan, settings: RenderSettings, albedo: ArrayLike | Mapping[int, ArrayLike],
                  say: Progress, beside: threading.Thread | None = None) -> GBuffer:
    """The frame's G-buffer: the one given, or the scene rendered by Mitsuba with ``albedo`` (per channel,
    clipped to [0, 1]; or a mapping profile id -> albedo, :func:`per_id`) at the settings' size, samples,
    seed and frame, each profile id with its material's eta and name. ``beside``: a thread compiling the pass's
    kernels (:func:`ssskit.backends.warm_up_in_background`, one core): each of Mitsuba's images that starts
    while it runs leaves it a core (:func:`ssskit.scenes.mitsuba_variant.leaving_a_core_to`; the same image on
    any thread count), so on 2 cores the compilation, the longer of the two, is not slowed."""
    if plan.gbuffer is not None:
        return plan.gbuffer
    if beside is not None:
        with leaving_a_core_to(beside):
            return frame_gbuffer(plan, settings, albedo, say)
    assert plan.spec is not None
    say(f"rendering the {plan.label} G-buffer ({settings.width}x{settings.height}, {settings.spp} spp, "
        "Mitsuba scalar_rgb)")
    mats = plan.materials or (plan.material,)
    if isinstance(albedo, Mapping):
        alb = np.clip([albedo[pid] for pid in range(1, len(mats) + 1)], 0.0, 1.0)
    else:
        alb = np.clip(albedo, 0.0, 1.0)
    gb = render_gbuffer(plan.spec, alb, eta=[m.eta for m in mats], width=settings.width, height=settings.height,
                        spp=settings.spp, seed=settings.seed, frame=settings.frame,
                        material=tuple(m.name for m in mats), light_layers=plan.transmission)
    _refuse_no_sss(gb, f"the {plan.label} G-buffer ({settings.width}x{settings.height})", "the camera sees no surface "
                   "of an SSS object (a flat model seen edge-on, or one outside the frame)", SceneError)
    return gb


def _refuse_no_sss(gb: GBuffer, label: str, why: str, error: type[SsskitError]) -> None:
    """The one rule of a G-buffer file (plan_scene) and of a rendered one (frame_gbuffer): at least one SSS pixel,
    else ``error`` naming ``label`` and ``why`` there is none."""
    if not gb.mask.any():
        raise error(f"{label} has no SSS pixel: {why}, so there is nothing for the pass to blur and nothing to measure")


def ground_truths(res: TruthResult, settings: RenderSettings, plan: ScenePlan, profile: RGBProfile,
                  exact: Callable[[], np.ndarray | None], say: Progress, progress: bool) -> None:
    """Add the ground truths to ``res`` (module docstring): ``exact()`` (the pass's exact limit, blurred
    diffuse layer or None) when ``settings.exact``, the path-traced reference when ``settings.reference``,
    their metrics inside the SSS mask, and with either the levels per region of ``profile`` (a radial
    profile, or a mapping profile id -> profile: the furthest-reaching one's reach sizes the regions). ``progress``: show the path tracer's progress bar."""
    gb = res.gbuffer
    mask = gb.mask
    if settings.exact and mask.any():
        say("exact 2D convolution (FFT)")
        res.exact = exact()
        if res.exact is not None:
            m_exact = region_metrics(gb.composite(res.exact), res.image, mask, settings.perceptual)
            if not np.any(gb.diffuse[mask]):  # no front light: the pass and its exact limit blur nothing, and
                # match (the transmitted light, if any, is added to both alike): no relative error, PSNR or FLIP
                m_exact = {**{k: (math.nan if k in ("relative_rmse", "psnr", "flip") else v) for k, v in m_exact.items()},
                           "no_light": True}
            res.metrics["exact_2d"] = m_exact
    if settings.reference:
        say(f"path tracing {plan.label} (Mitsuba volpathmis, {settings.reference_spp} to {settings.reference_max_spp} "
            f"spp until the SSS mask's relative standard error is {settings.reference_rel_se:.1%}; cached)")
        assert plan.spec is not None
        media = list(plan.materials) if plan.per_id else (plan.materials or (plan.material,))[0]
        ref = render_reference(plan.spec, media, width=gb.shape[1], height=gb.shape[0],
                               spp=settings.reference_spp, max_spp=settings.reference_max_spp,
                               target_rel_se=settings.reference_rel_se, region=mask if mask.any() else None,
                               seed=settings.seed, frame=settings.frame, progress=progress)
        res.reference = ref.image
        res.reference_info = ref
        m: dict[str, Any] = region_metrics(res.reference, res.image, mask, settings.perceptual)
        m["mean_ratio_in_mask"] = ((res.image[mask].mean(axis=0) / np.maximum(res.reference[mask].mean(axis=0), 1e-12))
                                   .tolist() if mask.any() else None)
        m["pixels_with_surface"] = int(np.isfinite(gb.depth).sum())
        m["reference"] = ref.summary()
        res.metrics["path_traced"] = m
    if (settings.reference or res.exact is not None) and mask.any():
        if isinstance(profile, Mapping):  # one profile per id: the furthest-reaching sizes the regions
            profile = max(profile.values(), key=lambda p: float(np.max(p.radius_at_fraction(0.99))))
        res.metrics["regions"] = compare_regions(gb, profile, res.sss, res.exact, res.reference_info)


__all__ = ["BurleyInput", "ImageLayers", "SceneInput", "ScenePlan", "finite", "frame_gbuffer", "ground_truths",
           "material_label", "metric_lines", "per_id", "plan_scene", "reference_line"]
