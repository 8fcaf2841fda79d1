"""What is left of the back-lit ear's difference once the transmittance pass runs (issue 25), measured:

* the **transmitted part alone** (:func:`transmitted_table`): the reference's light that entered through the
  surface the camera does not see is the reference as rendered less the same scene with a black backing there
  (:func:`lab.variants.backed_scene`); the pass's is what the transmittance pass adds (its result, T E / pi).
  Their ratio per region, per channel, separates the transmission model's error from the reflectance model's
  (the thin ear's red light lost through its back, docs/regions.md);
* the **shadow map's resolution** (:func:`map_resolution_pass`): the pass with the light-space depth ray-cast
  at k times the frame's size (the G-buffer's layer is at the frame's: an EXR part has one data window);
* the **reference's rough faces** (:func:`slab_face_levels`): the back-lit slab path-traced with smooth faces
  (MCML's) and with the references' rough dielectric;
* **oblique incidence** (:func:`oblique_table`): MCML's scattered transmittance of a slab lit at theta against
  the same slab at normal incidence (the pass's thickness along the surface normal) and against a slab as thick
  as the light's chord t / cos theta (the translucency shadow map's thickness).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ssskit.materials import Material


def region_levels(part: np.ndarray, e: np.ndarray, masks: dict[str, np.ndarray],
                  se: np.ndarray | None = None) -> dict[str, dict[str, Any]]:
    """Per region: ``level`` = mean(part) / mean(E / pi) per channel (the region table's level) and, with
    per-pixel standard errors ``se``, its standard error (the pixels' in quadrature)."""
    out = {}
    for name, m in masks.items():
        n = int(m.sum())
        if n == 0:
            continue
        ebar = e[m].astype(np.float64).mean(axis=0)
        row: dict[str, Any] = {"pixels": n, "level": (part[m].astype(np.float64).mean(axis=0) / ebar).tolist()}
        if se is not None:
            row["se"] = (np.sqrt(np.sum(se[m].astype(np.float64) ** 2, axis=0)) / n / ebar).tolist()
        out[name] = row
    return out


def transmitted_table(pass_part: np.ndarray, ref: np.ndarray, ref_backed: np.ndarray, ref_se: np.ndarray,
                      ref_backed_se: np.ndarray, e: np.ndarray, masks: dict[str, np.ndarray]) -> dict[str, Any]:
    """The transmitted part per region: the pass's (``pass_part``, T E / pi) against the reference's (as rendered
    less backed; its standard error the two references' in quadrature, an upper bound when their chunks share
    seeds and so correlate), and their ratio with its standard error."""
    t_ref = np.asarray(ref, np.float64) - np.asarray(ref_backed, np.float64)
    se = np.hypot(np.asarray(ref_se, np.float64), np.asarray(ref_backed_se, np.float64))
    p = region_levels(pass_part, e, masks)
    r = region_levels(t_ref, e, masks, se)
    out = {}
    for name in r:
        a, b, s = np.asarray(p[name]["level"]), np.asarray(r[name]["level"]), np.asarray(r[name]["se"])
        out[name] = {"pixels": r[name]["pixels"], "pass": a.tolist(), "path_traced": b.tolist(), "path_traced_se": s.tolist(),
                     "ratio": (a / b).tolist(), "ratio_se": (a / b * s / np.abs(b)).tolist()}
    return out


def map_resolution_pass(scene: Any, gb: Any, plan: Any, factor: int, backend: str = "numpy") -> np.ndarray:
    """The transmittance pass's exitance (H, W, 3) on ``gb`` with the light-space depth ray-cast at ``factor``
    times the frame's size (:func:`ssskit.scenes.lightspace.depth_map`) instead of the G-buffer's own layer;
    ``factor`` 1 reproduces the pass on the G-buffer's layer."""
    from ssskit.backends import get_backend
    from ssskit.scenes.lightspace import depth_map, scene_light_view

    h, w = gb.shape
    view = scene_light_view(scene, (factor * w, factor * h))
    shadow = depth_map(scene, view)
    uvz, _, ndl, light = gb.transmission_inputs()
    uvz = view.project(gb.positions() / gb.camera.world_units_per_mm)
    slots = (gb.profile_id > 0).astype(np.int32)
    return np.asarray(get_backend(backend).transmission(plan, slots, uvz, shadow, ndl, light), np.float64)


def slab_face_levels(thickness_mm: float, faces: str, material: Material, view_deg: float = 45.0, size: int = 16,
                     chunks: int = 1280, chunk_spp: int = 64, seed: int = 7) -> dict[str, Any]:
    """pi L / E of the back-lit slab (:func:`ssskit.scenes.backlit.backlit_slab`) path-traced with ``faces``
    ``"smooth"`` (Mitsuba ``dielectric``, MCML's smooth Fresnel faces) or ``"rough"`` (the references'
    ``roughdielectric``, Beckmann alpha 0.15), over a ``size`` x ``size`` * 3/4 image of the slab's middle:
    the mean and the standard error of ``chunks`` renders of ``chunk_spp`` samples (seeds ``chunk_seed(seed, i)``).
    E is the light's irradiance at the lit face, pi (the scene's)."""
    from ssskit.scenes.backlit import backlit_slab
    from ssskit.scenes.reference import _interior, chunk_seed
    from ssskit.scenes.scenes import mitsuba, scene_dict

    mi = mitsuba()
    spec = backlit_slab(thickness_mm, view_deg)
    inner = _interior(material, "rough-dielectric")
    if faces == "smooth":
        inner = {"type": "dielectric", "int_ior": float(material.eta), "ext_ior": float(material.eta_ambient),
                 "__medium": inner["__medium"]}
    elif faces != "rough":
        raise ValueError(f"faces must be smooth or rough, got {faces!r}")
    black = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.0}}
    d = scene_dict(spec, size, size * 3 // 4, 1, 0, 0, {"type": "volpathmis", "max_depth": 1024},
                   lambda sid: inner if sid in spec.sss_shapes else black)
    scene = mi.load_dict(d)
    means = np.array([np.array(mi.render(scene, seed=chunk_seed(seed, i), spp=chunk_spp))[..., :3].mean(axis=(0, 1))
                      for i in range(chunks)])
    e = math.pi * 400.0 * (250.0 / (5000.0 - thickness_mm)) ** 2  # the sphere light at the lit face
    return {"thickness_mm": thickness_mm, "faces": faces, "level": (math.pi * means.mean(0) / e).tolist(),
            "se": (math.pi * means.std(0, ddof=1) / math.sqrt(chunks) / e).tolist(), "spp": chunks * chunk_spp}


def oblique_table(material: Material, thicknesses: Sequence[float], angles: Sequence[float], photons: int = 100_000,
                  seed: int = 900) -> list[dict[str, Any]]:
    """MCML's scattered transmittance T_s(t, theta) (Tt less the unscattered beam, whose Fresnel at theta and
    path t / cos theta_t inside are exact) of the material's slab at each thickness and incidence angle, and
    its ratios to T_s(t, 0) (the pass's thickness along the normal) and to T_s(t / cos theta, 0) (along the
    light's chord), each from independent runs."""
    from ssskit.profiles.montecarlo import simulate
    from ssskit.profiles.montecarlo.engine_numba import _fresnel
    from ssskit.profiles.montecarlo.slab import slab_config

    def ballistic(c: int, t: float, deg: float) -> float:
        s_t = math.sin(math.radians(deg)) / material.eta
        mu_t = math.sqrt(1.0 - s_t * s_t)
        r, _ = _fresnel(material.eta_ambient, material.eta, math.cos(math.radians(deg)))
        e = math.exp(-material.sigma_t[c] * t / mu_t)
        return (1.0 - r) ** 2 * e / (1.0 - r * r * e * e)

    def scattered(c: int, t: float, deg: float, s: int) -> tuple[float, float]:
        res = simulate(slab_config(material, c, t, photons, s, incidence_deg=float(deg)))
        return res.tt - ballistic(c, t, deg), res.tt_se

    rows = []
    for i, t in enumerate(thicknesses):
        normal = [scattered(c, t, 0.0, seed + 97 * i) for c in range(3)]
        for j, deg in enumerate(angles):
            at = [scattered(c, t, deg, seed + 97 * i + 7 * j + 1) for c in range(3)]
            chord = [scattered(c, t / math.cos(math.radians(deg)), 0.0, seed + 97 * i + 7 * j + 3) for c in range(3)]
            rows.append({"thickness_mm": t, "incidence_deg": deg, "Ts": [a[0] for a in at],
                         "Ts_se": [a[1] for a in at],
                         "normal_over_oblique": [n[0] / a[0] for n, a in zip(normal, at)],
                         "chord_over_oblique": [k[0] / a[0] for k, a in zip(chord, at)],
                         "ratio_se": [math.hypot(n[1], a[1]) / a[0] for n, a in zip(normal, at)]})
    return rows


__all__ = ["map_resolution_pass", "oblique_table", "region_levels", "slab_face_levels", "transmitted_table"]
