"""Both papers' head figures on the scan they used (the built-in scene ``head``: :mod:`ssskit.scenes.head`,
docs/head.md), at Xie 2020 Fig. 1's three views (``front``, ``ear``, ``close``).

* :func:`head_references`: the path-traced truth per view and material (Mitsuba volpathmis, the rough
  dielectric boundary; :func:`ssskit.scenes.render_reference`), converged on the largest region
  (:func:`driving_region`), each region's level with its standard error;
* :func:`fig7_numbers`: Xie 2020 Fig. 7 on the head, Eq. 21's approximate inverse CDF against the exact
  Burley sampling, both converged (:func:`ssskit.pipeline.burley_frame.burley_reference` with each
  sampler), as the RMS of the relative pixel difference beside Xie's 1.87 %;
* :func:`fig9_numbers`: Xie 2020 Fig. 9 on the head, the adaptive Burley pass (sigma0^2 = 1e-3, kappa = 0.2,
  8-64 spp) against the path trace per region, without and with the transmittance pass;
* :func:`scale_sensitivity`: how the region levels move when the head is 10 % smaller or larger.

``ssskit figures head-refs head-fig7 head-fig9 --scene head`` (or ``docs/head_numbers.py``) writes them.
Head scan: Lee Perry-Smith, Infinite-Realities (CC BY 3.0).
"""

from __future__ import annotations

import dataclasses
import time
import tomllib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..settings import HEAD_ATTRIBUTION
from .plots import pyplot, save_figure

if TYPE_CHECKING:
    from ..profiles.base import RGBProfile
    from .views import StudyScene

Progress = Callable[[str], None]

#: Xie 2020's head views (Fig. 1: close skin patch, ear, front)
VIEWS = ("front", "ear", "close")
#: Xie 2020 Fig. 7: RMS error of Eq. 21 against MIS (exact) sampling on the head, PBRT, 2k spp
XIE_FIG7_RMS = 0.0187
#: Xie 2020 Fig. 9's settings of the adaptive pass
XIE_ADAPTIVE: dict[str, Any] = {"sigma0_sq": 1e-3, "kappa": 0.2, "b_min": 8, "b_max": 64}


def head_spec(view: str = "front", mm_per_unit: float | None = None) -> Any:
    """The built-in head's :class:`~ssskit.scenes.SceneSpec` at ``view``; ``mm_per_unit``: another scale
    (the scene file's document with the generator's ``mm_per_unit`` replaced; cameras and lights stay)."""
    from ..scenes import resolve_scene
    from ..scenes.scenefile import BUILTIN_DIR, scene_from_document, with_view

    if mm_per_unit is None:
        spec = resolve_scene("head", view=view).spec
        assert spec is not None
        return spec
    path = BUILTIN_DIR / "head.toml"
    doc = tomllib.loads(path.read_text(encoding="utf-8"))
    doc["shapes"]["head"]["params"] = {"mm_per_unit": float(mm_per_unit)}
    spec = scene_from_document(doc, base=path.parent, source=str(path)).spec
    return with_view(dataclasses.replace(spec, name=f"head-{mm_per_unit:g}mm"), view)


def head_view(view: str = "front", material: str = "skin1", width: int = 96, height: int = 72, spp: int = 16,
              seed: int = 0, mm_per_unit: float | None = None) -> StudyScene:
    """The G-buffer of the head at ``view`` with the material's Burley parameters and separable taps
    (:func:`ssskit.figures.views.study_gbuffer`)."""
    from .views import study_gbuffer

    return study_gbuffer(view, material, width, height, spp=spp, seed=seed, scene=head_spec(view, mm_per_unit),
                         light_layers=True)


def _masks(sc: StudyScene) -> tuple[dict[str, np.ndarray], float]:
    from ..metrics import region_masks
    from ..pipeline.regions import pixel_mm

    gb = sc.gbuffer
    radius_px = float(np.max(sc.profile.radius_at_fraction(0.99))) / pixel_mm(gb)
    return region_masks(gb.diffuse.astype(np.float64), gb.mask, radius_px), radius_px


def driving_region(sc: StudyScene) -> tuple[str, np.ndarray]:
    """(name, mask) of the region the reference converges on: the largest (on the head the shadow-edge band,
    two thirds or more of the SSS pixels). The smaller regions' standard errors are stated, not driven: on 2
    cores a terminator band of 5 % of the pixels would take about 15,000 spp per view for 2 % (measured:
    11 % at 512 spp, front view, 96 x 72)."""
    masks, _ = _masks(sc)
    name = max((int(m.sum()), n) for n, m in masks.items())[1]
    return name, masks[name]


def reference_levels(sc: StudyScene, ref: Any) -> dict[str, dict[str, Any]]:
    """Each region's level of the path trace (diffuse part: the reference less the G-buffer's specular
    layer, over E / pi; :func:`ssskit.metrics.region_level`) with its standard error and relative SE; ``all``:
    every SSS pixel."""
    from ..metrics import region_level

    masks, _ = _masks(sc)
    gb = sc.gbuffer
    assert gb.specular is not None
    part = np.asarray(ref.image, np.float64) - gb.specular.astype(np.float64)
    out = {}
    for name, m in {**masks, "all": gb.mask}.items():
        row = region_level(part, gb.diffuse.astype(np.float64), m, np.asarray(ref.pixel_se, np.float64))
        if row["pixels"]:
            row["rel_se"] = (np.asarray(row["se"]) / np.abs(np.asarray(row["level"]))).tolist()
        out[name] = row
    return out


def head_reference(view: str, material: str = "skin1", width: int = 96, height: int = 72, rel_se: float = 0.02,
                   max_spp: int = 4096, mm_per_unit: float | None = None,
                   cache_only: bool = False) -> tuple[StudyScene, Any, dict[str, Any]]:
    """(the view's :class:`StudyScene`, its path-traced :class:`~ssskit.scenes.Reference`, a JSON-ready row):
    rendered until the driving region's (:func:`driving_region`) relative SE is at most ``rel_se`` in
    every channel or ``max_spp`` is spent; cached (``cache_only``: the cached one or a SceneError)."""
    from ..materials import get_material
    from ..scenes import render_reference

    sc = head_view(view, material, width, height, mm_per_unit=mm_per_unit)
    name, region = driving_region(sc)
    t0 = time.perf_counter()
    ref = render_reference(sc.spec, _homogeneous(get_material(material)), width, height, spp=256, max_spp=max_spp,
                           target_rel_se=rel_se, region=region, chunk_spp=16, progress=False, cache_only=cache_only)
    row = {"view": view, "material": material, "size": [width, height], "spp": ref.spp, "converged": ref.converged,
           "driving_region": name, "seconds": time.perf_counter() - t0, "regions": reference_levels(sc, ref),
           "attribution": HEAD_ATTRIBUTION}
    return sc, ref, row


#: the settings of the head's references (docs/head_references.py's defaults, docs/head_references.json)
REFERENCE_SIZE, REFERENCE_REL_SE, REFERENCE_MAX_SPP = (96, 72), 0.02, 4096


def cached_reference_layers(view: str, material: str) -> dict[str, Any]:
    """What the live viewer shows beside its frame at a head view (``ssskit view --scene head``): the cached
    path trace of ``view`` with ``material`` at the settings of docs/head_references.json (:func:`head_reference`
    with ``cache_only``: a SceneError naming the command that renders it where none is cached), with the layers
    its region levels need: ``image`` and ``pixel_se`` (H, W, 3), the G-buffer's ``specular`` and ``e_over_pi``
    (H, W, 3), the SSS ``mask`` and the comparison regions ``masks`` (:func:`ssskit.metrics.region_masks`), and
    ``spp``, ``converged``, ``driving_region``."""
    from ..errors import SceneError

    w, h = REFERENCE_SIZE
    try:
        sc, ref, row = head_reference(view, material, w, h, REFERENCE_REL_SE, REFERENCE_MAX_SPP, cache_only=True)
    except SceneError:
        raise SceneError(f"no path-traced reference of the head's {view} view with {material} is cached here: "
                         f"python docs/head_references.py --views {view} --materials {material} renders it "
                         f"(minutes)") from None
    masks, _ = _masks(sc)
    gb = sc.gbuffer
    assert gb.specular is not None
    return {"image": np.asarray(ref.image, np.float64), "pixel_se": np.asarray(ref.pixel_se, np.float64),
            "specular": gb.specular.astype(np.float64), "e_over_pi": gb.diffuse.astype(np.float64),
            "mask": np.asarray(gb.mask, bool), "masks": masks, "spp": int(ref.spp), "converged": bool(ref.converged),
            "driving_region": row["driving_region"]}


def head_references(views: Sequence[str] = VIEWS, materials: Sequence[str] = ("skin1",), width: int = 96,
                    height: int = 72, rel_se: float = 0.02, max_spp: int = 4096,
                    progress: Progress | None = None) -> list[dict[str, Any]]:
    """:func:`head_reference`'s rows for every view and material (``seconds``: this call's, near 0 when cached)."""
    rows = []
    for mat in materials:
        for v in views:
            if progress:
                progress(f"path tracing the head, {v} view, {mat}")
            rows.append(head_reference(v, mat, width, height, rel_se, max_spp)[2])
    return rows


def _homogeneous(material: Any) -> Any:
    """The head is one homogeneous medium (docs/head.md): a layered material is refused in one line."""
    from ..materials import homogeneous

    return homogeneous(material, "the head's path-traced references")


def _constant_layer(layer: np.ndarray) -> Callable[[Any], np.ndarray]:
    """A transmission callback that gives every frame the same light layer (a still camera)."""
    return lambda gbuffer: layer


def _level(row: dict[str, object]) -> list[float]:
    """The level (R, G, B) of a :func:`ssskit.metrics.region_level` row."""
    level = row["level"]
    assert isinstance(level, (list, tuple, np.ndarray))
    return [float(v) for v in level]


def _composite(sc: StudyScene, sss: np.ndarray) -> np.ndarray:
    gb = sc.gbuffer
    return (gb.albedo * sss).astype(np.float64)


def fig7_numbers(views: Sequence[str] = VIEWS, material: str = "skin1", width: int = 192, height: int = 144,
                 spp: int = 4096, backend: str = "numba", progress: Progress | None = None) -> dict[str, Any]:
    """Xie 2020 Fig. 7 on the head: the Burley pass with Eq. 21's sampler against the exact inverse CDF, both
    at ``spp`` samples per pixel without mips and with the same random numbers (seed 0), per view: ``rms`` the
    relative RMSE of the composited diffuse SSS over the SSS pixels (sqrt(sum (x - e)^2 / sum e^2)),
    ``rms_pixel`` the RMS of the per-pixel relative difference, ``mean_bias`` the relative difference of the
    means, and ``noise_floor`` the ``rms`` between two exact runs of different seeds (what the numbers'
    Monte Carlo noise can reach), beside Xie's 1.87 % (PBRT, MIS against Eq. 21, 2k spp)."""
    from ..screenspace import burley_sss

    say = progress or (lambda m: None)
    rows, images = [], {}
    for v in views:
        say(f"Xie Fig. 7 on the head: {v} view")
        sc = head_view(v, material, width, height)
        m = sc.gbuffer.mask
        runs = {name: _composite(sc, burley_sss(sc.gbuffer, sc.params, spp=spp, seed=seed, sampler=sampler,
                                                mips=False, backend=backend))
                for name, sampler, seed in (("exact", "exact", 0), ("eq21", "xie", 0), ("exact2", "exact", 1))}
        e, x, e2 = (runs[k][m] for k in ("exact", "eq21", "exact2"))

        def rel_rmse(a: np.ndarray, b: np.ndarray) -> float:
            return float(np.sqrt(np.sum((a - b) ** 2) / np.sum(b**2)))

        rel = (x - e) / np.maximum(e, 1e-12)
        rows.append({"view": v, "rms": rel_rmse(x, e), "rms_pixel": float(np.sqrt(np.mean(rel**2))),
                     "mean_bias": float(x.mean() / e.mean() - 1.0), "noise_floor": rel_rmse(e2, e),
                     "pixels": int(m.sum())})
        images[v] = (runs["exact"], runs["eq21"], m)
    return {"figure": "Xie 2020 Fig. 7 on the head", "material": material, "size": [width, height], "spp": spp,
            "xie_rms": XIE_FIG7_RMS, "rows": rows, "attribution": HEAD_ATTRIBUTION, "images": images}


def fig9_numbers(view: str = "front", material: str = "skin1", width: int = 96, height: int = 72, frames: int = 16,
                 rel_se: float = 0.02, max_spp: int = 4096, backend: str = "numba",
                 progress: Progress | None = None) -> dict[str, Any]:
    """Xie 2020 Fig. 9 on the head: the adaptive Burley pass (:data:`XIE_ADAPTIVE`, Eq. 21, mips, ``frames``
    frames of a still camera with TAA; the last frame measured) without and with the transmittance pass
    (:func:`ssskit.pipeline.transmission.transmission_light`, the material's MCML model, the first light:
    the one behind the ear) against the path trace per region (:func:`ssskit.pipeline.regions.compare_regions`:
    each region's level of the pass, of the pass's converged limit (``exact_2d``: exact sampler, 4096 spp,
    no mips) and of the path trace with its standard error), the last frame's counts and the difference
    images."""
    from ..materials import get_material
    from ..pipeline.burley_frame import burley_reference
    from ..pipeline.regions import compare_regions
    from ..pipeline.settings import RenderSettings
    from ..pipeline.transmission import transmission_light
    from ..screenspace import AdaptiveSettings, BurleySettings, run_frames
    from ..screenspace.taa import TAASettings

    say = progress or (lambda m: None)
    sc, ref, ref_row = head_reference(view, material, width, height, rel_se, max_spp)
    gb = sc.gbuffer
    limit = burley_reference(gb, sc.params, spp=4096, backend=backend)
    mat = get_material(material)
    settings = RenderSettings(transmission="on", backend=backend)
    added = transmission_light(gb, settings, {1: mat}, say)[0].astype(np.float32)
    out: dict[str, Any] = {"figure": "Xie 2020 Fig. 9 on the head", "view": view, "material": material,
                           "size": [width, height], "frames": frames, "adaptive": XIE_ADAPTIVE,
                           "reference": {k: ref_row[k] for k in ("spp", "converged", "driving_region", "seconds")},
                           "attribution": HEAD_ATTRIBUTION, "runs": {}, "images": {}}
    for name, trans in (("without", None), ("with", added)):
        say(f"Xie Fig. 9 on the head: adaptive pass {name} transmission")
        lim = limit if trans is None else limit + trans
        run = run_frames([gb] * frames, sc.params, BurleySettings(sampler="xie", mips=True, backend=backend),
                         adaptive=AdaptiveSettings(**XIE_ADAPTIVE), taa=TAASettings(), keep_counts=True,
                         references=[lim] * frames,
                         transmission=None if trans is None else _constant_layer(trans))
        sss = run.last_sss
        assert sss is not None and run.counts is not None
        cmp = compare_regions(gb, sc.profile, sss, lim, ref)
        out["runs"][name] = {"regions": cmp["regions"], "mean_spp": run.mean_spp[-1], "psnr_gray": run.psnr_gray[-1],
                             "psnr_gray_taa": run.psnr_gray_taa[-1]}
        diff = _composite(sc, sss) - (np.asarray(ref.image, np.float64) - gb.specular.astype(np.float64))
        out["images"][name] = {"image": _composite(sc, sss), "difference": np.where(gb.mask[..., None], diff, 0.0),
                               "counts": run.counts[-1]}
    out["images"]["reference"] = np.asarray(ref.image, np.float64) - gb.specular.astype(np.float64)
    out["images"]["reference_se"] = np.asarray(ref.pixel_se, np.float64)
    out["images"]["mask"] = gb.mask
    return out


def scale_sensitivity(factors: Sequence[float] = (0.9, 1.0, 1.1), views: Sequence[str] = VIEWS,
                      material: str = "skin1", width: int = 96, height: int = 72, spp: int = 4096,
                      backend: str = "numba") -> dict[str, Any]:
    """How the Burley pass's converged region levels (exact sampler, ``spp``, no mips) and its separable
    counterpart (the burley_fit kernel, 7 taps) move when the head is scaled by ``factors`` of
    :data:`ssskit.scenes.head.MM_PER_UNIT` (the cameras and lights stay: the head grows in the same frame):
    per view and factor, each region's level (green channel)."""
    from ..metrics import region_level
    from ..pipeline.burley_frame import burley_reference
    from ..scenes.head import MM_PER_UNIT
    from ..screenspace import PassSettings, separable_sss

    rows = []
    for v in views:
        for f in factors:
            sc = head_view(v, material, width, height, mm_per_unit=MM_PER_UNIT * f)
            masks, _ = _masks(head_view(v, material, width, height))  # the regions of scale 1: the same pixels
            gb = sc.gbuffer
            e = gb.diffuse.astype(np.float64)
            burley = burley_reference(gb, sc.params, spp=spp, backend=backend)
            sep = separable_sss(gb, sc.taps, PassSettings(backend=backend))
            row: dict[str, Any] = {"view": v, "factor": f, "mm_per_unit": MM_PER_UNIT * f, "regions": {}}
            for name, mk in masks.items():
                mk = mk & gb.mask
                if mk.sum() == 0:
                    continue
                row["regions"][name] = {
                    "pixels": int(mk.sum()),
                    "burley": _level(region_level(_composite(sc, burley), e, mk))[1],
                    "separable": _level(region_level(_composite(sc, sep), e, mk))[1]}
            rows.append(row)
    return {"factors": list(factors), "material": material, "size": [width, height], "rows": rows}


#: the supplement's Fig. S.2 kernels (every separable model of the paper, d'Eon's six Gaussians, and the engines')
S2_KERNELS = ("preintegrated", "svd:1", "svd_l1:1", "svd:2", "guided", "artist:fit", "gaussians:6", "preintegrated_svd:1",
              "burley_fit", "jimenez2012:7")
#: the supplement's Fig. S.8 distances (close-up, medium and long shot) as the head's views, with their camera
#: distances (mm) to the point they look at
S8_DISTANCES = {"close": "close", "medium": "ear", "far": "front"}


def separable_numbers(views: Sequence[str] = VIEWS, material: str = "skin1", width: int = 96, height: int = 72,
                      kernels: Sequence[str] = S2_KERNELS, taps: int = 7, backend: str = "numba",
                      path_traced: bool = True, repeats: int = 3, progress: Progress | None = None) -> dict[str, Any]:
    """The separable-SSS paper on the head: per view, every kernel of ``kernels`` (the supplement's Fig. S.2
    comparison) run by the separable pass with ``taps`` importance-sampled taps on the head's G-buffer (its
    albedo the material's Monte Carlo total reflectance) against the exact 2D convolution of the same
    Monte Carlo profile (:func:`ssskit.truth.exact_screen_space`: relative RMSE over the SSS pixels) and, with
    ``path_traced``, against the path trace per region (:func:`ssskit.pipeline.regions.compare_regions`), and
    the pass's median time (ms, ``repeats`` runs); the views double as Fig. S.8's close, medium and far shots
    (:data:`S8_DISTANCES`). ``images``: per view the preintegrated pass, the exact convolution and the path
    trace (Fig. 1-style skin)."""
    from ..kernels import build_kernel, default_grid, parse_method_spec
    from ..materials import get_material
    from ..pipeline.regions import compare_regions
    from ..profiles import profile_for_material
    from ..sampling.taps import make_taps
    from ..screenspace import PassSettings, separable_sss
    from ..truth import exact_screen_space

    say = progress or (lambda m: None)
    mat = get_material(material)
    prof = profile_for_material(mat, "montecarlo")
    cell, n = default_grid(prof)
    rows: list[dict[str, Any]] = []
    images: dict[str, Any] = {}
    built = {}
    for spec in kernels:  # once: the kernels depend on the profile only
        method, params, label = parse_method_spec(spec)
        say(f"kernel {label}")
        built[label] = make_taps(build_kernel(method.name, prof, cell, n, **params), taps)
    for v in views:
        say(f"the separable paper on the head: {v} view")
        if path_traced:
            sc, ref, _ = head_reference(v, material, width, height)
        else:
            sc, ref = head_view(v, material, width, height), None
        gb = dataclasses.replace(sc.gbuffer, albedo=np.where(sc.gbuffer.mask[..., None],
                                                             np.clip(prof.total_rd(), 0, 1), 0.0).astype(np.float32))
        m = gb.mask
        exact = exact_screen_space(gb, prof)
        assert exact is not None
        cam = gb.camera
        dist = float(np.linalg.norm(np.asarray(sc.spec.target) - np.asarray(sc.spec.origin)))
        for label, tp in built.items():
            settings = PassSettings(backend=backend)
            sss = separable_sss(gb, {1: tp}, settings)
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                separable_sss(gb, {1: tp}, settings)
                times.append((time.perf_counter() - t0) * 1e3)
            a, e = (gb.albedo * sss)[m].astype(np.float64), (gb.albedo * exact)[m].astype(np.float64)
            row: dict[str, Any] = {"view": v, "kernel": label, "taps": tp.taps, "rank": tp.rank,
                                   "rel_rmse_exact": float(np.sqrt(np.sum((a - e) ** 2) / np.sum(e**2))),
                                   "ms": float(np.median(times)), "camera_mm": dist,
                                   "pixel_mm": float(np.median(gb.depth_mm[m]) / cam.fx)}
            if ref is not None:
                cmp = compare_regions(gb, prof, sss, exact, ref)
                row["regions"] = {k: {"pixels": r["pixels"], "screen_space": r["screen_space"]["level"],
                                      "exact_2d": r["exact_2d"]["level"], "path_traced": r["path_traced"]["level"],
                                      "path_traced_se": r["path_traced"]["se"],
                                      "ratio": r.get("screen_space_vs_path_traced")}
                                  for k, r in cmp["regions"].items() if r["pixels"]}
            rows.append(row)
            if label == "preintegrated":
                images[v] = {"pass": gb.albedo * sss, "exact": gb.albedo * exact,
                             "path_traced": None if ref is None else np.asarray(ref.image) - gb.specular,
                             "path_traced_se": None if ref is None else np.asarray(ref.pixel_se, np.float64),
                             "spp": None if ref is None else ref.spp, "mask": gb.mask}
    return {"figure": "the separable-SSS paper on the head (Fig. 1, S.2, S.8)", "material": material,
            "size": [width, height], "taps": taps, "s8": S8_DISTANCES, "rows": rows, "attribution": HEAD_ATTRIBUTION,
            "images": images}


def plot_separable(res: dict[str, Any], path: Path) -> Path:
    """Fig. 1-style skin per view: the preintegrated separable pass, the exact 2D convolution, the path trace."""
    plt = pyplot()
    views = list(res["images"])
    fig, axes = plt.subplots(len(views), 3, figsize=(8.4, 2.2 * len(views) + 0.5), squeeze=False)
    for i, v in enumerate(views):
        im = res["images"][v]
        scale = float(np.percentile(im["exact"][im["exact"] > 0], 99.5))
        _show(axes[i][0], im["pass"], f"{v}: separable, preintegrated, {res['taps']} taps", scale)
        _show(axes[i][1], im["exact"], "exact 2D convolution", scale)
        if im["path_traced"] is not None:
            _show_path_traced(axes[i][2], im["path_traced"], im["path_traced_se"], im["mask"], im["spp"], scale)
        else:
            axes[i][2].axis("off")
    fig.suptitle(f"The separable-SSS paper on the head ({res['material']}). {HEAD_ATTRIBUTION}", fontsize=9)
    save_figure(fig, path)
    return path


def head_separable(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None,
                   backend: str = "numba") -> list[Path]:
    """``ssskit figures head-separable``: :func:`separable_numbers` at 96 x 72 (``head_separable.png``, ``.json``)."""
    return _written(out, "head_separable", separable_numbers(backend=backend, progress=progress), plot_separable)


def _json_ready(d: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in d.items() if k != "images"}


def _written(out: Path, name: str, res: dict[str, Any], plot: Callable[[dict[str, Any], Path], Path]) -> list[Path]:
    """``name``.png drawn by ``plot`` and ``name``.json (``res`` without its images) in ``out``."""
    import json

    from ..io import write_text

    png = plot(res, Path(out) / f"{name}.png")
    js = Path(out) / f"{name}.json"
    write_text(js, json.dumps(_json_ready(res), indent=1))
    return [png, js]


def _show(ax: Any, img: np.ndarray, title: str, scale: float) -> None:
    ax.imshow(np.clip(np.asarray(img, np.float64) / scale, 0.0, 1.0) ** (1 / 2.2))
    ax.set_title(title, fontsize=8)
    ax.axis("off")


def _show_path_traced(ax: Any, img: np.ndarray, pixel_se: np.ndarray, mask: np.ndarray, spp: int, scale: float) -> None:
    """A path trace (diffuse part) as shown: its display copy (:func:`ssskit.figures.display.display_copy`:
    box means of b x b pixels where its own per-pixel noise is above 10 %; only for showing, every number is
    measured on the unfiltered image), titled with the samples per shown pixel (spp x b^2) and its remaining
    relative noise. Its per-pixel noise is the dielectric boundary's (docs/head.md, "Why the path traces speckle")."""
    from .display import display_copy

    shown, block, rel = display_copy(img, pixel_se, mask)
    box = f"{block}x{block} box means, " if block > 1 else ""
    _show(ax, shown, f"path traced: {spp * block ** 2} spp per shown pixel\n({box}noise {rel:.0%})", scale)


def plot_fig7(res: dict[str, Any], path: Path) -> Path:
    """Per view: the exact sampling, Eq. 21 and their difference x 10 (Xie Fig. 7's layout)."""
    plt = pyplot()
    views = list(res["images"])
    fig, axes = plt.subplots(len(views), 3, figsize=(8.4, 2.2 * len(views) + 0.5), squeeze=False)
    for i, v in enumerate(views):
        e, x, m = res["images"][v]
        row = next(r for r in res["rows"] if r["view"] == v)
        scale = float(np.percentile(e[m], 99.5))
        _show(axes[i][0], e, f"{v}: exact inverse CDF", scale)
        _show(axes[i][1], x, f"Eq. 21 (RMS {100 * row['rms']:.2f} %)", scale)
        _show(axes[i][2], np.abs(x - e) * 10, "|difference| x 10", scale)
    fig.suptitle(f"Xie Fig. 7 on the head ({res['spp']} spp; Xie: RMS 1.87 %). {HEAD_ATTRIBUTION}", fontsize=9)
    save_figure(fig, path)
    return path


def plot_fig9(res: dict[str, Any], path: Path) -> Path:
    """The path trace, the adaptive pass without and with transmission, their difference images (red: the pass
    above the path trace, blue: below) and the sample counts (Xie Fig. 9's columns)."""
    plt = pyplot()
    im = res["images"]
    ref = im["reference"]
    scale = float(np.percentile(ref[ref > 0], 99.5)) if (ref > 0).any() else 1.0
    fig, axes = plt.subplots(2, 4, figsize=(11, 4.8), squeeze=False)
    for i, name in enumerate(("without", "with")):
        _show_path_traced(axes[i][0], ref, im["reference_se"], im["mask"], res["reference"]["spp"], scale)
        _show(axes[i][1], im[name]["image"], f"adaptive, {name} transmission", scale)
        d = im[name]["difference"].mean(axis=-1) / scale
        axes[i][2].imshow(d, cmap="coolwarm", vmin=-0.25, vmax=0.25)
        axes[i][2].set_title("difference (pass - path traced)", fontsize=8)
        axes[i][2].axis("off")
        axes[i][3].imshow(im[name]["counts"], cmap="gray", vmin=0, vmax=64)
        axes[i][3].set_title("samples per pixel (white = 64)", fontsize=8)
        axes[i][3].axis("off")
    fig.suptitle(f"Xie Fig. 9 on the head, {res['view']} view. {HEAD_ATTRIBUTION}", fontsize=9)
    save_figure(fig, path)
    return path


def head_fig7(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None,
              backend: str = "numba") -> list[Path]:
    """``ssskit figures head-fig7``: :func:`fig7_numbers` at 192 x 144, 4096 spp (``head_fig7.png``, ``.json``)."""
    return _written(out, "head_fig7", fig7_numbers(backend=backend, progress=progress), plot_fig7)


def head_fig9(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None,
              backend: str = "numba") -> list[Path]:
    """``ssskit figures head-fig9``: :func:`fig9_numbers` for the front and ear views at 96 x 72 (the path
    traces cached; minutes each the first time), ``head_fig9_VIEW.png`` and ``head_fig9.json``."""
    import json

    from ..io import write_text

    paths, rows = [], []
    for v in ("front", "ear"):
        res = fig9_numbers(v, backend=backend, progress=progress)
        paths.append(plot_fig9(res, Path(out) / f"head_fig9_{v}.png"))
        rows.append(_json_ready(res))
    js = Path(out) / "head_fig9.json"
    write_text(js, json.dumps(rows, indent=1))
    return [*paths, js]


__all__ = ["VIEWS", "XIE_ADAPTIVE", "XIE_FIG7_RMS", "driving_region", "fig7_numbers", "fig9_numbers", "head_fig7", "head_fig9", "head_separable", "S2_KERNELS", "S8_DISTANCES", "separable_numbers", "plot_separable",
           "REFERENCE_MAX_SPP", "REFERENCE_REL_SE", "REFERENCE_SIZE", "cached_reference_layers", "head_reference", "head_references", "head_spec", "head_view", "plot_fig7", "plot_fig9", "reference_levels", "scale_sensitivity"]
