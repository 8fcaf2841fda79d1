"""A flat medium lit at a chosen incidence angle and seen at a chosen view angle: the control that
separates what the light's and the camera's angles do to a region's level from what the surface's
shape does (:mod:`ssskit.pipeline.oblique`).

:func:`flat_scene` is a 200 x 200 x 20 mm slab of the material (top face z = 0) with one point light
far away (:data:`LIGHT_DISTANCE_MM`) at ``incidence_deg`` from the normal, in the x-z plane, and the
camera :data:`CAMERA_DISTANCE_MM` away at ``view_deg`` from the normal, ``azimuth_deg`` around the
normal from the light's side, looking at the origin. Its image (a field of view of
:data:`FIELD_MM` across) lies more than 60 mm inside every edge of the slab: Skin1's red profile holds
99% of its light within 14 mm and its diffusion length is 3.7 mm, so every pixel is a lit plateau of a
semi-infinite flat medium (no shadow, no edge, no transmission through the 20 mm), lit at one angle
and seen at one angle (to within the light's and the camera's finite distances: 0.8 and 2 degrees
across the image). The point light's intensity makes E / pi = 1 at the origin.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import SceneError
from .scenes import COAT_ROUGHNESS, SceneSpec, _T, mitsuba

#: half the slab's side (mm) and its thickness
SLAB_HALF_MM = 100.0
SLAB_THICKNESS_MM = 20.0
#: the point light's and the camera's distance from the origin (mm)
LIGHT_DISTANCE_MM = 1500.0
CAMERA_DISTANCE_MM = 600.0
#: the image's width across the origin (mm, perpendicular to the view)
FIELD_MM = 40.0


def _check_angle(value, name: str, lo: float, hi: float) -> float:
    if isinstance(value, bool) or not (isinstance(value, (int, float, np.integer, np.floating))
                                       and math.isfinite(value) and lo <= value < hi):
        raise SceneError(f"{name} must be a number of degrees in [{lo:g}, {hi:g}), got {value!r}")
    return float(value)


def light_position(incidence_deg: float) -> np.ndarray:
    """Where :func:`flat_scene` puts the point light: (sin, 0, cos) of ``incidence_deg`` x the light's distance."""
    t = math.radians(_check_angle(incidence_deg, "incidence angle", 0.0, 90.0))
    return LIGHT_DISTANCE_MM * np.array([math.sin(t), 0.0, math.cos(t)])


def camera_position(view_deg: float, azimuth_deg: float = 0.0) -> np.ndarray:
    """Where :func:`flat_scene` puts the camera: at ``view_deg`` from the normal, ``azimuth_deg`` about it
    from the light's side (+x), :data:`CAMERA_DISTANCE_MM` from the origin."""
    t = math.radians(_check_angle(view_deg, "view angle", 0.0, 90.0))
    p = math.radians(_check_angle(azimuth_deg, "azimuth", -360.0, 360.0))
    return CAMERA_DISTANCE_MM * np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def flat_scene(incidence_deg: float, view_deg: float = 0.0, azimuth_deg: float = 0.0) -> SceneSpec:
    """The flat medium lit at ``incidence_deg`` and seen at ``view_deg`` (module docstring). Named
    ``flat-i<incidence>-v<view>-a<azimuth>``."""
    light = light_position(incidence_deg)
    eye = camera_position(view_deg, azimuth_deg)
    intensity = math.pi * LIGHT_DISTANCE_MM**2 / math.cos(math.radians(incidence_deg))  # E / pi = 1 at the origin
    # the look-at's up: the normal, unless the camera looks along it
    up = (0.0, 0.0, 1.0) if view_deg >= 1.0 else (0.0, 1.0, 0.0)
    fov = 2.0 * math.degrees(math.atan(FIELD_MM / 2.0 / CAMERA_DISTANCE_MM))
    half, thick = SLAB_HALF_MM, SLAB_THICKNESS_MM
    return SceneSpec(
        f"flat-i{incidence_deg:g}-v{view_deg:g}-a{azimuth_deg:g}",
        f"a flat slab lit at {incidence_deg:g} deg incidence, seen at {view_deg:g} deg ({azimuth_deg:g} deg azimuth)",
        tuple(float(v) for v in eye), (0.0, 0.0, 0.0), up, fov,
        lambda: {"slab": {"type": "cube", "to_world": _T()().translate([0, 0, -thick / 2])
                          @ _T()().scale([half, half, thick / 2])}},
        ("slab",),
        lambda: {"key": {"type": "point", "position": light.tolist(),
                         "intensity": {"type": "rgb", "value": intensity}}},
        orbit_deg_per_frame=0.0)


def rough_dielectric_weights(cos_i, eta: float, alpha: float = COAT_ROUGHNESS, samples: int = 50_000,
                             seed: int = 0, inside: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(mean, standard error), each of shape cos_i.shape + (2,): the light the reference's boundary
    reflects ([..., 0]) and transmits ([..., 1]) at each incidence cosine ``cos_i``, arriving from
    outside (or, ``inside``, from the medium): Mitsuba's ``roughdielectric`` (Beckmann ``alpha``,
    int_ior = ``eta``) sampled ``samples`` times per angle with its own visible-normal routine in
    importance (flux) transport mode, the mean sample weight on each side. 1 minus both is what the
    single-scattering BSDF loses."""
    if not (isinstance(eta, (int, float, np.floating)) and math.isfinite(eta) and eta > 1.0):
        raise SceneError(f"a dielectric boundary needs eta > 1, got {eta!r}")
    if isinstance(samples, bool) or not (isinstance(samples, int) and samples >= 2):
        raise SceneError(f"samples must be an integer >= 2, got {samples!r}")
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


def rough_dielectric_transmittance(cos_i, eta: float, alpha: float = COAT_ROUGHNESS, samples: int = 50_000,
                                   seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(transmittance, standard error) at each incidence cosine ``cos_i`` of the reference's boundary
    for light arriving from outside (:func:`rough_dielectric_weights`). A smooth boundary transmits
    1 - R (Fresnel); a rough one sees the light at the microfacets' own angles, which near grazing
    incidence face the light more than the mean surface does."""
    mean, se = rough_dielectric_weights(cos_i, eta, alpha, samples, seed)
    return mean[..., 1], se[..., 1]


__all__ = ["CAMERA_DISTANCE_MM", "FIELD_MM", "LIGHT_DISTANCE_MM", "SLAB_HALF_MM", "SLAB_THICKNESS_MM",
           "camera_position", "flat_scene", "light_position", "rough_dielectric_transmittance",
           "rough_dielectric_weights"]
