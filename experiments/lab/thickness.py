"""The thin object's back losses, measured: what a medium of finite thickness does not return, in the
path-traced reference against MCML, and on the ear (issue 11).

The screen-space model (and the exact 2D convolution, paper Eq. 1) uses the semi-infinite medium's
profile: light entering the seen surface comes back out of it with total Rd(inf). A slab of thickness
t returns Rd(t) < Rd(inf): the rest diffuses through to its back and leaves there (MCML's Tt). The
ear is a flattened ellipsoid 0-4 mm thick against red's diffusion length of 3.7 mm (Skin1), so after
the transmission control (no light entering its unseen surface,
:func:`lab.variants.backed_scene`) the model is still too bright in red. Three measurements:

* :func:`slab_setups` / :func:`slab_check` (the reference does what MCML says): the slab cut to a
  thickness t (:func:`lab.variants.thin_scene`) against the 20 mm slab, the plateau's
  reference level with paired chunk seeds (:func:`lab.attribution.run_experiment`),
  against MCML's Rd(t) F_t(mu) / (Rd(20) F_20(mu)) at the plateau's incidence (F: the radiance factor
  at the camera, :meth:`MCResult.radiance_factor_at`), both with standard errors.
* :func:`thickness_setups` (the scene-level control on the ear): the backed ear against the same ear
  with its unseen half ``factor`` times deeper (:func:`lab.variants.deepened_scene`, backed
  too): the seen surface and the G-buffer stay the same, the back losses go. ``gap_removed`` of
  :func:`run_experiment` is the share of the backed ear's difference reference - exact that they were.
* :func:`predict_thin` (the model's prediction, no path tracing): per pixel the chord through the
  medium along the inward normal (:func:`ssskit.scenes.thickness.chord_thickness`), MCML's
  Rd(t) / Rd(inf) per channel at that thickness and at the pixel's incidence angle of the light
  (:func:`ssskit.profiles.montecarlo.slab.thickness_table` at a few angles, interpolated in both),
  averaged over a region the way its level is: predicted exact / reference = sum(w) / sum(w f(t))
  with w = E / pi (the loss decided where the light enters: entry-weighted) or w = the exact 2D
  result (decided where it leaves: exit-weighted; the two differ only where the light changes within
  a diffusion length, on the ear by < 10^-3). It neglects lateral transport in a shell whose
  thickness changes within a diffusion length, the curvature of the shell, the rim (thickness -> 0
  within a pixel), shadows in the incidence angle and the exit angle (the camera's).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ssskit.errors import SettingsError
from ssskit.materials import get_material
from ssskit.profiles.montecarlo.slab import interpolate_ratio, slab_config, thickness_table
from ssskit.profiles.montecarlo import simulate
from ssskit.scenes.scenes import get_scene
from ssskit.scenes.thickness import chord_thickness, incidence_angle
from .variants import backed_scene, box_thickness_mm, deepened_scene, thin_scene
from .attribution import ATTRIBUTION_REGIONS, Prepared, Setup, prepare, regions_of, run_experiment
from .oblique import pixel_angles, point_light

Progress = Callable[[str], None]

#: the ear's control: its unseen half this many times deeper (2 mm -> 6, 20, 60 mm; MCML's Rd(t) of Skin1
#: is Rd(inf) within its 0.5% error from t = 10 mm on, in every channel)
DEEPEN_FACTORS = (3.0, 10.0, 30.0)
#: the slab check's thicknesses (mm): the ear's thickness range
SLAB_THICKNESSES = (4.0, 2.0)
#: the incidence angles (degrees) of the ear prediction's MCML tables (the first: normal incidence)
TABLE_ANGLES = (0.0, 30.0, 45.0, 60.0, 75.0)


def thickness_setups(scene: str, material, factors: Sequence[float] = DEEPEN_FACTORS) -> list[Setup]:
    """[the scene backed (no light enters its unseen surface), the same with its unseen half k times deeper,
    backed too, for each k of ``factors``] (module docstring)."""
    mat = get_material(material)
    if not factors or any(not (isinstance(k, (int, float)) and math.isfinite(k) and k > 1) for k in factors):
        raise SettingsError(f"the depth factors must be numbers > 1, got {list(factors)!r}")
    return [Setup("backed", backed_scene(scene), mat)] + [
        Setup(f"backed, unseen half x{k:g} deeper", backed_scene(deepened_scene(scene, k)), mat) for k in factors]


def slab_setups(material, thicknesses: Sequence[float] = SLAB_THICKNESSES, boundary: str = "index-matched",
                scene: str = "slab") -> list[Setup]:
    """[the slab as it is (20 mm), the slab cut to each of ``thicknesses``] with the ``boundary``
    (index-matched: the material at eta = 1 and Mitsuba ``null``, the cheap set-up MCML at eta = 1 matches
    within 1% at 128 spp; or the rough dielectric)."""
    mat = get_material(material)
    if boundary == "index-matched":
        mat = dataclasses.replace(mat, eta=1.0)
    elif boundary != "rough-dielectric":
        raise SettingsError(f"boundary must be index-matched or rough-dielectric, got {boundary!r}")
    if not thicknesses:
        raise SettingsError("the slab check needs at least one thickness")
    return [Setup(get_scene(scene).name, scene, mat, boundary)] + [
        Setup(f"{t:g} mm", thin_scene(scene, t), mat, boundary) for t in thicknesses]


def _ratio_at(tables: Sequence[dict[str, Any]], thickness: np.ndarray,
              incidence: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) Rd(t) / Rd(inf) and its SE per pixel: from the one table, or linear in the incidence angle
    between the tables (ascending ``incidence_deg``; clamped at the ends) at each pixel's angle."""
    if incidence is None or len(tables) == 1:
        return interpolate_ratio(tables[0], thickness)
    angles = np.array([tb["incidence_deg"] for tb in tables], float)
    if np.any(np.diff(angles) <= 0):
        raise SettingsError(f"the tables' incidence angles must ascend, got {angles.tolist()}")
    per = [interpolate_ratio(tb, thickness) for tb in tables]
    a = np.clip(np.asarray(incidence, float), angles[0], angles[-1])
    i = np.clip(np.searchsorted(angles, a, side="right") - 1, 0, len(angles) - 2)
    u = ((a - angles[i]) / (angles[i + 1] - angles[i]))[:, None]
    f = np.stack([p[0] for p in per])  # (A, N, 3)
    se = np.stack([p[1] for p in per])
    k = np.arange(a.shape[0])
    return (1 - u) * f[i, k] + u * f[i + 1, k], (1 - u) * se[i, k] + u * se[i + 1, k]


def predict_thin(prep: Prepared, masks: dict[str, np.ndarray], thickness: np.ndarray,
                 table: dict[str, Any] | Sequence[dict[str, Any]],
                 incidence: np.ndarray | None = None) -> dict[str, Any]:
    """Predicted exact / reference per region of a thin object (module docstring) from the per-pixel
    ``thickness`` (H, W) mm and a :func:`thickness_table` -- or several at ascending incidence angles,
    interpolated at each pixel's ``incidence`` (H, W) degrees (:func:`ssskit.scenes.thickness.incidence_angle`);
    pixels where either is NaN are left out. Per region: ``entry_weighted`` and ``exit_weighted``
    (value, se: the table's errors taken fully correlated across pixels, an upper bound), the region's
    E / pi-weighted mean thickness and the pixels used."""
    tables = [table] if isinstance(table, dict) else list(table)
    gb = prep.gbuffer
    e = gb.diffuse.astype(np.float64)
    x = (gb.albedo * prep.exact).astype(np.float64)
    ok = np.isfinite(thickness)
    if incidence is not None:
        ok &= np.isfinite(incidence)
    f = np.full(e.shape, np.nan)
    f_se = np.full(e.shape, np.nan)
    f[ok], f_se[ok] = _ratio_at(tables, thickness[ok], None if incidence is None else np.asarray(incidence)[ok])
    out: dict[str, Any] = {}
    for name in ATTRIBUTION_REGIONS:
        m = masks[name] & ok
        if not m.any():
            continue
        ew = e[m].mean(axis=1)
        cell: dict[str, Any] = {"pixels": int(m.sum()), "pixels_left_out": int((masks[name] & ~ok).sum()),
                                "mean_thickness_mm": float(np.sum(ew * thickness[m]) / np.sum(ew))}
        if incidence is not None:
            cell["mean_incidence_deg"] = float(np.sum(ew * np.asarray(incidence)[m]) / np.sum(ew))
        for key, w in (("entry_weighted", e[m]), ("exit_weighted", x[m])):
            sw, swf = w.sum(axis=0), (w * f[m]).sum(axis=0)
            r = sw / swf
            cell[key] = {"value": r.tolist(), "se": (r * (w * f_se[m]).sum(axis=0) / swf).tolist()}
        out[name] = cell
    return out


def thickness_experiment(scene: str, material, factors: Sequence[float] = DEEPEN_FACTORS, width: int = 160,
                         height: int = 120, spp: int = 1024, chunk_spp: int = 8, photons: int = 200_000,
                         table_photons: int = 200_000, angles: Sequence[float] = TABLE_ANGLES, seed: int = 0,
                         progress: Progress | None = None) -> dict[str, Any]:
    """The ear's thickness experiment: :func:`run_experiment` on :func:`thickness_setups` (the scene-level
    control) and :func:`predict_thin` on its first setup's regions (the model's prediction), with the chord
    map and MCML tables (:func:`thickness_table`, ``table_photons`` per simulation) at each of ``angles``:
    ``prediction.normal_incidence`` (the 0 degree table) and ``prediction.at_incidence`` (each pixel at
    its light's incidence angle, :func:`ssskit.scenes.thickness.incidence_angle`)."""
    say = progress or (lambda msg: None)
    setups = thickness_setups(scene, material, factors)
    res = run_experiment(setups, width=width, height=height, spp=spp, chunk_spp=chunk_spp, photons=photons, seed=seed,
                         surface=True, progress=say)
    say("prediction: MCML thickness tables, chords, incidence angles")
    prep = prepare(setups[0], width, height, photons, surface=False)
    masks = regions_of(prep)
    thick = chord_thickness(setups[0].scene, width, height, mask=prep.gbuffer.mask)
    inc = incidence_angle(setups[0].scene, width, height, mask=prep.gbuffer.mask)
    tables = [thickness_table(setups[0].material, photons=table_photons, incidence_deg=float(a)) for a in angles]
    res["prediction"] = {"method": "chord along the inward normal; MCML Rd(t) / Rd(inf) of a slab",
                         "tables": tables,
                         "normal_incidence": predict_thin(prep, masks, thick, tables[0]),
                         "at_incidence": predict_thin(prep, masks, thick, tables, inc)}
    return res


def slab_check(material, thicknesses: Sequence[float] = SLAB_THICKNESSES, boundary: str = "index-matched",
               spp: int = 128, chunk_spp: int = 8, photons: int = 200_000, mcml_photons: int = 1_000_000,
               width: int = 160, height: int = 120, seed: int = 0, scene: str = "slab",
               progress: Progress | None = None) -> dict[str, Any]:
    """The slab's plateau: the reference level of the slab cut to each thickness over the 20 mm slab's
    (paired chunks, ± SE) against MCML's Rd(t) F_t(mu) / (Rd(T) F_T(mu)) (T: the slab's own thickness;
    the plateau's mean incidence angle and view cosine; ± SE from the batch errors), per channel.
    MCML runs at the setups' eta (1 for the index-matched boundary) with a smooth boundary."""
    say = progress or (lambda msg: None)
    setups = slab_setups(material, thicknesses, boundary, scene)
    res = run_experiment(setups, width=width, height=height, spp=spp, chunk_spp=chunk_spp, photons=photons, seed=seed,
                         surface=False, progress=say)
    spec = get_scene(scene)
    prep = prepare(setups[0], width, height, photons, surface=False)
    plateau = regions_of(prep)["plateau"]
    if not plateau.any():
        raise SettingsError(f"scene {spec.name!r} has no lit plateau")
    cos_i, mu_v = pixel_angles(prep.gbuffer, point_light(spec))
    inc = float(np.degrees(np.mean(np.arccos(cos_i[plateau]))))
    mu = float(np.mean(mu_v[plateau]))
    full = box_thickness_mm(spec.shapes()[spec.sss_shapes[0]])
    mat = setups[0].material

    def factor(t: float, c: int) -> tuple[float, float]:
        r = simulate(slab_config(mat, c, t, mcml_photons, seed=11 + int(round(100 * t)), incidence_deg=inc))
        f, f_se = r.radiance_factor_at(mu, bins=8)
        return r.total_rd * f, r.total_rd * f * math.hypot(f_se / f, r.total_rd_se / r.total_rd)

    say(f"MCML at {inc:.1f} degrees, mu = {mu:.4f}")
    base = [factor(full, c) for c in range(3)]
    rows = []
    for s, t in zip(res["setups"][1:], thicknesses):
        ref = s["vs_first"]["plateau"]["reference_ratio"]
        mc = [factor(float(t), c) for c in range(3)]
        pred = [a / b for (a, _), (b, _) in zip(mc, base)]
        pred_se = [r * math.hypot(ae / a, be / b) for r, (a, ae), (b, be) in zip(pred, mc, base)]
        diff_se = [math.hypot(a, b) for a, b in zip(ref["se"], pred_se)]
        rows.append({"thickness_mm": float(t), "reference_ratio": ref, "mcml_ratio": {"value": pred, "se": pred_se},
                     "reference_over_mcml": [a / b for a, b in zip(ref["value"], pred)],
                     "difference_in_se": [(a - b) / d for a, b, d in zip(ref["value"], pred, diff_se)]})
    return {"boundary": boundary, "eta": float(mat.eta), "incidence_deg": inc, "view_cosine": mu,
            "full_thickness_mm": full, "plateau_pixels": res["regions"]["plateau"], "mcml_photons": mcml_photons,
            "rows": rows, "experiment": res}


__all__ = ["DEEPEN_FACTORS", "SLAB_THICKNESSES", "TABLE_ANGLES", "predict_thin", "slab_check", "slab_setups",
           "thickness_experiment", "thickness_setups"]
