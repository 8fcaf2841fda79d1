"""A scene's thickness: how thick the medium is under each pixel (:func:`chord_thickness`: the chord
through an SSS object along the inward normal of the surface point a pixel sees), at what angle the
light arrives there (:func:`incidence_angle`), and a built-in scene's slab cut to a chosen thickness
(:func:`thin_scene`). Thin media lose through their back the light a semi-infinite one returns; MCML's
finite slab (:mod:`ssskit.profiles.montecarlo.slab`) says how much.

Why the normal and not the refracted view ray: what a thin object loses is the light that diffuses
through to its back (:mod:`ssskit.profiles.montecarlo.slab`); after a reduced mean free path (1.3 mm
in red for Skin1, against the ear's 0-4 mm) a photon's direction is forgotten, and how much of it
reaches the back depends on the distance to the back surface, which for a locally parallel shell is
its thickness along the normal -- the thickness of the slab MCML simulates. The view ray's direction
enters only through the exit's angle; the light's enters through the depth at which it is deposited,
which :func:`incidence_angle` gives the prediction (Skin1, 2 mm: Rd(t) / Rd(inf) in red is 0.76 at
normal incidence and 0.79 at 45 degrees).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..errors import SceneError
from ..quantities import LENGTH_MM, check_shape, checks
from .mitsuba_variant import load_scene
from .scenes import IMAGE_SIZE, SceneSpec, _T, get_scene, mitsuba, scene_camera, scene_lights


def _sss_only(spec: SceneSpec) -> Any:
    shapes = spec.shapes()
    return load_scene({"type": "scene", **{sid: shapes[sid] for sid in spec.sss_shapes}})


def _seen_points(spec: SceneSpec, width: int, height: int, frame: int,
                 mask: np.ndarray | None) -> Iterator[tuple[int, int, Any, np.ndarray, Any]]:
    """Yield (y, x, hit, inward unit normal, Mitsuba scene) for each pixel (of ``mask``) whose centre ray
    hits an SSS object of ``spec`` (``width`` and ``height``: checked by its callers)."""
    if mask is not None:
        mask = check_shape(mask, "mask", (height, width), SceneError, "iufb", bool)
    mi = mitsuba()
    sc = _sss_only(spec)
    cam = scene_camera(spec, width, height, frame)
    eye = np.linalg.inv(cam.world_to_camera)[:3, 3]
    far = cam.unproject(np.ones((height, width)))  # a point on each pixel centre's ray
    ys, xs = np.nonzero(np.ones((height, width), bool) if mask is None else mask)
    for y, x in zip(ys.tolist(), xs.tolist()):
        d = far[y, x] - eye
        si = sc.ray_intersect(mi.Ray3f(mi.ScalarPoint3f(*eye), mi.ScalarVector3f(*(d / np.linalg.norm(d)))))
        if not si.is_valid():
            continue
        n = np.array(si.sh_frame.n, float)
        if np.dot(n, d) < 0:  # the outward normal faces the camera at a seen point: turn it inward
            n = -n
        yield y, x, si, n, sc


@checks(SceneError, **IMAGE_SIZE)  # (before the (height, width) arrays: width -1 was numpy's ValueError)
def chord_thickness(scene: str | SceneSpec, width: int, height: int, frame: int = 0,
                    mask: np.ndarray | None = None) -> np.ndarray:
    """(H, W) float64: per pixel, the length (mm) of the chord through the SSS objects along the inward
    shading normal at the point the pixel's centre ray hits (module docstring); NaN where that ray
    misses every SSS object or the chord does not come out of it (an open mesh). ``mask`` (H, W) bool:
    only those pixels (default: every pixel). The rays are traced by Mitsuba against the SSS shapes
    alone, so an occluder or a backing shell does not cut a chord short."""
    spec = get_scene(scene)
    mi = mitsuba()
    out = np.full((height, width), np.nan)
    for y, x, si, n, sc in _seen_points(spec, width, height, frame, mask):
        back = sc.ray_intersect(si.spawn_ray(mi.ScalarVector3f(*n)))
        if back.is_valid():
            out[y, x] = float(np.linalg.norm(np.array(back.p, float) - np.array(si.p, float)))
    return out


def _light_power(light: dict) -> tuple[np.ndarray, float]:
    """(position, power factor): a point light's intensity, a spherical area light's radiance x pi r^2
    (its irradiance at distance d >> r along cos is that x cos / d^2), the mean over RGB."""
    if light.get("type") == "point":
        return np.asarray(light["position"], float), float(np.mean(light["intensity"]["value"]))
    if light.get("type") == "sphere":
        rad = light["emitter"]["radiance"]["value"]
        return (np.asarray(light.get("center", (0.0, 0.0, 0.0)), float),
                float(np.mean(rad)) * np.pi * float(light.get("radius", 1.0)) ** 2)
    raise SceneError(f"no incidence for a light of type {light.get('type')!r}")


@checks(SceneError, **IMAGE_SIZE)
def incidence_angle(scene: str | SceneSpec, width: int, height: int, frame: int = 0,
                    mask: np.ndarray | None = None) -> np.ndarray:
    """(H, W) float64 degrees: per pixel, the angle between the outward normal at the seen point and the
    direction to the scene's lights, the mean over the lights weighted by the irradiance each would give
    there unshadowed (power x cos / d^2; a light below the surface gives none); NaN where no light is
    above the surface or the pixel's centre ray misses the SSS objects."""
    spec = get_scene(scene)
    lights = [_light_power(L) for L in scene_lights(spec, frame).values()]
    out = np.full((height, width), np.nan)
    for y, x, si, n, _ in _seen_points(spec, width, height, frame, mask):
        p = np.array(si.p, float)
        wsum = asum = 0.0
        for pos, power in lights:
            d = pos - p
            dist = float(np.linalg.norm(d))
            cos = float(np.dot(-n, d)) / dist
            if cos > 0:
                wgt = power * cos / dist**2
                wsum += wgt
                asum += wgt * np.degrees(np.arccos(min(cos, 1.0)))
        if wsum > 0:
            out[y, x] = asum / wsum
    return out


def box_thickness_mm(shape: dict) -> float:
    """The thickness (mm) of a Mitsuba ``cube`` shape along its local z axis: 2 |to_world e_z| (the
    unit cube spans [-1, 1]^3)."""
    m = np.array(shape.get("to_world", _T()()).matrix, dtype=float)
    return 2.0 * float(np.linalg.norm(m[:3, 2]))


def thin_scene(scene: str | SceneSpec, thickness_mm: float) -> SceneSpec:
    """``scene`` with each SSS box (a Mitsuba ``cube``: the slab) cut to ``thickness_mm`` below the face
    at its local +z (the slab's lit top face, which the camera sees): to_world' = to_world .
    translate(0, 0, 1 - s) . scale(1, 1, s), s = thickness / the box's thickness, keeps the local
    z = +1 face and moves the z = -1 face up (module docstring). A SceneError for a scene with no SSS
    box, or a thickness not below the box's. Named ``<name>-t<thickness>``."""
    spec = get_scene(scene)
    base = spec.shapes()
    boxes = [sid for sid in spec.sss_shapes if base[sid].get("type") == "cube"]
    if not boxes:
        raise SceneError(f"scene {spec.name!r} has no SSS box (a Mitsuba cube) to make thinner")
    full = min(box_thickness_mm(base[sid]) for sid in boxes)
    t = float(dataclasses.replace(LENGTH_MM, hi=full, reason=f"thinner than the SSS box's {full:g} mm").check(
        thickness_mm, "the thickness", SceneError))

    def shapes() -> dict[str, dict]:
        d = spec.shapes()
        for sid in boxes:
            s = t / box_thickness_mm(d[sid])
            d[sid] = dict(d[sid], to_world=d[sid].get("to_world", _T()()) @ _T()().translate([0.0, 0.0, 1.0 - s])
                          @ _T()().scale([1.0, 1.0, s]))
        return d

    return dataclasses.replace(spec, name=f"{spec.name}-t{t:g}", description=f"{spec.description}; {t:g} mm thick",
                               shapes=shapes)


__all__ = ["box_thickness_mm", "chord_thickness", "incidence_angle", "thin_scene"]
