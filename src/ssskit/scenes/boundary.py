"""The path-traced references' boundary, as Mitsuba itself samples it: a rough dielectric (Mitsuba 3's
single-scattering ``roughdielectric``, Beckmann microfacets of roughness alpha = :data:`COAT_ROUGHNESS`,
Walter et al. 2007 [WMLT07]) between air and a medium of index eta.

:func:`rough_dielectric_weights` tells what that boundary reflects, transmits and loses at each incidence
angle, from either side, by sampling Mitsuba's own BSDF (its visible-normal routine, importance transport
mode); it is the independent reference the MCML engine's rough surface
(:attr:`ssskit.profiles.montecarlo.MCConfig.roughness`) is tested against, and tells a user how far the
reference's boundary is from Fresnel's smooth one (:func:`rough_dielectric_transmittance`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SceneError
from ..quantities import Quantity, checks
from .scenes import COAT_ROUGHNESS, mitsuba

#: a dielectric boundary's index, and the samples of a mean and its standard error
BOUNDARY_ETA = Quantity("eta", 1.0, math.inf, "", "a dielectric boundary; eta = 1 is none", lo_open=True, hi_open=True)
SAMPLES = Quantity("samples", 2, math.inf, "", "a mean and its spread", integer=True, hi_open=True)


@checks(SceneError, eta=BOUNDARY_ETA, samples=SAMPLES)
def rough_dielectric_weights(cos_i: ArrayLike, eta: float, alpha: float = COAT_ROUGHNESS, samples: int = 50_000,
                             seed: int = 0, inside: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(mean, standard error), each of shape cos_i.shape + (2,): the light the reference's boundary
    reflects ([..., 0]) and transmits ([..., 1]) at each incidence cosine ``cos_i``, arriving from
    outside (or, ``inside``, from the medium): Mitsuba's ``roughdielectric`` (Beckmann ``alpha``,
    int_ior = ``eta``) sampled ``samples`` times per angle with its own visible-normal routine in
    importance (flux) transport mode, the mean sample weight on each side. 1 minus both is what the
    single-scattering BSDF loses."""
    mi = mitsuba()
    bsdf = mi.load_dict({"type": "roughdielectric", "int_ior": float(eta), "ext_ior": 1.0,
                         "distribution": "beckmann", "alpha": float(alpha)})
    ctx = mi.BSDFContext(mi.TransportMode.Importance)
    rng = np.random.default_rng(seed)
    cos = np.atleast_1d(np.asarray(cos_i, float))
    mean, se = np.empty(cos.shape + (2,)), np.empty(cos.shape + (2,))
    for j, c in enumerate(cos):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(math.sqrt(max(1.0 - c * c, 0.0)), 0.0, -float(c) if inside else float(c))
        si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
        u = rng.random((samples, 3))
        w = np.zeros((samples, 2))
        for k in range(samples):
            bs, weight = bsdf.sample(ctx, si, float(u[k, 0]), mi.Point2f(float(u[k, 1]), float(u[k, 2])))
            w[k, int(bs.wo[2] * si.wi[2] < 0)] = weight[0]
        mean[j], se[j] = w.mean(axis=0), w.std(axis=0, ddof=1) / math.sqrt(samples)
    shape = np.shape(cos_i) + (2,)
    return mean.reshape(shape), se.reshape(shape)


def rough_dielectric_transmittance(cos_i: ArrayLike, eta: float, alpha: float = COAT_ROUGHNESS, samples: int = 50_000,
                                   seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(transmittance, standard error) at each incidence cosine ``cos_i`` of the reference's boundary
    for light arriving from outside (:func:`rough_dielectric_weights`). A smooth boundary transmits
    1 - R (Fresnel); a rough one sees the light at the microfacets' own angles, which near grazing
    incidence face the light more than the mean surface does."""
    mean, se = rough_dielectric_weights(cos_i, eta, alpha, samples, seed)
    return mean[..., 1], se[..., 1]


__all__ = ["rough_dielectric_transmittance", "rough_dielectric_weights"]
