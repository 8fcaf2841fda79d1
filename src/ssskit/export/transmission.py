"""Transmission parameters for Unity HDRP from the MCML slab tables: the diffusion profile's
``transmissionTint`` and ``thicknessRemap`` for its thick-object transmission.

HDRP's transmittance (``ComputeTransmittanceDisney`` in HDRP's ``DiffusionProfile.hlsl``, Unity-Technologies/
Graphics; the Christensen-Burley profile integrated over the plane at depth t, [CB15]):

    T_c(t) = (A_c / 4) (e^(-S_c t) + 3 e^(-S_c t / 3)),  S_c = 1 / d_c,

with A the ``transmissionTint`` (HDRP premultiplies it by 1/4 on the CPU) and d the profile's scattering
distance (``scatteringDistance`` x multiplier, mm at worldScale 1: :mod:`ssskit.export.unity`). The shape
S is the reflectance profile's, shared by both: only the tint is free. :func:`hdrp_transmission` chooses
the tint per channel that minimises the relative error against MCML's T(t) over the thicknesses where T >
``visible`` (weighted least squares, closed form: A = sum(g T / T^2) / sum(g^2 / T^2), g = T / A the shape),
clamped to [0, 1] (an LDR colour; ``tint_unclamped`` the fit before), and reports what is lost: the relative error over those thicknesses.
``thicknessRemap`` = (0, the largest of those thicknesses): a thickness texture's [0, 1] spans the range
fitted.
"""

from __future__ import annotations

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


def hdrp_transmission(table: TransmissionTable, d_mm: Any, visible: float = 1e-3) -> dict[str, Any]:
    """HDRP's ``transmissionTint`` and ``thicknessRemap`` fitted to ``table`` with the profile's scattering
    distance ``d_mm`` (3,) (module docstring), and the error left."""
    t = table.thickness_mm
    tint = np.zeros(3)
    free = np.zeros(3)
    rel_max = np.zeros(3)
    rel_rms = np.zeros(3)
    t_hi = 0.0
    for c in range(3):
        y = table.tt[:, c]
        m = y > visible
        g = hdrp_shape(d_mm, t[m])[:, c]
        w = 1.0 / y[m] ** 2
        a = float(np.sum(w * g * y[m]) / np.sum(w * g * g))
        free[c] = a
        tint[c] = min(max(a, 0.0), 1.0)
        rel = np.abs(tint[c] * g - y[m]) / y[m]
        rel_max[c], rel_rms[c] = rel.max(), float(np.sqrt(np.mean(rel ** 2)))
        t_hi = max(t_hi, float(t[m].max()))
    return {"engine": "unity", "transmissionMode": "ThickObject (shadow-map thickness)",
            "transmissionTint": tint.tolist(), "tint_unclamped": free.tolist(), "thicknessRemap": [0.0, t_hi],
            "scattering_distance_mm": np.asarray(d_mm, float).tolist(),
            "max_rel_error": rel_max.tolist(), "rms_rel_error": rel_rms.tolist(),
            "fitted_where_T_above": visible,
            "formula": "T_c(t) = (transmissionTint_c / 4) (e^(-t / d_c) + 3 e^(-t / (3 d_c))); tint_c the weighted "
                       "least-squares fit (relative error) to MCML's T(t) where T > fitted_where_T_above, clamped to "
                       "[0, 1]; d the reflectance profile's scattering distance (not free)"}


__all__ = ["hdrp_model", "hdrp_shape", "hdrp_transmission"]
