"""What each difference in the region table is, measured: controlled experiments that switch ONE
cause off in the path-traced reference (or in the scene) and measure how much of a region's
difference between the screen-space model and the reference goes away, with standard errors.

The region table (:func:`ssskit.pipeline.regions.compare_regions`) gives per region (lit plateau,
shadow-edge band, terminator, silhouette) the level -- mean diffuse part / mean E / pi -- of the
screen-space pass, of the exact 2D convolution with the same profile (paper Eq. 1) and of the
path-traced reference. The screen-space model is a flat, semi-infinite medium lit from the front
whose light leaves like a Lambertian surface of albedo Rd, with the light that arrives on the seen
surface only. Three things the reference has and the model does not, each with its experiment:

* **transmission** (:func:`transmission_setups`): light that enters the medium through the surface
  the camera does not see (through a thin part, around the silhouette). Control: the same scene
  with a black backing just outside that surface (:func:`lab.variants.backed_scene`), so
  no light enters there; nothing the camera sees changes.
* **grazing Fresnel** (:func:`fresnel_setups`): the boundary's Fresnel transmission, which falls to
  0 at grazing angles (the silhouette, where the camera looks along the surface; the terminator,
  where the light does). Control: the index-matched boundary (Mitsuba ``null``), with the Monte
  Carlo profile at eta = 1 on the pass/exact side (the slab-edge figure's set-up). What changes in
  a region's ratio exact / reference relative to the plateau's is the grazing Fresnel (plus the
  dielectric's change of the exit's angular shape).
* **curvature** (:func:`curvature_setups`): the surface is not flat within the profile's reach.
  Control: the whole scene scaled by k (:func:`lab.variants.scaled_scene`; the same
  image, k times the mm per pixel): the surface's curvature relative to the profile's reach falls
  by k, and the ratio exact / reference trends to the flat surface's value.

Every setup of one experiment is measured on the same pixels (the baseline's regions), rendered in
``chunks`` independent chunks with the same per-chunk seeds in every setup
(:func:`ssskit.scenes.reference.chunk_seed`); each chunk gives every region's level, so a ratio of
two setups' levels (or a share of a gap) gets its standard error from the spread of its per-chunk
estimates (the batch method with the delta method: SE(a/b) = sd(a_i - r b_i) / sqrt(K) / mean(b)),
valid whatever the correlation between setups.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ssskit.backends import DEFAULT_BACKEND
from ssskit.errors import SettingsError
from ssskit.kernels import build_kernel, default_grid
from ssskit.materials import get_material
from ssskit.metrics import REGIONS, region_masks
from ssskit.profiles import profile_for_material
from ssskit.sampling.taps import make_taps
from ssskit.scenes import render_gbuffer
from ssskit.scenes.reference import ReferenceRenderer, reference_phase_g
from ssskit.scenes.scenes import SceneSpec, get_scene
from .variants import backed_scene, scaled_scene
from ssskit.screenspace import PassSettings, separable_sss
from ssskit.truth import exact_screen_space
from .surface import surface_convolution
from ssskit.pipeline.regions import pixel_mm

Progress = Callable[[str], None]

#: the experiments
EXPERIMENTS = ("transmission", "fresnel", "curvature")
#: the region table's regions and two more, which overlap them: ``grazing_view``, the SSS pixels
#: seen at a grazing angle (normal . view direction < :data:`GRAZING_COS`), where the boundary's
#: Fresnel transmission to the camera is low; ``object``, every SSS pixel (the reference for a
#: region's ratio when there is no plateau)
ATTRIBUTION_REGIONS = (*REGIONS, "grazing_view", "object")
GRAZING_COS = 0.5


@dataclass(frozen=True)
class Setup:
    """One side of an experiment: a scene (name or variant), a homogeneous material and the
    reference's boundary (``rough-dielectric`` or ``index-matched``)."""

    label: str
    scene: str | SceneSpec
    material: Any
    boundary: str = "rough-dielectric"


def transmission_setups(scene: str, material) -> list[Setup]:
    """[the scene as rendered, the scene with a black backing behind the surface the camera does not
    see] (module docstring)."""
    mat = get_material(material)
    return [Setup("as rendered", scene, mat), Setup("backed (no light enters the unseen surface)",
                                                    backed_scene(scene), mat)]


def fresnel_setups(scene: str, material) -> list[Setup]:
    """[the rough dielectric at the material's eta, the index-matched boundary with the material at
    eta = 1] (module docstring)."""
    mat = get_material(material)
    return [Setup(f"rough dielectric (eta {mat.eta:g})", scene, mat),
            Setup("index-matched (eta 1, null boundary)", scene, dataclasses.replace(mat, eta=1.0), "index-matched")]


def curvature_setups(scene: str, material, factors: Sequence[float] = (1.0, 2.0, 4.0)) -> list[Setup]:
    """The scene scaled by each of ``factors`` (the first is the baseline; module docstring)."""
    mat = get_material(material)
    if not factors:
        raise SettingsError("curvature needs at least one scale factor")
    return [Setup(f"x{k:g}", get_scene(scene) if k == 1 else scaled_scene(scene, k), mat) for k in factors]


SETUPS: dict[str, Callable[..., list[Setup]]] = {
    "transmission": transmission_setups, "fresnel": fresnel_setups, "curvature": curvature_setups}


def experiment_setups(experiment: str, scene: str, material, factors: Sequence[float] = (1.0, 2.0, 4.0)) -> list[Setup]:
    """The setups of ``experiment`` (one of :data:`EXPERIMENTS`) on ``scene``; ``factors``: the curvature
    experiment's scale factors (the others take none)."""
    if experiment not in SETUPS:
        raise SettingsError(f"experiment must be one of {', '.join(EXPERIMENTS)}, got {experiment!r}")
    if experiment == "curvature":
        return curvature_setups(scene, material, factors)
    return SETUPS[experiment](scene, material)


@dataclass
class Prepared:
    """A setup's screen-space side: its Monte Carlo profile, G-buffer, pass, exact 2D convolution and
    the convolution over the seen surface (:func:`lab.surface.surface_convolution`, albedo included)."""

    setup: Setup
    profile: Any
    gbuffer: Any
    sss: np.ndarray
    exact: np.ndarray | None
    surface: np.ndarray | None = None


def prepare(setup: Setup, width: int, height: int, photons: int, gbuffer_spp: int = 16,
            backend: str = DEFAULT_BACKEND, surface: bool = True, model: str = "montecarlo") -> Prepared:
    """The ``model`` profile of the setup's material (Monte Carlo: ``photons`` per channel, cached), its G-buffer
    (albedo = the profile's total Rd), the pass (pre-integrated kernel, 7 importance-sampled taps,
    10% jitter: the demo's), the exact 2D convolution (paper Eq. 1) and, with ``surface``, Eq. 1 over
    the seen surface (:func:`lab.surface.surface_convolution`)."""
    mat = setup.material
    reference_phase_g(mat)
    prof = profile_for_material(mat, model, **({"photons": photons} if model == "montecarlo" else {}))
    gb = render_gbuffer(setup.scene, np.clip(prof.total_rd(), 0.0, 1.0), eta=mat.eta, width=width, height=height,
                        spp=gbuffer_spp, material=mat.name)
    cell, n = default_grid(prof)
    taps = make_taps(build_kernel("preintegrated", prof, cell, n), 7, "importance")
    sss = separable_sss(gb, taps, PassSettings(jitter=0.1, backend=backend))
    return Prepared(setup, prof, gb, sss, exact_screen_space(gb, prof),
                    surface_convolution(gb, prof) if surface else None)


def regions_of(prep: Prepared, fraction: float = 0.99) -> dict[str, np.ndarray]:
    """The region masks of a prepared setup, as in the region table (reach: the profile's ``fraction``
    radius in pixels at the objects' median depth), and ``grazing_view`` (:data:`ATTRIBUTION_REGIONS`)."""
    gb = prep.gbuffer
    radius_px = float(np.max(prep.profile.radius_at_fraction(fraction))) / pixel_mm(gb)
    masks = region_masks(gb.diffuse, gb.mask, radius_px)
    masks["grazing_view"] = gb.mask & (gb.view_cosine() < GRAZING_COS)
    masks["object"] = gb.mask.copy()
    return masks


def _levels(part: np.ndarray, e: np.ndarray, masks: dict[str, np.ndarray]) -> np.ndarray:
    """(R, 3): mean(part) / mean(E / pi) over each region (NaN for an empty one)."""
    out = np.full((len(ATTRIBUTION_REGIONS), 3), np.nan)
    for j, name in enumerate(ATTRIBUTION_REGIONS):
        m = masks[name]
        if m.any():
            out[j] = part[m].mean(axis=0) / np.maximum(e[m].mean(axis=0), 1e-300)
    return out


def reference_levels(prep: Prepared, masks: dict[str, np.ndarray], chunks: int, chunk_spp: int = 8,
                     seed: int = 0, max_depth: int = 1024, progress: Progress | None = None) -> np.ndarray:
    """(chunks, R, 3): each chunk's level (mean reference diffuse part / mean E / pi) per region, the
    G-buffer's specular layer subtracted. Chunk i is rendered with :func:`chunk_seed`\\ (seed, i) in
    the bounding box of the regions only (every other pixel is unused)."""
    gb = prep.gbuffer
    h, w = gb.shape
    union = np.zeros((h, w), bool)
    for m in masks.values():
        union |= m
    ys, xs = np.nonzero(union)
    x0, y0 = int(xs.min()), int(ys.min())
    cw, ch = int(xs.max()) - x0 + 1, int(ys.max()) - y0 + 1
    win = (slice(y0, y0 + ch), slice(x0, x0 + cw))
    sub = {k: m[win] for k, m in masks.items()}
    e = gb.diffuse[win].astype(np.float64)
    spec = gb.specular[win].astype(np.float64)
    s = prep.setup
    renderer = ReferenceRenderer(s.scene, s.material, w, h, max_depth=max_depth, seed=seed, boundary=s.boundary,
                                 crop=(x0, y0, cw, ch))
    out = np.empty((chunks, len(ATTRIBUTION_REGIONS), 3))
    t0 = time.perf_counter()
    for i in range(chunks):
        out[i] = _levels(renderer.chunk(i, chunk_spp) - spec, e, sub)
        if progress is not None and (i + 1) % max(1, chunks // 4) == 0:
            progress(f"{s.label}: {(i + 1) * chunk_spp} spp, {time.perf_counter() - t0:.0f} s")
    return out


def ratio_se(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """mean(num) / mean(den) over axis 0 (K per-chunk estimates from the same chunks) and its standard
    error by the batch and delta methods: sd(num_i - r den_i) / sqrt(K) / |mean(den)|."""
    num, den = np.broadcast_arrays(np.asarray(num, float), np.asarray(den, float))
    k = num.shape[0]
    if k < 2:
        raise SettingsError("a standard error needs at least two chunks")
    r = num.mean(axis=0) / den.mean(axis=0)
    se = (num - r * den).std(axis=0, ddof=1) / math.sqrt(k) / np.abs(den.mean(axis=0))
    return r, se


def _pair(v, se) -> dict[str, list]:
    return {"value": np.asarray(v).tolist(), "se": np.asarray(se).tolist()}


def run_experiment(setups: Sequence[Setup], width: int = 160, height: int = 120, spp: int = 256,
                   chunk_spp: int = 8, photons: int = 200_000, seed: int = 0, gbuffer_spp: int = 16,
                   backend: str = DEFAULT_BACKEND, surface: bool = True, model: str = "montecarlo",
                   progress: Progress | None = None) -> dict[str, Any]:
    """Measure every setup on the first one's regions (module docstring; restricted to the pixels that
    every setup's G-buffer has on its SSS objects) with ``spp`` samples per pixel in chunks of
    ``chunk_spp`` (the same chunk seeds in every setup).

    Returns a JSON-ready dict: ``regions`` (names, pixels), per setup and region the levels of the
    pass, the exact 2D convolution, the surface convolution (``surface``) and the reference (± SE),
    ``exact_over_reference``, ``pass_over_reference`` and ``surface_over_reference`` (± SE), and
    ``exact_over_reference_vs_plateau`` / ``_vs_object`` (that ratio divided by the plateau's, when
    there is a plateau, / by the whole object's, ± SE from the paired chunks); per setup after the
    first, against the first: ``reference_ratio`` (its reference level / the first's) and ``gap_removed`` (the share of the first setup's gap reference - exact that is
    gone: 1 - gap / first gap), each ± SE. Each setup's levels are taken against its own E / pi.
    """
    if len(setups) < 1:
        raise SettingsError("an experiment needs at least one setup")
    if isinstance(spp, bool) or not (isinstance(spp, int) and isinstance(chunk_spp, int) and chunk_spp >= 1
                                     and spp >= 2 * chunk_spp):
        raise SettingsError(f"spp must be an integer of at least two chunks of {chunk_spp!r} spp, got {spp!r}")
    say = progress or (lambda msg: None)
    chunks = spp // chunk_spp
    preps = []
    for s in setups:
        say(f"{s.label}: profile, G-buffer, pass, exact 2D" + (", surface convolution" if surface else ""))
        preps.append(prepare(s, width, height, photons, gbuffer_spp, backend, surface, model))
    common = np.logical_and.reduce([p.gbuffer.mask for p in preps])
    masks = {name: m & common for name, m in regions_of(preps[0]).items()}
    names = ATTRIBUTION_REGIONS
    pixels = {name: int(masks[name].sum()) for name in names}
    present = [j for j, name in enumerate(names) if pixels[name]]
    plateau, whole = names.index("plateau"), names.index("object")
    per_setup, levels, exacts = [], [], []
    for prep in preps:
        t0 = time.perf_counter()
        lv = reference_levels(prep, masks, chunks, chunk_spp, seed, progress=say)
        seconds = time.perf_counter() - t0
        gb = prep.gbuffer
        e = gb.diffuse.astype(np.float64)
        pas = _levels(gb.albedo * prep.sss, e, masks)
        exa = _levels(gb.albedo * prep.exact, e, masks) if prep.exact is not None else np.full_like(pas, np.nan)
        sur = _levels(prep.surface.astype(np.float64), e, masks) if prep.surface is not None else None
        ref, ref_se = ratio_se(lv, np.ones_like(lv))
        row: dict[str, Any] = {"label": prep.setup.label, "scene": get_scene(prep.setup.scene).name,
                               "eta": float(prep.setup.material.eta), "boundary": prep.setup.boundary,
                               "pixel_mm": pixel_mm(gb), "spp": chunks * chunk_spp, "seconds": round(seconds, 1),
                               "profile_total_rd": np.asarray(prep.profile.total_rd()).tolist(), "regions": {}}
        for j in present:
            cell: dict[str, Any] = {"screen_space": pas[j].tolist(), "exact_2d": exa[j].tolist(),
                                    "path_traced": _pair(ref[j], ref_se[j])}
            models = {"exact": exa, "pass": pas} | ({"surface": sur} if sur is not None else {})
            for key, model in models.items():
                cell[f"{key}_over_reference"] = _pair(*ratio_se(np.broadcast_to(model[j], lv[:, j].shape), lv[:, j]))
            if sur is not None:
                cell["surface"] = sur[j].tolist()
            for other, key in ((plateau, "plateau"), (whole, "object")):
                if pixels[key] and j != other:
                    # (x_j / a_j) / (x_o / a_o) = (x_j / x_o) * (a_o / a_j): a paired ratio of two regions' chunks
                    r, se = ratio_se(lv[:, other], lv[:, j])
                    scale = exa[j] / exa[other]
                    cell[f"exact_over_reference_vs_{key}"] = _pair(r * scale, se * np.abs(scale))
            row["regions"][names[j]] = cell
        if levels:
            row["vs_first"] = {}
            for j in present:
                rr, rr_se = ratio_se(lv[:, j], levels[0][:, j])
                gap_ratio, gap_se = ratio_se(lv[:, j] - exa[j], levels[0][:, j] - exacts[0][j])
                row["vs_first"][names[j]] = {"reference_ratio": _pair(rr, rr_se),
                                             "gap_removed": _pair(1.0 - gap_ratio, gap_se)}
        levels.append(lv)
        exacts.append(exa)
        per_setup.append(row)
    return {"regions": pixels, "width": width, "height": height, "chunk_spp": chunk_spp, "photons": photons,
            "seed": seed, "setups": per_setup}


__all__ = ["ATTRIBUTION_REGIONS", "EXPERIMENTS", "GRAZING_COS", "SETUPS", "Prepared", "Setup", "curvature_setups",
           "experiment_setups", "fresnel_setups", "prepare", "ratio_se", "reference_levels", "regions_of", "run_experiment", "transmission_setups"]
