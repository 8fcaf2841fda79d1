"""A flat medium lit at a chosen incidence angle and seen at a chosen view angle: the control that
separates what the light's and the camera's angles do to a region's level from what the surface's
shape does (:mod:`lab.oblique`).

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

from ssskit.errors import SceneError
from ssskit.scenes.boundary import rough_dielectric_transmittance, rough_dielectric_weights
from ssskit.scenes.scenes import SceneSpec, _T

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


__all__ = ["CAMERA_DISTANCE_MM", "FIELD_MM", "LIGHT_DISTANCE_MM", "SLAB_HALF_MM", "SLAB_THICKNESS_MM",
           "camera_position", "flat_scene", "light_position", "rough_dielectric_transmittance",
           "rough_dielectric_weights"]

# the references' boundary as Mitsuba samples it lives in the product (ssskit.scenes.boundary); re-exported
# here for the experiments that use it beside the flat scene
