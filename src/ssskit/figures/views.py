"""Xie et al. 2020 Fig. 1 and Sec. 6.4, in kind: the three-view study on the generated head-like bust
(:func:`ssskit.scenes.generated.bust`) at the close, ear and front views.

Four methods per view, on one G-buffer of the bust (material ``skin1`` by default, its Burley profile:
A the dipole's total reflectance, d from Eq. 5's searchlight configuration):

* ``adaptive``: the Burley pass with Xie's variance-guided counts (sigma0^2 = 1e-3, kappa = 0.2,
  8-64 spp: Fig. 1(a)), Eq. 21's sampler with the prefiltered irradiance (Eqs. 22-23), ``frames``
  frames of a still camera through :func:`ssskit.screenspace.run_frames`; the last frame is measured,
  its counts are the heatmap (the fixed-count runs go through the same loop);
* ``eq21-64``: the same pass at a fixed 64 spp (Fig. 1(c)'s count; Eq. 21's sampler);
* ``golubev-64``: Golubev 2018's sampler in the same pass at 64 spp (Fig. 1(b), Sec. 6.4: exact inverse
  CDF, stratified radii, golden-angle rotation, the count capped by the footprint);
* ``separable``: the separable pass with the ``burley_fit`` kernel (Fig. 1(d); Xie 2020 appendix A.1).

Each is compared with the pass's converged limit (:func:`ssskit.pipeline.burley_frame.burley_reference`:
the exact sampler at ``reference_spp`` spp without mips, Xie's "reference image at 2k samples per
pixel"), as gray-scale PSNR of the composited image inside the SSS mask on the display's scale
(:func:`ssskit.metrics.display_psnr`; Xie 2020 Sec. 6 reports gray PSNR) of the last frame, and for
the Burley methods also after the frame loop's TAA (:class:`~ssskit.screenspace.taa.TAASettings`
defaults; Xie's images went through UE4's TAA), and optionally with the path-traced reference of the same bust per region
(:func:`ssskit.pipeline.regions.compare_regions`: lit plateau, shadow edge, terminator, silhouette).
Xie's Sec. 6.4 numbers, PSNR(Golubev) - PSNR(Eq. 21) = 2.09 / 0.29 / 0.26 dB in the close, ear and
front views (:data:`XIE_GOLUBEV_MINUS_EQ21`), stand beside ours. Every method's time per frame is
measured per backend (the median over frames; wall time of the pass, and of the guiding phase for
the adaptive run).

``ssskit figures xie-fig1`` draws it; ``benchmarks/xie_three_views.py`` prints the table as JSON.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .plots import pyplot, save_figure

if TYPE_CHECKING:
    from ..profiles.base import RGBProfile
    from ..screenspace import GBuffer

#: the views of Xie 2020 Fig. 1 (close skin patch, ear, front) as --view values of the bust: (azimuth,
#: elevation, distance as a multiple of the framing distance, which fits the whole bust, shoulders and all):
#: a cheek-and-nose patch, the side of the head with its ear, the face
STUDY_VIEWS: dict[str, tuple[float, float, float]] = {"close": (25.0, 5.0, 0.22), "ear": (90.0, 5.0, 0.5),
                                                      "front": (0.0, 5.0, 0.6)}
#: the study's methods, in Fig. 1's order
STUDY_METHODS = ("adaptive", "golubev-64", "eq21-64", "separable")
#: Xie 2020 Sec. 6.4: PSNR(Golubev 64 spp) - PSNR(Eq. 21), dB, per view
XIE_GOLUBEV_MINUS_EQ21 = {"close": 2.09, "ear": 0.29, "front": 0.26}
FIXED_SPP = 64

Progress = Callable[[str], None]


@dataclass(frozen=True)
class StudyScene:
    """One view of the study's scene: its ``spec`` and G-buffer, the ``materials`` of its profile ids
    (1, 2, ...), their Burley ``params`` and the separable pass's ``taps`` (the burley_fit kernel of each
    material's Burley profile), and ``profile``: the profile that reaches furthest (it sizes the regions)."""

    spec: Any
    gbuffer: Any
    materials: tuple[Any, ...]
    params: dict[int, Any]
    taps: dict[int, Any]
    profile: Any


def study_gbuffer(view: str | tuple[float, float, float], material: str = "skin1", width: int = 256,
                  height: int = 192, spp: int = 16, seed: int = 0, scene: Any = "bust", units: str | None = None,
                  material_map: str | dict[str, str] | None = None, light_layers: bool = False) -> StudyScene:
    """The study's :class:`StudyScene` at ``view`` (a name of :data:`STUDY_VIEWS` or any --view value):
    ``scene`` a mesh scene (:func:`ssskit.scenes.resolve_scene`: the bust by default, or a mesh or
    scene file with its ``units`` and ``material_map``); objects the scene gives no material take
    ``material``; ``light_layers``: the G-buffer also carries the transmittance pass's light layers."""
    from ..kernels import build_kernel, default_grid
    from ..materials import get_material
    from ..profiles import burley_profile
    from ..sampling.taps import make_taps
    from ..scenes import render_gbuffer, resolve_scene
    from ..screenspace import BurleyParams

    from ..scenes import SCENES, SceneSpec

    spec: SceneSpec | None
    if isinstance(scene, SceneSpec):  # a scene already seen from its view (ssskit.figures.head)
        spec = scene
    else:
        named = isinstance(scene, str) and scene in SCENES and SCENES.get(scene).views  # the head's own views
        v = view if named else STUDY_VIEWS.get(view, view) if isinstance(view, str) else view
        spec = resolve_scene(scene, view=v, units=units, material_map=material_map, width=width, height=height).spec
    assert spec is not None  # a mesh scene always has one
    mats: tuple[Any, ...] = tuple(get_material(m) for m in spec.shape_materials(material))
    params, taps, profiles = {}, {}, []
    for pid, mat in enumerate(mats, start=1):
        prof = burley_profile(mat)
        cell, n = default_grid(prof)
        params[pid] = BurleyParams.from_profile(prof)
        taps[pid] = make_taps(build_kernel("burley_fit", prof, cell, n), 7)
        profiles.append(prof)
    albedo = np.clip([params[pid].albedo for pid in params], 0.0, 1.0)
    gb = render_gbuffer(spec, albedo, eta=[m.eta for m in mats], width=width, height=height, spp=spp, seed=seed,
                        material=tuple(m.name for m in mats), light_layers=light_layers)
    reach = [float(np.max(p.radius_at_fraction(0.99))) for p in profiles]
    return StudyScene(spec, gb, mats, params, taps, profiles[int(np.argmax(reach))])


def golubev_counts(gbuffer: GBuffer, params: Any, spp: int = FIXED_SPP) -> np.ndarray:
    """(H, W) int64: the samples Golubev's sampler takes per pixel, step 2 of the Burley plan
    (:mod:`ssskit.backends.burley_plan`) as the numpy oracle computes it
    (:func:`ssskit.backends.numpy_backend.burley_counts`: max(1, min(spp, floor(pi r997^2 sx sy / 4))),
    sx = fx / z, sy = fy / z); 0 outside the mask."""
    from ..backends.numpy_backend import burley_counts
    from ..backends.plan import profile_ids
    from ..screenspace import BurleySettings
    from ..screenspace.burley import burley_plan_for

    cam = gbuffer.camera
    plan = burley_plan_for(params, profile_ids(gbuffer.profile_id), cam.fx, cam.fy,
                           BurleySettings(sampler="golubev", spp=spp))
    slots = plan.slot_map(gbuffer.profile_id)
    ys, xs = np.nonzero(slots > 0)
    z = gbuffer.depth_mm[ys, xs].astype(np.float64)
    out = np.zeros(gbuffer.shape, dtype=np.int64)
    out[ys, xs] = burley_counts(plan, spp, ys, xs, plan.fx / z, plan.fy / z, slots[ys, xs])
    return out


def _timed(fn: Callable[[], Any], repeats: int) -> tuple[Any, float]:
    """(the last result, the median wall time in ms of ``repeats`` calls after one warm-up call)."""
    out = fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append((time.perf_counter() - t0) * 1e3)
    return out, float(np.median(times))


def _methods(sc: StudyScene, backend: str, frames: int, repeats: int, limit_sss: np.ndarray | None = None,
             taa: bool = True) -> dict[str, dict[str, Any]]:
    """Each method's blurred diffuse layer, counts and ms per frame on ``backend``; with ``limit_sss`` (the
    converged limit's blurred diffuse layer) the Burley methods' last-frame gray PSNR before and after TAA
    (:func:`ssskit.metrics.display_psnr`, through the frame loop)."""
    from ..screenspace import AdaptiveSettings, BurleySettings, PassSettings, run_frames, separable_sss
    from ..screenspace.taa import TAASettings

    gb, params = sc.gbuffer, sc.params
    out: dict[str, dict[str, Any]] = {}
    burley = BurleySettings(sampler="xie", mips=True, backend=backend)
    still = [gb] * frames  # the same G-buffer object: a still camera
    refs = None if limit_sss is None else [limit_sss] * frames
    skip = min(2, frames - 1)  # the first frames compile and warm the caches
    runs: dict[str, dict[str, Any]] = {"adaptive": dict(burley=burley, adaptive=AdaptiveSettings(sigma0_sq=1e-3, kappa=0.2, b_min=8, b_max=64)),
            "eq21-64": dict(burley=burley, spp=FIXED_SPP),
            "golubev-64": dict(burley=burley.replace(sampler="golubev"), spp=FIXED_SPP)}
    for name, kw in runs.items():
        run = run_frames(still, params, references=refs, taa=TAASettings() if taa else None, keep_counts=True, **kw)
        counts = run.counts[-1].astype(np.int64) if run.counts is not None else np.zeros(gb.shape, np.int64)
        if name == "golubev-64":  # the footprint caps the count (the plan's step 2)
            counts = golubev_counts(gb, params)
        out[name] = {"sss": run.last_sss, "counts": counts, "ms": float(np.median(run.ms_frame[skip:])),
                     "psnr_gray": run.psnr_gray[-1], "psnr_gray_taa": run.psnr_gray_taa[-1]}
    sep, t = _timed(lambda: separable_sss(gb, sc.taps, PassSettings(backend=backend)), repeats)
    # a separable pixel reads 2 x taps texels per term (horizontal and vertical passes)
    reads = np.zeros(len(sc.taps) + 1, np.int64)
    for pid, tp in sc.taps.items():
        reads[pid] = 2 * tp.taps * tp.rank
    out["separable"] = {"sss": sep, "counts": reads[gb.profile_id], "ms": t, "psnr_gray": None, "psnr_gray_taa": None}
    return out


def three_view_study(material: str = "skin1", views: Sequence[str] = tuple(STUDY_VIEWS), width: int = 256,
                     height: int = 192, frames: int = 16, scene: str = "bust", units: str | None = None,
                     material_map: str | dict[str, str] | None = None, backends: Sequence[str] = ("numba",),
                     reference_spp: int = 4096, gbuffer_spp: int = 16, repeats: int = 3,
                     path_traced: bool = False, path_traced_size: tuple[int, int] | None = None,
                     path_traced_spp: tuple[int, int] = (64, 4096), path_traced_rel_se: float = 0.02,
                     progress: Progress | None = None) -> dict[str, Any]:
    """The study (module docstring). Returns a JSON-ready dict: ``rows`` (one per view, method and
    backend: psnr_gray against the converged limit, mean_spp over the SSS mask, ms per frame),
    ``golubev_minus_eq21`` per view (dB, first backend) beside ``xie``, ``limit`` (the converged
    limit's own noise: ``psnr_gray`` of a second limit with another seed), ``regions`` (with
    ``path_traced``: per view and method, each region's level against the path-traced reference's
    with its standard error) and ``images`` (not JSON: per view, each method's composite, counts, the
    limit), which :func:`xie_fig1` draws.

    ``scene``, ``units``, ``material_map``: the mesh scene (:func:`study_gbuffer`; the bust by default).
    ``path_traced_size``: the reference's image size (default: the study's); the G-buffer is then
    rendered again at that size for the region comparison.
    """
    from ..metrics import display_psnr
    from ..pipeline.burley_frame import burley_reference

    say = progress or (lambda msg: None)
    if not backends:
        raise ValueError("three_view_study needs at least one backend")
    opts: dict[str, Any] = {"scene": scene, "units": units, "material_map": material_map}
    rows: list[dict[str, Any]] = []
    diff: dict[str, float] = {}
    diff_taa: dict[str, float] = {}
    limits: dict[str, dict[str, Any]] = {}
    regions: dict[str, dict[str, Any]] = {}
    images: dict[str, dict[str, Any]] = {}
    names: tuple[str, ...] = ()
    for view in views:
        say(f"xie-fig1: {view} view, G-buffer ({width}x{height})")
        sc = study_gbuffer(view, material, width, height, gbuffer_spp, **opts)
        gb, mask = sc.gbuffer, sc.gbuffer.mask
        names = tuple(m.name for m in sc.materials)
        say(f"xie-fig1: {view} view, converged limit ({reference_spp} spp, seeds 0 and 1; cached)")
        limit_sss = burley_reference(gb, sc.params, spp=reference_spp, backend=backends[0])
        limit = gb.composite(limit_sss)
        limit2 = gb.composite(burley_reference(gb, sc.params, spp=reference_spp, seed=1, backend=backends[0]))
        limits[view] = {"psnr_gray_second_seed": display_psnr(limit, limit2, mask), "spp": int(reference_spp),
                        "sss_pixels": int(mask.sum())}
        images[view] = {"limit": limit, "mask": mask}
        for b in backends:
            say(f"xie-fig1: {view} view, four methods on {b} ({frames} frames each)")
            res = _methods(sc, b, frames, repeats, limit_sss)
            for name in STUDY_METHODS:
                r = res[name]
                img = gb.composite(r["sss"])
                rows.append({"view": view, "method": name, "backend": b,
                             "psnr_gray": display_psnr(limit, img, mask), "psnr_gray_taa": r["psnr_gray_taa"],
                             "mean_spp": float(r["counts"][mask].mean()) if mask.any() else 0.0, "ms": r["ms"]})
                if b == backends[0]:
                    images[view][name] = {"image": img, "counts": r["counts"], "sss": r["sss"]}
        first = {r["method"]: r for r in rows if r["view"] == view and r["backend"] == backends[0]}
        diff[view] = first["golubev-64"]["psnr_gray"] - first["eq21-64"]["psnr_gray"]
        diff_taa[view] = first["golubev-64"]["psnr_gray_taa"] - first["eq21-64"]["psnr_gray_taa"]
        if path_traced:
            pw, ph = path_traced_size or (width, height)
            psc = sc if (pw, ph) == (width, height) else study_gbuffer(view, material, pw, ph, gbuffer_spp, **opts)
            regions[view] = _path_traced_regions(psc, backends[0], frames, path_traced_spp, path_traced_rel_se, say)
    return {"scene": str(scene), "material": names[0] if len(names) == 1 else list(names),
            "size": [int(width), int(height)], "frames": int(frames), "backends": list(backends),
            "reference_spp": int(reference_spp), "rows": rows, "golubev_minus_eq21": diff,
            "golubev_minus_eq21_taa": diff_taa,
            "xie": dict(XIE_GOLUBEV_MINUS_EQ21), "limit": limits, "regions": regions, "images": images}


def _path_traced_regions(sc: StudyScene, backend: str, frames: int, spp: tuple[int, int], rel_se: float,
                         say: Progress) -> dict[str, Any]:
    """Each method's level per region (:func:`ssskit.pipeline.regions.compare_regions`) over the path-traced
    reference's of the same view and size: {reference: its summary, regions: {name: {pixels, path_traced:
    level and standard error (R, G, B), methods: {method: ratio and its standard error}}}}."""
    from ..pipeline.regions import compare_regions
    from ..scenes import render_reference

    gb = sc.gbuffer
    h, w = gb.shape
    say(f"xie-fig1: path-traced reference ({w}x{h}, {spp[0]}-{spp[1]} spp until {rel_se:.0%}; cached)")
    mats = list(sc.materials) if len(sc.materials) > 1 else sc.materials[0]
    ref = render_reference(sc.spec, mats, width=w, height=h, spp=spp[0], max_spp=spp[1], target_rel_se=rel_se,
                           region=gb.mask, progress=True)
    res = _methods(sc, backend, frames, repeats=1, taa=False)
    regions: dict[str, Any] = {}
    for name in STUDY_METHODS:
        for region, row in compare_regions(gb, sc.profile, res[name]["sss"], None, ref)["regions"].items():
            entry = regions.setdefault(region, {"pixels": row["pixels"], "methods": {}})
            if "screen_space_vs_path_traced" in row:
                entry["path_traced"] = {"level": row["path_traced"]["level"], "se": row["path_traced"]["se"]}
                entry["methods"][name] = row["screen_space_vs_path_traced"]
    return {"reference": ref.summary(), "regions": regions}


def _heat(ax: Any, counts: np.ndarray, mask: np.ndarray, vmax: float, title: str) -> Any:
    im = ax.imshow(np.where(mask, counts, np.nan), cmap="magma", vmin=0, vmax=vmax)
    ax.set_title(title, fontsize=7)
    ax.axis("off")
    return im


def plot_study(study: dict[str, Any], path: Path) -> Path:
    """Fig. 1's layout: per view a row of the four methods (tone-mapped at the converged limit's 99.5th
    percentile, titled with gray PSNR against it and ms per frame on the first backend), the converged
    limit, and the adaptive sample-count heatmap (8-64)."""
    from ..io import tonemap

    plt = pyplot()
    views = list(study["images"])
    ncol = len(STUDY_METHODS) + 2
    fig, axes = plt.subplots(len(views), ncol, figsize=(2.9 * ncol, 2.2 * len(views) + 0.6), squeeze=False)
    first = study["backends"][0]
    for r, view in enumerate(views):
        im = study["images"][view]
        peak = float(np.percentile(im["limit"], 99.5)) or 1.0
        for c, name in enumerate(STUDY_METHODS):
            row = next(x for x in study["rows"] if x["view"] == view and x["method"] == name and x["backend"] == first)
            ax = axes[r, c]
            ax.imshow(tonemap(im[name]["image"], peak))
            taa = "" if row["psnr_gray_taa"] is None else f" (TAA {row['psnr_gray_taa']:.1f})"
            ax.set_title(f"{view}: {name}\n{row['psnr_gray']:.1f} dB{taa}, {row['ms']:.0f} ms ({first})", fontsize=7)
            ax.axis("off")
        axes[r, ncol - 2].imshow(tonemap(im["limit"], peak))
        axes[r, ncol - 2].set_title(f"converged limit ({study['reference_spp']} spp)", fontsize=7)
        axes[r, ncol - 2].axis("off")
        heat = _heat(axes[r, ncol - 1], im["adaptive"]["counts"], im["mask"], 64,
                     f"adaptive spp (mean {im['adaptive']['counts'][im['mask']].mean():.1f})")
    fig.colorbar(heat, ax=list(axes[:, -1]), fraction=0.05, pad=0.02).ax.tick_params(labelsize=6)
    d = study["golubev_minus_eq21"]
    fig.suptitle(f"Xie 2020 Fig. 1 in kind: {study['scene']}, {study['material']}, {study['size'][0]}x"
                 f"{study['size'][1]}; Golubev - Eq. 21: " + ", ".join(
                     f"{v} {d[v]:+.2f} dB (Xie {study['xie'].get(v, float('nan')):.2f})" for v in views), fontsize=8)
    save_figure(fig, path)
    return path


def study_json(study: dict[str, Any]) -> dict[str, Any]:
    """The study without its images (JSON-ready)."""
    return {k: v for k, v in study.items() if k != "images"}


def xie_fig1(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None, backend: str = "numba",
             scene: str = "bust", units: str | None = None, material_map: str | dict[str, str] | None = None,
             material: str = "skin1") -> list[Path]:
    """``ssskit figures xie-fig1``: the three-view study at 256 x 192 on ``backend`` of ``scene`` (the
    bust by default; ``--scene``, ``--units``, ``--material-map`` of ``ssskit figures``) in ``material``
    (the figure's ``profile`` is not used: the study takes each material's Burley profile);
    ``xie_fig1.png`` and ``xie_fig1.json``."""
    import json

    from ..io import write_text

    study = three_view_study(material=material, backends=(backend,), scene=scene, units=units,
                             material_map=material_map, progress=progress)
    png = plot_study(study, Path(out) / "xie_fig1.png")
    js = Path(out) / "xie_fig1.json"
    write_text(js, json.dumps(study_json(study), indent=1))
    return [png, js]


#: the demo's small study of the user's model: size, adaptive frames, converged limit's spp
DEMO_SIZE = (128, 96)
DEMO_FRAMES = 8
DEMO_REFERENCE_SPP = 1024


def demo_section(out: Path, progress: Progress | None, ctx: dict[str, Any]) -> str:
    """The demo report's "Your model" section (``ssskit.report.SECTIONS`` signature), built when ``ssskit
    demo --scene`` names one (``ctx["scene"]``: scene, units, material_map): the three-view study of it at
    :data:`DEMO_SIZE` on ``ctx["backend"]``, its table and figure."""
    import html

    opts = ctx["scene"]
    backend = ctx.get("backend") or "numba"
    t0 = time.perf_counter()
    study = three_view_study(backends=(backend,), width=DEMO_SIZE[0], height=DEMO_SIZE[1], frames=DEMO_FRAMES,
                             reference_spp=DEMO_REFERENCE_SPP, repeats=1, scene=opts["scene"], units=opts.get("units"),
                             material_map=opts.get("material_map"), progress=progress)
    png = plot_study(study, Path(out) / "figures" / "your_model.png")
    seconds = time.perf_counter() - t0
    body = "".join(f"<tr><td class=name>{html.escape(r['view'])}</td><td class=name>{html.escape(r['method'])}</td>"
                   f"<td>{r['psnr_gray']:.1f}</td><td>{r['mean_spp']:.1f}</td><td>{r['ms']:.1f}</td></tr>"
                   for r in study["rows"])
    return (f"<h2>Your model: {html.escape(str(opts['scene']))}</h2>"
            f"<p class=note>The three views of Xie 2020 Fig. 1 (close, ear = profile, front) at {DEMO_SIZE[0]}x"
            f"{DEMO_SIZE[1]}: the adaptive Burley pass (sigma0^2 = 1e-3, kappa = 0.2, 8-64 spp, {DEMO_FRAMES} frames), "
            "Golubev's and Eq. 21's samplers at 64 spp and the separable burley_fit pass, each as gray PSNR against "
            f"the pass's converged limit ({DEMO_REFERENCE_SPP} spp), with ms per frame on the {html.escape(backend)} "
            f"backend. Materials: {html.escape(str(study['material']))}. Built in {seconds:.0f} s.</p>"
            "<table><tr><th>view</th><th>method</th><th>PSNR gray</th><th>mean spp</th><th>ms</th></tr>"
            f"{body}</table><img src='figures/{png.name}'>")


__all__ = ["DEMO_FRAMES", "DEMO_REFERENCE_SPP", "DEMO_SIZE", "FIXED_SPP", "STUDY_METHODS", "STUDY_VIEWS", "StudyScene", "XIE_GOLUBEV_MINUS_EQ21", "demo_section", "golubev_counts", "plot_study",
           "study_gbuffer", "study_json", "three_view_study", "xie_fig1"]
