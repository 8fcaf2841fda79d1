"""A scene from its light: the translucency shadow map (light-space depth, Jimenez et al. 2010 [JWSG10]
Sec. 3) ray-cast by Mitsuba for a built-in scene, and the exact thickness along the light at the points
the camera sees, so the map's thickness (:func:`ssskit.screenspace.transmission.thickness_from_map`, the
pass's steps 1-2) can be measured against it.

The light view is orthographic (a directional light's map) along the direction from the scene's first
light to the centre of its SSS objects' bounding box, covering the box; depths are distances along that
direction (mm). The truth per seen point p: the ray from p towards the light, traced through the SSS
shapes alone; ``through`` is the distance to its last hit (the first surface the light meets: what an
infinitely fine map gives, z - D), ``chord`` the sum of the segments inside the medium (the two differ
where the light's path leaves and re-enters the object, e.g. between an ear's folds). Zero where p is
itself the first surface the light meets.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..screenspace.transmission import LightView
from .scenes import SceneSpec, get_scene, mitsuba, scene_lights
from .thickness import _seen_points, _sss_only


def scene_light_view(scene: str | SceneSpec, resolution: int | tuple[int, int], frame: int = 0) -> LightView:
    """The orthographic view from ``scene``'s first light onto its SSS objects (module docstring)."""
    spec = get_scene(scene)
    sc = _sss_only(spec)
    box = sc.bbox()
    lo, hi = np.array(box.min, float), np.array(box.max, float)
    centre = 0.5 * (lo + hi)
    light = next(iter(scene_lights(spec, frame).values()))
    pos = np.asarray(light.get("position", light.get("center", (0.0, 0.0, 0.0))), float)
    extent = float(np.linalg.norm(hi - lo)) * 1.05
    return LightView.looking_along(centre - pos, centre, extent, resolution,
                                   distance_mm=float(np.linalg.norm(centre - pos)))


def depth_map(scene: str | SceneSpec, view: LightView) -> np.ndarray:
    """(H, W) float64 light-space depth (mm along the light) of the first SSS surface per texel centre;
    inf where the texel's ray meets none."""
    mi = mitsuba()
    sc = _sss_only(get_scene(scene))
    origins, d = view.texel_rays()
    w, h = view.size
    out = np.full((h, w), np.inf)
    dv = mi.ScalarVector3f(*d)
    for y in range(h):
        for x in range(w):
            si = sc.ray_intersect(mi.Ray3f(mi.ScalarPoint3f(*origins[y, x]), dv))
            if si.is_valid():
                out[y, x] = float(np.dot(np.array(si.p, float) - np.asarray(view.origin), d))
    return out


#: how far along the ray the next trace starts past a hit (mm). Mitsuba's ``spawn_ray`` offsets the origin
#: along the normal instead (about 5e-3 mm at 60 mm from the origin), which at a grazing ray is a chord
#: through a different part of the object (0.5 mm against 0.8 mm on the sphere); along the ray the
#: offset stays on the same line
RAY_STEP_MM = 1e-3


def _towards_light(mi: Any, sc: Any, si: Any, d: np.ndarray) -> tuple[float, float]:
    """(through, chord) from a surface hit towards the light (module docstring)."""
    back = mi.ScalarVector3f(*(-d))
    p0 = np.array(si.p, float)
    through = chord = 0.0
    n = np.array(si.n, float)
    inside = bool(np.dot(n, -d) < 0)  # the outward normal faces away from the light: the ray goes in
    last = p0
    for _ in range(64):
        nxt = sc.ray_intersect(mi.Ray3f(mi.ScalarPoint3f(*(last - RAY_STEP_MM * d)), back))
        if not nxt.is_valid():
            break
        q = np.array(nxt.p, float)
        if inside:
            chord += float(np.linalg.norm(q - last))
        inside = not inside
        last = q
        through = float(np.linalg.norm(q - p0))
    return through, chord


def seen_truth(scene: str | SceneSpec, view: LightView, width: int, height: int,
               frame: int = 0) -> dict[str, np.ndarray]:
    """For each pixel whose centre ray meets an SSS object: ``points`` (N, 3) world mm, ``through`` and
    ``chord`` (N,) mm (module docstring), ``pixels`` (N, 2) (y, x)."""
    mi = mitsuba()
    spec = get_scene(scene)
    d = np.asarray(view.direction, float)
    pts, thr, chd, pix = [], [], [], []
    for y, x, si, _n, sc in _seen_points(spec, width, height, frame, None):
        t, c = _towards_light(mi, sc, si, d)
        pts.append(np.array(si.p, float))
        thr.append(t)
        chd.append(c)
        pix.append((y, x))
    return {"points": np.array(pts).reshape(-1, 3), "through": np.array(thr), "chord": np.array(chd),
            "pixels": np.array(pix, int).reshape(-1, 2)}




def light_layers(scene: str | SceneSpec, width: int, height: int, frame: int = 0) -> tuple[np.ndarray, dict]:
    """The G-buffer's optional light layers (:mod:`ssskit.screenspace.gbuffer`): the ray-cast map at the
    frame's size and the projection's JSON with ``irradiance``, the first light's power x 1 / d^2 at the
    SSS objects' centre (a point light's intensity; a spherical light's radiance x pi r^2), grey."""
    from .thickness import _light_power

    spec = get_scene(scene)
    view = scene_light_view(spec, (width, height), frame)
    light = next(iter(scene_lights(spec, frame).values()))
    pos, power = _light_power(light)
    box = _sss_only(spec).bbox()
    centre = 0.5 * (np.array(box.min, float) + np.array(box.max, float))
    e = power / float(np.sum((centre - pos) ** 2))
    return depth_map(spec, view), {**view.to_dict(), "irradiance": [e, e, e]}


__all__ = ["depth_map", "light_layers", "scene_light_view", "seen_truth"]
