"""The built-in 3D scenes: a registry of :class:`SceneSpec` (geometry, lights, camera look-at), their
camera and light paths over frames, and the Mitsuba 3 scene dictionaries the renderers load.

One world unit is one mm (``world_units_per_mm`` = 1). Camera and light paths (``frame``): the
camera orbits the target about the up axis by ``orbit_deg_per_frame`` and the lights by
``light_orbit_deg_per_frame`` (the sphere's light moves, so its shadow sweeps the floor); every
G-buffer carries its camera, so :func:`ssskit.screenspace.motion_vectors` gives the reprojection.

The SSS objects' boundary is a rough dielectric everywhere it appears (the G-buffer's specular
layer and the path-traced reference alike): Beckmann microfacets with roughness alpha =
:data:`COAT_ROUGHNESS` (Mitsuba ``roughplastic`` with no diffuse part for the specular layer,
``roughdielectric`` around the medium for the reference), interior index = the material's eta.

Why Mitsuba 3 and not moderngl: it installs from PyPI with no GPU, display or EGL, its
``scalar_rgb`` variant runs on any CPU, it renders shadows from point and area lights correctly
(ray-traced, not shadow maps), and the same scene description gives the volumetric path-traced
reference (``volpathmis``).
"""

from __future__ import annotations

import functools
import hashlib
import math
from dataclasses import dataclass
from typing import Any, Callable


import numpy as np
from numpy.typing import ArrayLike

from ..cache import cache_file
from ..errors import SceneError
from ..quantities import SIZE_PX, TYPE, Quantity, fail
from ..io import atomic_output
from ..registry import Registry
from ..screenspace.camera import Camera
from ..settings import SIZE_RANGE
from .meshes import ply_bytes
from .mitsuba_variant import interruptible_render, load_scene, mitsuba, render_threads

#: diffuse albedo of everything that is not an SSS object (floors, occluders)
FLOOR_ALBEDO = 0.5
#: Beckmann roughness alpha of the SSS objects' rough dielectric boundary (specular layer and
#: reference alike; Mitsuba's rough BSDFs default to Beckmann); a smooth boundary would show no
#: highlight of a point light.
COAT_ROUGHNESS = 0.15
#: image sizes the renderers accept (pixels per side): ssskit.settings.SIZE_RANGE
IMAGE_SIDE = SIZE_PX.within(*SIZE_RANGE)
#: a rendered image's width and height, as a function declares them (:func:`ssskit.quantities.checks`)
IMAGE_SIZE: dict[str, Any] = {"width": (IMAGE_SIDE, "image width"), "height": (IMAGE_SIDE, "image height")}


@dataclass(frozen=True)
class SceneSpec:
    """A built-in scene: camera look-at, field of view, lights and shapes (Mitsuba dicts)."""

    name: str
    description: str
    origin: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float]
    fov_x_deg: float
    shapes: Callable[[], dict[str, dict]]  # id -> Mitsuba shape dict without bsdf
    sss_shapes: tuple[str, ...]
    lights: Callable[[], dict[str, dict]]
    orbit_deg_per_frame: float = 2.0
    light_orbit_deg_per_frame: float = 0.0  # lights orbit the target about the up axis
    #: one material (preset name or material file) per SSS shape, "" for the render's own material;
    #: empty: every SSS shape takes the render's material. SSS shape i has profile id i + 1 either way.
    sss_materials: tuple[str, ...] = ()
    #: why the path-traced reference cannot render this scene (an open or non-manifold SSS mesh), or None
    reference_problem: str | None = None
    #: whether the scene's only light is behind its SSS object (seen from the camera): its front is unlit,
    #: so its frame shows nothing but the light the transmittance pass adds (``--transmission auto`` runs
    #: that pass for such a scene: :func:`ssskit.pipeline.transmission.transmission_runs`)
    lit_from_behind: bool = False
    #: what a user must be told of the scene: (key, value) pairs, e.g. the head scan's ``attribution``, ``licence``
    #: and ``mm_per_unit`` (:mod:`ssskit.scenes.head`); reported beside every result (``ssskit render --json``)
    about: tuple[tuple[str, Any], ...] = ()
    #: named cameras (name, (origin, target, up, fov_x_deg)) that ``--view NAME`` picks (the head's close, ear, front)
    views: tuple[tuple[str, tuple], ...] = ()
    #: the image's sub-pixel offset (x right, y down, in pixels): the jittered projection a TAA renders each
    #: frame with (Karis 2014; Mitsuba's principal point offset, a fraction of the film); (0, 0): none. The
    #: G-buffer's camera stays the unjittered one, as a TAA's motion vectors leave the jitter out
    pixel_jitter: tuple[float, float] = (0.0, 0.0)

    def shape_materials(self, default: str) -> tuple[str, ...]:
        """The material of each SSS shape (profile id i + 1 is ``sss_shapes[i]``), ``default`` where the
        scene names none."""
        mats = self.sss_materials or ("",) * len(self.sss_shapes)
        return tuple(m or default for m in mats)


SCENES: Registry[SceneSpec] = Registry("scene", SceneError)


def get_scene(scene: str | SceneSpec) -> SceneSpec:
    """A built-in scene by name (:data:`SCENES`), or ``scene`` itself when it already is a
    :class:`SceneSpec` (a variant such as :func:`ssskit.scenes.thickness.thin_scene`'s)."""
    return scene if isinstance(scene, SceneSpec) else SCENES.get(scene)


def front_lit_scenes() -> list[str]:
    """The built-in scenes a reflectance pass is measured on: all but those lit only from behind
    (:attr:`SceneSpec.lit_from_behind`), whose front is black without the transmittance pass (the demo's
    screen-space and Burley tables; the back-lit ones are the transmission section's)."""
    return [name for name in SCENES.names() if not SCENES.get(name).lit_from_behind]


def _T():
    return mitsuba().ScalarTransform4f


# ---- geometry ----------------------------------------------------------------------------------------

def _ply(name: str, verts: np.ndarray, faces: np.ndarray, normals: np.ndarray | None = None,
         face_normals: bool | None = None, deferred: list[Callable[[], None]] | None = None) -> dict:
    """A Mitsuba ``ply`` shape for a triangle mesh, written once to the ``meshes`` cache (binary PLY,
    named by a digest of the arrays). ``face_normals`` (default: when no normals are given) shades
    with the faces' normals; otherwise Mitsuba interpolates the given or its own smooth vertex normals.
    ``deferred``: the write is appended there instead of done now (a scene file writes its meshes only once
    every check of the file has passed: nothing is written for a file that is refused)."""
    verts = np.ascontiguousarray(verts, dtype="<f4")
    faces = np.ascontiguousarray(faces, dtype="<u4")
    cols = [verts] if normals is None else [verts, np.ascontiguousarray(normals, dtype="<f4")]
    vdata = np.concatenate(cols, axis=1).astype("<f4")
    digest = hashlib.sha1(vdata.tobytes() + faces.tobytes()).hexdigest()[:16]
    path = cache_file("meshes", name, digest, ".ply")

    def write() -> None:
        if not path.is_file():
            with atomic_output(path) as tmp:
                tmp.write_bytes(ply_bytes(verts, faces, normals))

    if deferred is None:
        write()
    else:
        deferred.append(write)
    return {"type": "ply", "filename": str(path), "face_normals": normals is None if face_normals is None
            else bool(face_normals)}


def _grid_faces(rows: int, cols: int) -> np.ndarray:
    idx = np.arange(rows * cols).reshape(rows, cols)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    return np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])


@functools.lru_cache(maxsize=None)
def _bumpy_geometry(n: int = 200, size: float = 40.0, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of a heightfield tile (mm) with a gentle swell and pore-scale pits (~0.15 mm
    deep, ~0.3 mm wide); computed once per process (every scene dict and cache key needs it)."""
    rng = np.random.default_rng(seed)
    u = np.linspace(-size / 2, size / 2, n)
    X, Y = np.meshgrid(u, u)
    Z = 1.5 * np.sin(X / 6.0) * np.cos(Y / 7.0)
    for cx, cy in rng.uniform(-size / 2, size / 2, (900, 2)):
        Z -= 0.15 * np.exp(-((X - cx) ** 2 + (Y - cy) ** 2) / (2 * 0.15**2))
    verts = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    return _frozen(verts), _frozen(_grid_faces(n, n))


@functools.lru_cache(maxsize=None)
def _ellipsoid_geometry(radii: tuple[float, float, float] = (18.0, 2.0, 28.0),
                        center: tuple[float, float, float] = (0.0, 0.0, 32.0),
                        n: int = 96) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices, faces and smooth normals of a UV-sphere mesh scaled to an ellipsoid (an ear-like thin
    shape); computed once per process."""
    th = np.linspace(0, np.pi, n)
    ph = np.linspace(0, 2 * np.pi, 2 * n)
    T, P = np.meshgrid(th, ph, indexing="ij")
    unit = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1).reshape(-1, 3)
    r = np.asarray(radii)
    verts = unit * r + np.asarray(center)
    normals = unit / r
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    # (theta, phi) grid faces wind inward; reversed, their geometric normals point out of the medium,
    # which is what Mitsuba's interior/exterior media test uses
    return _frozen(verts), _frozen(_grid_faces(n, 2 * n)[:, ::-1]), _frozen(normals)


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


# the built-in scenes are scene files (src/ssskit/scenes/builtin/*.toml), registered by .scenefile


# ---- camera and light paths ----------------------------------------------------------------------------

def _orbit(point: ArrayLike, spec: SceneSpec, degrees: float) -> np.ndarray:
    """``point`` rotated about the axis through the target along ``up`` (Rodrigues' formula)."""
    target = np.array(spec.target, float)
    up = np.array(spec.up, float) / np.linalg.norm(spec.up)
    ang = math.radians(degrees)
    v = np.asarray(point, float) - target
    v = v * math.cos(ang) + np.cross(up, v) * math.sin(ang) + up * (up @ v) * (1 - math.cos(ang))
    return target + v


def camera_pose(spec: SceneSpec, frame: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(origin, target, up) of the camera orbiting the target about the up axis by
    frame * orbit_deg_per_frame."""
    up = np.array(spec.up, float) / np.linalg.norm(spec.up)
    return _orbit(spec.origin, spec, spec.orbit_deg_per_frame * frame), np.array(spec.target, float), up


def scene_lights(spec: SceneSpec, frame: int = 0) -> dict[str, dict]:
    """The scene's lights at ``frame``: point positions and sphere centres orbit the target by
    frame * light_orbit_deg_per_frame."""
    lights = spec.lights()
    deg = spec.light_orbit_deg_per_frame * frame
    if deg == 0:
        return lights
    for light in lights.values():
        for key in ("position", "center"):
            if key in light:
                light[key] = _orbit(light[key], spec, deg).tolist()
    return lights


def scene_camera(spec: SceneSpec, width: int, height: int, frame: int = 0) -> Camera:
    """The :class:`Camera` (x right, y down, z forward) matching Mitsuba's look-at sensor at ``frame``."""
    origin, target, up = camera_pose(spec, frame)
    f = target - origin
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    d = np.cross(f, r)
    m = np.eye(4)
    m[:3, :3] = np.stack([r, d, f])
    m[:3, 3] = -m[:3, :3] @ origin
    return Camera.from_fov(width, height, spec.fov_x_deg, world_to_camera=m, world_units_per_mm=1.0)


# ---- Mitsuba scene dictionaries --------------------------------------------------------------------------

#: samples per pixel of a Mitsuba render (any budget: a reference's as well as a G-buffer's)
RENDER_SPP = Quantity("spp", 1, math.inf, "", "samples per pixel", integer=True, hi_open=True)


def per_shape(name: str, value: Any, n: int, one: Callable[[Any], bool]) -> tuple:
    """``value`` for each of a scene's ``n`` SSS shapes: one for all (where ``one(value)``) or a sequence of ``n``,
    else a SceneError in the type wording."""
    values = (value,) * n if one(value) else tuple(value)
    if len(values) != n:
        raise fail(SceneError, TYPE, name=name, kind=f"one, or one per SSS shape ({n})", actual=f"{len(values)}")
    return values


#: Mitsuba's perspective sensor's default clip planes (world units: mm), kept wherever they hold the scene
NEAR_CLIP, FAR_CLIP = 1e-2, 1e4


def clip_planes(distance: float) -> tuple[float, float]:
    """(near_clip, far_clip) of a camera ``distance`` (world mm) from its target: Mitsuba's defaults
    (:data:`NEAR_CLIP`, :data:`FAR_CLIP`) unless the scene's size needs more, then scaled with the distance
    (near 1e-3 d, far 10 d). An automatically framed model of radius R is seen from d = 5.6 k R (docs/meshes.md
    "Camera and lights") and lies between d - R and d + R, so a model of 40 m (d = 112 m, beyond the default
    far plane of 10 m) no longer renders black, nor a 4 m one clipped; the built-in scenes (d < 1 m) keep
    the defaults, hence their images."""
    d = float(distance)
    return min(NEAR_CLIP, 1e-3 * d), max(FAR_CLIP, 10.0 * d)


def _sensor(spec: SceneSpec, width: int, height: int, spp: int, seed: int, frame: int) -> dict:
    origin, target, up = camera_pose(spec, frame)
    near, far = clip_planes(float(np.linalg.norm(target - origin)))
    sensor = {"type": "perspective", "fov": spec.fov_x_deg, "fov_axis": "x", "near_clip": near, "far_clip": far,
              "to_world": _T()().look_at(origin=origin.tolist(), target=target.tolist(), up=up.tolist()),
              "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                       "pixel_format": "rgb"},
              "sampler": {"type": "independent", "sample_count": spp, "seed": seed}}
    jx, jy = spec.pixel_jitter
    if jx or jy:  # pixel (i, j) sees what (i + jx, j + jy) sees unjittered (tests/scenes/test_scenes.py)
        sensor.update(principal_point_offset_x=float(jx) / width, principal_point_offset_y=float(jy) / height)
    return sensor


def scene_dict(spec: SceneSpec, width: int, height: int, spp: int, seed: int, frame: int, integrator: dict,
               bsdf_for: Callable[[str], dict]) -> dict:
    """The Mitsuba scene dict of ``spec`` at ``frame``: ``bsdf_for(shape id)`` gives each shape's BSDF
    (a ``__medium`` entry becomes the shape's interior medium)."""
    d = {"type": "scene", "integrator": integrator, "sensor": _sensor(spec, width, height, spp, seed, frame)}
    for sid, shape in spec.shapes().items():
        entry = dict(shape)
        props = dict(bsdf_for(sid))
        if "__medium" in props:
            entry["interior"] = props.pop("__medium")
        if props:
            entry["bsdf"] = props
        d[sid] = entry
    d.update(scene_lights(spec, frame))
    return d


def render_dict(scene: dict) -> np.ndarray:
    """Load and render a Mitsuba scene dict; (H, W, C) float32."""
    loaded = load_scene(scene)
    with render_threads():
        return np.array(interruptible_render(loaded), dtype=np.float32)
