"""What the light's incidence angle, the view angle and the boundary do to a region's level, measured:
the flat-medium prediction from MCML for a scene's own geometry, and the controlled path-traced
experiment on a flat medium lit and seen at the same angles.

The screen-space model gives a lit pixel Rd(0) E / pi (the normal-incidence profile's total
reflectance, a Lambertian exit). In the flat limit (the scene scaled up until its surface is flat
within the profile's reach, :func:`lab.variants.scaled_scene`) what is left between the
model and the reference is how a flat medium lit at theta_i and seen at theta_v differs from that:

* **oblique incidence**: Rd(theta_i) / Rd(0), MCML with the beam at theta_i (the Fresnel
  transmittance of a smooth boundary at theta_i and the shallower refracted beam);
* **non-Lambertian exit**: MCML's radiance factor f(theta_i, mu_v)
  (:mod:`lab.oblique_table`);
* **the boundary**: the reference's rough dielectric (Mitsuba ``roughdielectric``, single-scattering
  Beckmann microfacets) is not MCML's smooth Fresnel boundary; what it changes is measured by
  :func:`flat_experiment` (a flat slab, :func:`lab.flat.flat_scene`, at the scene's angles:
  the reference over the MCML prediction, with the index-matched boundary as the control that must
  give 1), or by MCML with the references' rough surface (``oblique_table(..., roughness=)``);
* **re-entry** (:func:`surface_reentry`): on a relief, light that leaves the surface (the boundary's
  reflection, the diffuse light) meets it again and enters; the G-buffer's E / pi is direct light only.

:func:`flat_prediction` forms the first two per pixel -- cos theta_i from the G-buffer's positions and
normals and the scene's point light, mu_v from :meth:`GBuffer.view_cosine` -- and averages them the
way a region's level is formed (level = mean diffuse part / mean E / pi, so each pixel weighs with its
E / pi):

    level_flat = sum_p (E/pi)_p Rd(theta_i,p) f(theta_i,p, mu_v,p) / sum_p (E/pi)_p,

and splits it as Rd(0) x incidence x exit with incidence = sum (E/pi) Rd(theta_i) / sum (E/pi) / Rd(0)
and exit = level_flat / (Rd(0) incidence).
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np

from ssskit.errors import SceneError, SettingsError
from ssskit.materials import get_material
from .oblique_table import ObliqueTable, cos_brackets, incidence_cosines, oblique_table
from ssskit.scenes import render_gbuffer, scene_lights
from .flat import SLAB_HALF_MM, flat_scene, light_position
from ssskit.scenes.reference import ReferenceRenderer, batch_mean_se
from ssskit.scenes.scenes import COAT_ROUGHNESS, SceneSpec, get_scene, mitsuba

#: how far (mm) inside the flat slab's edges a pixel of :func:`flat_experiment` must lie
FLAT_MARGIN_MM = 20.0


def point_light(scene: str | SceneSpec, frame: int = 0) -> np.ndarray:
    """(3,) the position of the scene's only light, a point light; a SceneError for any other lighting."""
    lights = scene_lights(get_scene(scene), frame)
    if len(lights) != 1 or next(iter(lights.values())).get("type") != "point":
        raise SceneError("the flat-medium prediction needs a scene lit by one point light "
                         f"(got {', '.join(str(d.get('type')) for d in lights.values())})")
    return np.asarray(next(iter(lights.values()))["position"], float)


def pixel_angles(gbuffer, light) -> tuple[np.ndarray, np.ndarray]:
    """(cos theta_i, mu_v), each (H, W): the point light's incidence cosine on each pixel's surface
    (normal turned towards the camera; 0 where the light is below the horizon) and the view cosine
    (:meth:`GBuffer.view_cosine`)."""
    pos = gbuffer.positions()
    eye = np.linalg.inv(gbuffer.camera.world_to_camera)[:3, 3]
    n = gbuffer.normal.astype(np.float64)
    n = np.where((np.sum(n * (eye - pos), axis=-1) < 0)[..., None], -n, n)
    return incidence_cosines(pos, n, light), gbuffer.view_cosine()


def interpolate_in_cos(angles_deg, values, cos_i) -> np.ndarray:
    """(C, ...) ``values`` (C, A) given at ``angles_deg`` (A,) increasing, linear in cos theta between
    them, held constant beyond the first and the last angle, at ``cos_i``."""
    return np.einsum("ca,...a->c...", np.asarray(values, float), _cos_weights(angles_deg, cos_i))


def _cos_weights(angles_deg, cos_i) -> np.ndarray:
    """(..., A) the weights of linear interpolation in cos theta between ``angles_deg`` at ``cos_i``
    (:func:`~lab.oblique_table.cos_brackets`)."""
    lo, hi, t = cos_brackets(angles_deg, cos_i)
    w = np.zeros(t.shape + (np.size(angles_deg),))
    np.put_along_axis(w, lo[..., None], (1.0 - t)[..., None], axis=-1)
    np.put_along_axis(w, hi[..., None], t[..., None], axis=-1)
    return w


def flat_prediction(gbuffer, light, table: ObliqueTable, masks: dict[str, np.ndarray],
                    boundary: tuple | None = None, fine=None) -> dict[str, dict[str, Any]]:
    """Per region (``masks``: name -> (H, W) bool) the flat medium's level at the pixels' own angles
    (module docstring): ``level`` (3,), its split ``incidence`` and ``exit`` (3,), ``rd0`` (3,), a
    conservative relative standard error ``rel_se`` (3,) from MCML's (the table's errors at the
    neighbouring nodes added, not combined in quadrature), and the E / pi-weighted mean incidence and
    view angles (degrees) and relative azimuth of light and camera about the normal (degrees, 0: the
    camera on the light's side).

    ``boundary`` = (angles_deg (A,), factor (3, A), factor_se (3, A)): a measured factor of the
    boundary per incidence angle (:func:`flat_experiment`'s reference / prediction at those angles),
    interpolated in cos theta_i per pixel (:func:`interpolate_in_cos`) and applied to every pixel's
    radiance: then ``level`` includes it, ``boundary`` (3,) is its share and ``boundary_se`` (3,) its
    standard error (the nodes' independent errors, propagated through the interpolation weights).

    ``fine``: a G-buffer of the same view at s times the width and height (s an integer): the angles
    and E / pi are then taken at its pixels, s x s per pixel of ``masks`` (a region's sums run over
    the SSS sub-pixels of its pixels). One pixel's normal is one sample of the surface within it;
    where the surface's slope varies within a pixel (the bumpy tile's 0.3 mm pits at 0.27 mm per
    pixel) the mean of the nonlinear Rd(theta_i) E over the pixel is not Rd at its one normal times
    its mean E."""
    pixels = {name: int(m.sum()) for name, m in masks.items()}
    if fine is not None:
        h, w = gbuffer.shape
        s = fine.shape[0] // h
        if s < 1 or fine.shape != (h * s, w * s):
            raise SettingsError(f"the fine G-buffer must be an integer multiple of {w}x{h}, got "
                                f"{fine.shape[1]}x{fine.shape[0]}")
        masks = {name: np.repeat(np.repeat(m, s, axis=0), s, axis=1) & fine.mask for name, m in masks.items()}
        gbuffer = fine
    cos_i, cos_v = pixel_angles(gbuffer, light)
    e = gbuffer.diffuse.astype(np.float64)
    rd0 = table.rd[:, 0]
    pos = gbuffer.positions()
    eye = np.linalg.inv(gbuffer.camera.world_to_camera)[:3, 3]
    out = {}
    for name, m in masks.items():
        if not m.any():
            continue
        w = e[m]  # (P, 3)
        ci, cv = cos_i[m], cos_v[m]
        rd = table.rd_at(ci).T  # (P, 3)
        f = table.radiance_factor(ci, cv).T
        rd_rel = table.rd_rel_se(ci).T
        level = (w * rd * f).sum(axis=0) / w.sum(axis=0)
        extra: dict[str, Any] = {}
        if boundary is not None:
            b_ang, b_val, b_se = (np.asarray(v, float) for v in boundary)
            wts = _cos_weights(b_ang, ci)  # (P, A)
            b = (wts @ b_val.T)  # (P, 3)
            base = w * rd * f
            share = (base * b).sum(axis=0) / base.sum(axis=0)
            # d share / d b_a = sum_p base_p wts_pa / sum_p base_p
            grad = np.einsum("pc,pa->ca", base, wts) / base.sum(axis=0)[:, None]
            extra = {"boundary": share.tolist(), "boundary_se": np.sqrt(((grad * b_se) ** 2).sum(axis=1)).tolist()}
            level = level * share
        inc = (w * rd).sum(axis=0) / w.sum(axis=0) / rd0
        # the table's errors at each pixel's nodes, relative, added (an upper bound: the pixels share nodes)
        f_rel = table.radiance_factor_se(ci, cv).T / f
        rel = (w * rd * f * (rd_rel + f_rel)).sum(axis=0) / (w * rd * f).sum(axis=0)
        ww = w[:, 1]
        d_l = np.asarray(light, float) - pos[m]
        d_c = eye - pos[m]
        az = np.degrees(np.arctan2(d_c[:, 1], d_c[:, 0]) - np.arctan2(d_l[:, 1], d_l[:, 0]))
        az = (az + 180.0) % 360.0 - 180.0
        exit_part = level / (rd0 * inc) / (np.asarray(extra["boundary"]) if extra else 1.0)
        out[name] = {"pixels": pixels[name], "samples": int(m.sum()), "level": level.tolist(), "rd0": rd0.tolist(),
                     "incidence": inc.tolist(), "exit": exit_part.tolist(), "rel_se": rel.tolist(), **extra,
                     "incidence_deg": float(np.degrees(np.arccos(np.clip(ci, 0, 1))) @ ww / ww.sum()),
                     "view_deg": float(np.degrees(np.arccos(np.clip(cv, 0, 1))) @ ww / ww.sum()),
                     "azimuth_deg": float(az @ ww / ww.sum()),
                     "lit_pixels": int((ci > 0).sum())}
    return out


def compare_flat_limit(prediction: dict[str, Any], exact_level, measured_exact_over_ref, measured_se,
                       label: str = "") -> dict[str, Any]:
    """The flat-medium prediction of one region (an entry of :func:`flat_prediction`) against a measured
    exact / reference ratio (± SE) in the flat limit: ``predicted_exact_over_reference`` = exact level /
    flat level; ``reference_over_flat`` = that / the measured ratio (± SE; 1 when the prediction
    explains the whole difference, below 1 when the reference is darker than a flat medium with a
    smooth Fresnel boundary)."""
    pred = np.asarray(exact_level, float) / np.asarray(prediction["level"], float)
    meas = np.asarray(measured_exact_over_ref, float)
    ratio = pred / meas
    rel_b = (np.asarray(prediction["boundary_se"], float) / np.asarray(prediction["boundary"], float)
             if "boundary" in prediction else 0.0)
    se = np.abs(ratio) * np.sqrt((np.asarray(measured_se, float) / meas) ** 2
                                 + np.asarray(prediction["rel_se"], float) ** 2 + rel_b**2)
    return {"label": label, "measured_exact_over_reference": meas.tolist(),
            "measured_se": np.asarray(measured_se, float).tolist(),
            "predicted_exact_over_reference": pred.tolist(), "reference_over_flat": ratio.tolist(),
            "reference_over_flat_se": se.tolist()}


def flat_experiment(material, incidence_deg: float, view_deg: float, azimuth_deg: float = 0.0,
                    boundary: str = "rough-dielectric", width: int = 64, height: int = 48, spp: int = 256,
                    chunk_spp: int = 8, photons: int = 1_000_000, seed: int = 0, max_depth: int = 1024,
                    table: ObliqueTable | None = None, compare: dict[str, ObliqueTable] | None = None,
                    progress=None) -> dict[str, Any]:
    """The path-traced reference of a flat medium lit at ``incidence_deg`` and seen at ``view_deg``
    (:func:`lab.flat.flat_scene`) against the MCML prediction at every pixel's angles
    (:func:`flat_prediction`): ``reference`` (3,) = mean diffuse part / mean E / pi ± SE (batches of
    ``chunk_spp``; the G-buffer's specular layer subtracted), ``prediction`` and
    ``reference_over_prediction`` ± SE (the reference's and MCML's errors combined).

    ``boundary``: ``rough-dielectric`` (the material's eta; MCML with a smooth Fresnel boundary of the
    same eta) or ``index-matched`` (Mitsuba ``null``; the material and MCML at eta = 1). ``table``: an
    :class:`ObliqueTable` of the material at the boundary's eta (else computed with ``photons``).
    ``compare``: more tables (name -> table, e.g. MCML with the rough surface), each giving
    ``against[name]`` = its ``prediction`` and ``reference_over_prediction`` ± SE for the same reference."""
    mat = get_material(material)
    if boundary not in ("rough-dielectric", "index-matched"):
        raise SettingsError(f"boundary must be rough-dielectric or index-matched, got {boundary!r}")
    if boundary == "index-matched":
        mat = dataclasses.replace(mat, eta=1.0)
    if isinstance(spp, bool) or not (isinstance(spp, int) and isinstance(chunk_spp, int) and chunk_spp >= 1
                                     and spp >= 2 * chunk_spp):
        raise SettingsError(f"spp must be an integer of at least two chunks of {chunk_spp!r} spp, got {spp!r}")
    spec = flat_scene(incidence_deg, view_deg, azimuth_deg)
    if table is None:
        table = oblique_table(mat, photons=photons)
    elif not math.isclose(table.eta, mat.eta):
        raise SettingsError(f"the table is for eta {table.eta:g}, the {boundary} boundary needs {mat.eta:g}")
    gb = render_gbuffer(spec, (1.0, 1.0, 1.0), eta=mat.eta, width=width, height=height, spp=16, material=mat.name)
    pos = gb.positions()
    region = gb.mask & np.all(np.abs(pos[..., :2]) < SLAB_HALF_MM - FLAT_MARGIN_MM, axis=-1)
    if not region.all():
        raise SceneError("the flat slab does not fill the image (its field of view reaches an edge)")
    pred = flat_prediction(gb, light_position(incidence_deg), table, {"flat": region})["flat"]
    e = gb.diffuse.astype(np.float64).mean(axis=(0, 1))
    spec_mean = gb.specular.astype(np.float64).mean(axis=(0, 1))
    renderer = ReferenceRenderer(spec, mat, width, height, max_depth=max_depth, seed=seed, boundary=boundary)
    chunks = spp // chunk_spp
    t0 = time.perf_counter()
    levels = np.empty((chunks, 3))
    for i in range(chunks):
        levels[i] = (renderer.chunk(i, chunk_spp).mean(axis=(0, 1)) - spec_mean) / e
        if progress is not None and (i + 1) % max(1, chunks // 4) == 0:
            progress(f"flat {boundary} ({incidence_deg:g}, {view_deg:g}): {(i + 1) * chunk_spp} spp, "
                     f"{time.perf_counter() - t0:.0f} s")
    ref, ref_se = batch_mean_se(levels)

    def against(p):
        r = ref / np.asarray(p["level"])
        return r, r * np.hypot(ref_se / ref, np.asarray(p["rel_se"]))

    ratio, se = against(pred)
    others = {}
    for name, tab in (compare or {}).items():
        p = flat_prediction(gb, light_position(incidence_deg), tab, {"flat": region})["flat"]
        r, r_se = against(p)
        others[name] = {"prediction": p, "reference_over_prediction": r.tolist(),
                        "reference_over_prediction_se": r_se.tolist()}
    return {"boundary": boundary, "eta": float(mat.eta), "incidence_deg": float(incidence_deg),
            "view_deg": float(view_deg), "azimuth_deg": float(azimuth_deg), "size": [width, height],
            "spp": chunks * chunk_spp, "seconds": round(time.perf_counter() - t0, 1),
            "specular_fraction": (spec_mean / e / np.maximum(ref, 1e-300)).tolist(),
            "reference": ref.tolist(), "reference_se": ref_se.tolist(), "prediction": pred,
            "reference_over_prediction": ratio.tolist(), "reference_over_prediction_se": se.tolist(),
            "against": others}


def surface_reentry(scene: str | SceneSpec, table: ObliqueTable, samples: int = 20_000, seed: int = 0,
                    batches: int = 10) -> dict[str, Any]:
    """How much light leaving an SSS surface re-enters it elsewhere (light the G-buffer's direct E / pi
    does not have and the path-traced reference does): the scene's SSS shapes alone (the rest is black
    in the reference), lit by its point light (:func:`point_light`).

    Monte Carlo over points q uniform in the shapes' projected area (rays cast down along -z: a
    heightfield, such as the bumpy tile): the light's irradiance E(q) (shadow ray), the diffuse light
    leaving E Rd(theta_q) (``table``: MCML of the material, e.g. with the references' rough surface);
    one sample of the boundary's reflection (Mitsuba ``roughdielectric``, Beckmann alpha =
    :data:`ssskit.scenes.COAT_ROUGHNESS`, eta of the table, importance transport: its weight is the
    reflected energy) and one cosine-weighted direction of the diffuse light (a Lambertian exit), each
    traced to the surface: where it hits the front side at cos theta_p, it enters and leaves again as
    x Rd(theta_p) (the table; for the diffuse bounce Rd at the hit's angle of a Lambertian source is
    approximated by Rd(theta_p) of a beam). Returns ``reflected`` (the share of the incident light the
    boundary reflects), ``specular_reentry`` and ``diffuse_reentry`` (3,): the re-entering light's
    diffuse output over the direct light's, each ± SE (``batches`` batches), and ``samples``."""
    spec = get_scene(scene)
    mi = mitsuba()
    shapes = spec.shapes()
    sc = mi.load_dict({"type": "scene", **{sid: dict(shapes[sid]) for sid in spec.sss_shapes}})
    coat = mi.load_dict({"type": "roughdielectric", "int_ior": float(table.eta), "ext_ior": 1.0,
                         "distribution": "beckmann", "alpha": COAT_ROUGHNESS})
    ctx = mi.BSDFContext(mi.TransportMode.Importance)
    light = point_light(spec)
    bbox = sc.bbox()
    lo, hi = np.array(bbox.min, float), np.array(bbox.max, float)
    rng = np.random.default_rng(seed)
    per = max(samples // batches, 1)
    acc = np.zeros((batches, 8))  # incident, reflected, direct out (3), specular back (3) ... see below
    diff = np.zeros((batches, 3))

    def trace(p, n, d):
        hit = sc.ray_intersect(mi.Ray3f(mi.Point3f(*(p + 1e-3 * n)), mi.Vector3f(*d)))
        if not hit.is_valid():
            return None
        n2 = np.asarray(hit.n, float)
        n2 = n2 if n2[2] > 0 else -n2
        c2 = float(-(n2 @ d))
        return c2 if c2 > 0 else None

    for b in range(batches):
        for _ in range(per):
            x, y = rng.uniform(lo[0], hi[0]), rng.uniform(lo[1], hi[1])
            u = rng.random(5)
            si = sc.ray_intersect(mi.Ray3f(mi.Point3f(x, y, hi[2] + 1.0), mi.Vector3f(0.0, 0.0, -1.0)))
            if not si.is_valid():
                continue
            p, n = np.asarray(si.p, float), np.asarray(si.n, float)
            n = n if n[2] > 0 else -n
            to_l = light - p
            dist = float(np.linalg.norm(to_l))
            to_l /= dist
            cl = float(n @ to_l)
            if cl <= 0 or sc.ray_test(mi.Ray3f(mi.Point3f(*(p + 1e-3 * n)), mi.Vector3f(*to_l), dist - 1e-2)):
                continue
            e = cl / dist**2 / n[2]  # irradiance x the area element of a uniform (x, y) sample
            out_direct = e * table.rd_at(cl)
            acc[b, 0] += e
            acc[b, 2:5] += out_direct
            frame = mi.Frame3f(mi.Vector3f(*n))
            s2 = mi.SurfaceInteraction3f()
            s2.sh_frame = frame
            s2.wi = frame.to_local(mi.Vector3f(*to_l))
            bs, weight = coat.sample(ctx, s2, float(u[0]), mi.Point2f(float(u[1]), float(u[2])))
            if bs.wo[2] > 0:
                acc[b, 1] += e * float(weight[0])
                c2 = trace(p, n, np.asarray(frame.to_world(bs.wo), float))
                if c2 is not None:
                    acc[b, 5:8] += e * float(weight[0]) * table.rd_at(c2)
            # a cosine-weighted direction of the diffuse light leaving q
            r, phi = math.sqrt(u[3]), 2.0 * math.pi * u[4]
            local = mi.Vector3f(r * math.cos(phi), r * math.sin(phi), math.sqrt(max(1.0 - u[3], 0.0)))
            c3 = trace(p, n, np.asarray(frame.to_world(local), float))
            if c3 is not None:
                diff[b] += out_direct * table.rd_at(c3)
    direct = acc[:, 2:5]

    def ratio(num):
        r, se = _batch_ratio(num, direct)
        return r.tolist(), se.tolist()

    refl, refl_se = _batch_ratio(acc[:, 1:2], acc[:, 0:1])
    spec_r, spec_se = ratio(acc[:, 5:8])
    diff_r, diff_se = ratio(diff)
    return {"samples": per * batches, "reflected": float(refl[0]), "reflected_se": float(refl_se[0]),
            "specular_reentry": spec_r, "specular_reentry_se": spec_se,
            "diffuse_reentry": diff_r, "diffuse_reentry_se": diff_se}


def _batch_ratio(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sum(num) / sum(den) over batches (axis 0) and its standard error (batch and delta methods)."""
    k = num.shape[0]
    r = num.sum(axis=0) / den.sum(axis=0)
    se = (num - r * den).std(axis=0, ddof=1) * math.sqrt(k) / den.sum(axis=0)
    return r, se


__all__ = ["FLAT_MARGIN_MM", "compare_flat_limit", "flat_experiment", "flat_prediction",
           "interpolate_in_cos", "pixel_angles", "point_light", "surface_reentry"]
