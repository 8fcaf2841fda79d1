"""Transmission parameters for the engines from the MCML slab tables: Unity HDRP's diffusion-profile
``transmissionTint`` and ``thicknessRemap`` for its thick-object transmission (:func:`hdrp_transmission`),
and Unreal Engine 5's subsurface-profile ``TransmissionTintColor`` and ``ExtinctionScale`` (:func:`unreal_transmission`).

HDRP's transmittance (``ComputeTransmittanceDisney`` in HDRP's ``DiffusionProfile.hlsl``, Unity-Technologies/
Graphics; the Christensen-Burley profile integrated over the plane at depth t, [CB15]):

    T_c(t) = (A_c / 4) (e^(-S_c t) + 3 e^(-S_c t / 3)),  S_c = 1 / d_c,

with A the ``transmissionTint`` (HDRP premultiplies it by 1/4 on the CPU) and d the profile's scattering
distance (``scatteringDistance`` x multiplier, mm at worldScale 1: :mod:`ssskit.export.unity`). The shape
S is the reflectance profile's, shared by both: only the tint is free. :func:`hdrp_transmission` chooses
the tint per channel that minimises the relative error against MCML's scattered transmittance T_s(t) (Tt less
the unscattered beam, which leaves along the light and which a camera elsewhere never sees: the pass's ``mcml``
model, :attr:`~ssskit.profiles.montecarlo.transmission.TransmissionTable.diffuse`) over the thicknesses where T_s >
``visible`` and t at or past T_s's maximum (:func:`fitted_thicknesses`: HDRP's shape falls from t = 0, T_s rises
from 0 first) (weighted least squares, closed form: A = sum(g T / T^2) / sum(g^2 / T^2), g = T / A the shape),
clamped to >= 0 only (``transmissionTint`` is an HDR colour: ``[ColorUsage(false, true)]`` in HDRP's
DiffusionProfileSettings.cs, which ``Validate`` leaves unclamped), and reports what is lost: the relative error over
those thicknesses.
``thicknessRemap`` = (0, the largest of those thicknesses): a thickness texture's [0, 1] spans the range
fitted.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..backends.transmission_plan import SlotModel
from ..profiles.montecarlo.transmission import TransmissionTable


def hdrp_shape(d_mm: Any, thickness_mm: Any) -> np.ndarray:
    """(N, 3) g(t) = (e^(-S t) + 3 e^(-S t / 3)) / 4, S = 1 / d: HDRP's transmittance for tint 1."""
    s = 1.0 / np.asarray(d_mm, float)
    t = np.asarray(thickness_mm, float)[:, None]
    return np.asarray(0.25 * (np.exp(-s * t) + 3.0 * np.exp(-s * t / 3.0)))


def hdrp_model(tint: Any, d_mm: Any) -> SlotModel:
    """HDRP's T(t) as a pass model: a = (A / 4, 3 A / 4), b = (S, S / 3), c = 0, the cosine law at the back."""
    a = np.asarray(tint, float)
    s = 1.0 / np.asarray(d_mm, float)
    return SlotModel(np.stack([a / 4, 3 * a / 4], -1), np.stack([s, s / 3], -1), np.zeros((3, 2)), 1.0, 0.0, "mcml")


def fitted_thicknesses(table: TransmissionTable, visible: float = 1e-3) -> np.ndarray:
    """(N, 3) bool: per channel, the thicknesses an engine's transmission is fitted over: T_s > ``visible`` and t at
    or past T_s's maximum. The scattered part rises from 0 at t = 0 to its maximum (for Skin1 at a few tenths of a
    mm) and falls after; the engines' shapes fall from t = 0, so only the falling part can be followed, and thinner
    than that the export overestimates (reported as ``thinner_than_fit_mm``)."""
    ts = table.diffuse
    t = np.asarray(table.thickness_mm, float)
    peak = t[np.argmax(ts, axis=0)]  # (3,)
    return np.asarray((ts > visible) & (t[:, None] >= peak[None, :]))


def hdrp_transmission(table: TransmissionTable, d_mm: Any, visible: float = 1e-3) -> dict[str, Any]:
    """HDRP's ``transmissionTint`` and ``thicknessRemap`` fitted to ``table`` with the profile's scattering
    distance ``d_mm`` (3,) (module docstring), and the error left."""
    t = table.thickness_mm
    tint = np.zeros(3)
    free = np.zeros(3)
    rel_max = np.zeros(3)
    rel_rms = np.zeros(3)
    t_hi = 0.0
    fit = fitted_thicknesses(table, visible)
    for c in range(3):
        y = table.diffuse[:, c]  # T_s: the scattered light the pass's mcml model holds (not the unscattered beam)
        m = fit[:, c]
        g = hdrp_shape(d_mm, t[m])[:, c]
        w = 1.0 / y[m] ** 2
        a = float(np.sum(w * g * y[m]) / np.sum(w * g * g))
        free[c] = a
        tint[c] = max(a, 0.0)
        rel = np.abs(tint[c] * g - y[m]) / y[m]
        rel_max[c], rel_rms[c] = rel.max(), float(np.sqrt(np.mean(rel ** 2)))
        t_hi = max(t_hi, float(t[m].max()))
    return {"engine": "unity", "transmissionMode": "ThickObject (shadow-map thickness)",
            "transmissionTint": tint.tolist(), "tint_unclamped": free.tolist(), "thicknessRemap": [0.0, t_hi],
            "scattering_distance_mm": np.asarray(d_mm, float).tolist(),
            "max_rel_error": rel_max.tolist(), "rms_rel_error": rel_rms.tolist(),
            "fitted_where_T_above": visible, "thinner_than_fit_mm": _thin(table, fit),
            "formula": "T_c(t) = (transmissionTint_c / 4) (e^(-t / d_c) + 3 e^(-t / (3 d_c))); tint_c the weighted "
                       "least-squares fit (relative error) to MCML's scattered T_s(t) where T_s > "
                       "fitted_where_T_above and t >= thinner_than_fit_mm (an HDR colour, clamped to >= 0); d the reflectance profile's scattering distance (not free)"}


#: UE's ClampMin/ClampMax of ExtinctionScale (SubsurfaceProfile.h) and the grid searched between them
UE_EXTINCTION_RANGE = (0.01, 100.0)
#: UE's ClampMin/ClampMax of DistanceScale (SubsurfaceProfile.h, UE 5.8)
UE_DISTANCE_RANGE = (0.1, 10.0)
#: UE's clamp of colours in CreateTexture (Bias) and the 1 of an LDR colour
UE_TINT_RANGE = (0.009, 1.0)
#: the ScatteringDistribution exported: UE's ClampMin, the nearest to isotropic UE accepts (ApproximateHG within 2 %
#: of 0.5 for every angle), so the exit does not depend on the view, like MCML's tallied over the hemisphere
UE_EXPORT_G = 0.01


def unreal_shape(d_mm: Any, thickness_mm: Any, extinction_scale: float, normal_scale: float = 0.08,
                 distance_scale: float = 1.0) -> np.ndarray:
    """(N, 3) UE 5.8's transmission profile for TransmissionTintColor 1 at thicknesses (mm): the table of
    :func:`ssskit.screenspace.transmission.unreal_profile_table` read at UE's optical depth (the pass's
    ``unreal`` step 4)."""
    from ..backends.transmission_plan import build_transmission_plan
    from ..screenspace.transmission import unreal_model

    model = unreal_model(d_mm, (1.0, 1.0, 1.0), extinction_scale, normal_scale, distance_scale=distance_scale)
    plan = build_transmission_plan({1: model}, 0.0)
    return np.asarray(plan.transmittance(1, np.asarray(thickness_mm, float)))


def unreal_transmission(table: TransmissionTable, surface_albedo: Any, d_mm: Any, visible: float = 1e-3,
                        normal_scale: float = 0.08) -> dict[str, Any]:
    """Unreal Engine 5's transmission fields for a SubsurfaceProfile with Burley ``d_mm`` and ``surface_albedo``
    fitted to MCML's scattered transmittance T_s(t) of ``table`` (its ``diffuse``, what the pass's ``mcml`` model
    holds; [UE58]; the pass's ``unreal`` model is the engine's computation).

    UE's transmitted radiance is BaseColor x TransmissionTintColor x P(t) x ApproximateHG(cos, g) x E (the profile P
    of the tabulated Burley transmission at UE's optical depth; the recombine pass multiplies by the base colour);
    ssskit's is T(t) E / pi (a Lambertian exit). With ScatteringDistribution g = 0.01 (:data:`UE_EXPORT_G`,
    ApproximateHG = 0.5 (1 - g^2) within 2 % at every angle) the two agree where tint_c P_c(t) = T_c(t) / (pi A_c
    0.5 (1 - g^2)). ExtinctionScale and DistanceScale (which scales only the transmission table's distances) are
    searched on log grids over UE's ranges, and for each pair the tint per channel is the weighted least-squares fit
    in relative error over :func:`fitted_thicknesses` (closed form), clamped to UE's [0.009, 1]; NormalScale and
    WorldUnitScale (which also scales the reflectance) stay UE's defaults. Returns the fields and what is lost
    (relative error of UE's radiance against MCML's over those thicknesses)."""
    a = np.asarray(surface_albedo, float)
    t = table.thickness_mm
    phase = 0.5 * (1.0 - UE_EXPORT_G ** 2)
    fit = fitted_thicknesses(table, visible)
    best: dict[str, Any] | None = None
    grid = [(float(e), float(ds)) for e in np.geomspace(*UE_EXTINCTION_RANGE, 81)
            for ds in np.geomspace(*UE_DISTANCE_RANGE, 41)]
    for ext, ds in grid:
        g = unreal_shape(d_mm, t, ext, normal_scale, ds)
        tint, free = np.zeros(3), np.zeros(3)
        rel_max, rel_rms = np.zeros(3), np.zeros(3)
        cost = 0.0
        for c in range(3):
            ts = table.diffuse[:, c]  # T_s, the scattered part (the pass's mcml model)
            m = fit[:, c]
            y = ts[m] / (math.pi * a[c] * phase)
            gc = g[m, c]
            w = 1.0 / y ** 2
            den = float(np.sum(w * gc * gc))
            free[c] = float(np.sum(w * gc * y) / den) if den > 0 else UE_TINT_RANGE[1]
            tint[c] = min(max(free[c], UE_TINT_RANGE[0]), UE_TINT_RANGE[1])
            rel = np.abs(tint[c] * gc - y) / y
            rel_max[c], rel_rms[c] = rel.max(), float(np.sqrt(np.mean(rel ** 2)))
            cost += float(np.sum(rel ** 2))
        if best is None or cost < best["cost"]:
            best = {"cost": cost, "ext": ext, "ds": ds, "tint": tint, "free": free, "max": rel_max, "rms": rel_rms}
    assert best is not None
    return {"engine": "unreal", "unreal_versions": "UE 5.8 (the transmission table of ComputeTransmissionProfileBurley)",
            "ExtinctionScale": best["ext"], "NormalScale": normal_scale, "ScatteringDistribution": UE_EXPORT_G,
            "TransmissionTintColor": best["tint"].tolist(), "tint_unclamped": best["free"].tolist(),
            "DistanceScale": best["ds"], "WorldUnitScale": 0.1, "scattering_distance_mm": np.asarray(d_mm, float).tolist(),
            "max_rel_error": best["max"].tolist(), "rms_rel_error": best["rms"].tolist(),
            "fitted_where_T_above": visible, "thinner_than_fit_mm": _thin(table, fit),
            "formula": "UE radiance = BaseColor_c TransmissionTintColor_c P_c(x(t)) ApproximateHG(cos, g) E with P the "
                       "32-entry Burley transmission table (d_c) read at UE's optical depth x(ExtinctionScale t / 10 + "
                       "NormalScale / 2), its distances r_i / DistanceScale; fitted to MCML's T_s(t) E / pi: g = 0.01, "
                       "ExtinctionScale and DistanceScale by a log-grid search over [0.01, 100] x [0.1, 10], "
                       "TransmissionTintColor_c by weighted least squares in relative error where T_s > "
                       "fitted_where_T_above and t >= thinner_than_fit_mm, clamped to UE's [0.009, 1]"}


def _thin(table: TransmissionTable, fit: np.ndarray) -> list[float]:
    """Per channel the thinnest thickness fitted (T_s's maximum, :func:`fitted_thicknesses`)."""
    t = np.asarray(table.thickness_mm, float)
    return [float(t[fit[:, c]].min()) if fit[:, c].any() else float("nan") for c in range(3)]


__all__ = ["UE_EXPORT_G", "fitted_thicknesses", "hdrp_model", "hdrp_shape", "hdrp_transmission", "unreal_shape", "unreal_transmission"]
