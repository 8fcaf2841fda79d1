"""Built-in 3D scenes rendered by Mitsuba 3 (``scalar_rgb``, CPU) into pixel-aligned G-buffers,
and optional path-traced references of the same scenes.

Why Mitsuba 3 and not moderngl: it installs from PyPI with no GPU, display or EGL, its
``scalar_rgb`` variant runs on any CPU, it renders shadows from point and area lights correctly
(ray-traced, not shadow maps), and the same scene description gives the volumetric path-traced
reference (``volpathmis``, homogeneous medium inside a dielectric boundary) that the screen-space
result is compared with.

One world unit is one mm (``world_units_per_mm`` = 1). Layers per scene (section 6 of the
separable-SSS paper splits the frame the same way):

* ``diffuse``: direct lighting of white Lambertian surfaces (radiance E / pi), shadows included;
* ``specular``: the smooth dielectric coating's reflection (Mitsuba ``plastic``, no diffuse part,
  interior index = the material's eta) on SSS objects;
* ``albedo``: the profile's total diffuse reflectance per channel on SSS objects, grey elsewhere;
* ``depth``, ``normal``, ``profile_id``: one sample per pixel from Mitsuba's AOV integrator
  (positions converted to linear camera depth with the camera built from the same look-at).

Camera and light paths (``frame``): the camera orbits the target by ``orbit_deg_per_frame`` and the
lights by ``light_orbit_deg_per_frame`` (the sphere's light moves, so its shadow sweeps the floor);
every G-buffer carries its camera, so :func:`ssskit.screenspace.motion_vectors` gives the
reprojection.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import SsskitError
from ..registry import Registry

FLOOR_ALBEDO = 0.5
#: GGX roughness of the SSS objects' dielectric boundary (specular layer and reference alike);
#: a smooth boundary would show no highlight of a point light.
COAT_ROUGHNESS = 0.15


class SceneError(SsskitError):
    """A scene that cannot be built or rendered (unknown name, renderer missing, bad size)."""


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


SCENES: Registry[SceneSpec] = Registry("scene", SceneError)


def _mi():
    try:
        import mitsuba as mi
    except ImportError:  # pragma: no cover - mitsuba is a core dependency
        raise SceneError("the 3D scenes need Mitsuba 3: pip install mitsuba") from None
    if mi.variant() != "scalar_rgb":
        mi.set_variant("scalar_rgb")
    return mi


def _T():
    return _mi().ScalarTransform4f


def _area_sphere(center, radius, radiance):
    return {"type": "sphere", "center": list(center), "radius": radius,
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": radiance}}}


def _floor(size=400.0, z=0.0):
    return {"type": "rectangle", "to_world": _T()().translate([0, 0, z]) @ _T()().scale([size, size, 1])}


def _ply(name: str, verts: np.ndarray, faces: np.ndarray, normals: np.ndarray | None = None) -> dict:
    """A Mitsuba ``ply`` shape for a triangle mesh, written once to the cache (binary PLY)."""
    from ..io import atomic_output

    verts = np.ascontiguousarray(verts, dtype="<f4")
    faces = np.ascontiguousarray(faces, dtype="<u4")
    cols = [verts] if normals is None else [verts, np.ascontiguousarray(normals, dtype="<f4")]
    vdata = np.concatenate(cols, axis=1).astype("<f4")
    digest = hashlib.sha1(vdata.tobytes() + faces.tobytes()).hexdigest()[:16]
    path = reference_cache_dir().parent / "meshes" / f"{name}-{digest}.ply"
    if not path.is_file():
        props = "property float x\nproperty float y\nproperty float z\n"
        if normals is not None:
            props += "property float nx\nproperty float ny\nproperty float nz\n"
        header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(verts)}\n{props}"
                  f"element face {len(faces)}\nproperty list uchar uint vertex_indices\nend_header\n")
        fdata = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<u4", (3,))])
        fdata["n"] = 3
        fdata["i"] = faces
        with atomic_output(path) as tmp:
            tmp.write_bytes(header.encode() + vdata.tobytes() + fdata.tobytes())
    return {"type": "ply", "filename": str(path), "face_normals": normals is None}


def _grid_faces(rows: int, cols: int) -> np.ndarray:
    idx = np.arange(rows * cols).reshape(rows, cols)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    return np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])


def _bumpy_mesh(n: int = 200, size: float = 40.0, seed: int = 3) -> dict:
    """A heightfield tile (mm) with a gentle swell and pore-scale pits (~0.15 mm deep, ~0.3 mm wide)."""
    rng = np.random.default_rng(seed)
    u = np.linspace(-size / 2, size / 2, n)
    X, Y = np.meshgrid(u, u)
    Z = 1.5 * np.sin(X / 6.0) * np.cos(Y / 7.0)
    for cx, cy in rng.uniform(-size / 2, size / 2, (900, 2)):
        Z -= 0.15 * np.exp(-((X - cx) ** 2 + (Y - cy) ** 2) / (2 * 0.15**2))
    verts = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    return _ply("bumpy", verts, _grid_faces(n, n))


def _ellipsoid_mesh(radii=(18.0, 2.0, 28.0), center=(0.0, 0.0, 32.0), n: int = 96) -> dict:
    """A UV-sphere mesh scaled to an ellipsoid, with smooth normals (an ear-like thin shape)."""
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
    return _ply("ellipsoid", verts, _grid_faces(n, 2 * n)[:, ::-1], normals)


def _register() -> None:
    SCENES.register("sphere", SceneSpec(
        "sphere", "a 30 mm sphere on a plane, soft shadow from a spherical area light",
        (0.0, -160.0, 90.0), (0.0, 0.0, 22.0), (0.0, 0.0, 1.0), 32.0,
        lambda: {"sphere": {"type": "sphere", "center": [0, 0, 30], "radius": 30},
                 "floor": _floor()},
        ("sphere",),
        lambda: {"key": _area_sphere((90, -70, 160), 10, 60.0)}, light_orbit_deg_per_frame=6.0))
    SCENES.register("slab", SceneSpec(
        "slab", "a flat slab seen head-on with a straight hard shadow edge (the paper's Fig. 7 set-up)",
        (0.0, 0.0, 600.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 7.0,
        # the occluder (x from 60 to 330 mm at height 150) is outside the view; the point light at
        # (400, 0, 1000) puts its straight shadow edge on the line x = 0 of the slab's top face
        lambda: {"slab": {"type": "cube", "to_world": _T()().translate([0, 0, -10]) @ _T()().scale([60, 60, 10])},
                 "occluder": {"type": "rectangle",
                              "to_world": _T()().translate([195, 0, 150]) @ _T()().scale([135, 120, 1])}},
        ("slab",),
        lambda: {"key": {"type": "point", "position": [400, 0, 1000], "intensity": {"type": "rgb", "value": 3.0e6}}},
        orbit_deg_per_frame=1.0))
    SCENES.register("ear", SceneSpec(
        "ear", "a thin ear-like flattened ellipsoid (4 mm thick) lit from the side and behind",
        (0.0, -120.0, 40.0), (0.0, 0.0, 30.0), (0.0, 0.0, 1.0), 30.0,
        lambda: {"ear": _ellipsoid_mesh(), "floor": _floor()},
        ("ear",),
        lambda: {"key": _area_sphere((70, 90, 80), 8, 80.0), "fill": _area_sphere((-90, -60, 60), 6, 15.0)}))
    SCENES.register("bumpy", SceneSpec(
        "bumpy", "a 40 mm skin-like tile with pore-scale pits, grazing light",
        (0.0, -45.0, 45.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 40.0,
        lambda: {"bumpy": _bumpy_mesh(), "floor": _floor(z=-3.0)},
        ("bumpy",),
        lambda: {"key": {"type": "point", "position": [80, 20, 25], "intensity": {"type": "rgb", "value": 8.0e3}}}))


_register()


def _orbit(point, spec: SceneSpec, degrees: float) -> np.ndarray:
    """``point`` rotated about the axis through the target along ``up`` (Rodrigues' formula)."""
    target = np.array(spec.target, float)
    up = np.array(spec.up, float) / np.linalg.norm(spec.up)
    ang = math.radians(degrees)
    v = np.asarray(point, float) - target
    v = v * math.cos(ang) + np.cross(up, v) * math.sin(ang) + up * (up @ v) * (1 - math.cos(ang))
    return target + v


def _camera_pose(spec: SceneSpec, frame: int):
    """Origin of the camera orbiting the target about the up axis by frame * orbit_deg_per_frame."""
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


def scene_camera(spec: SceneSpec, width: int, height: int, frame: int = 0):
    """The :class:`Camera` (x right, y down, z forward) matching Mitsuba's look-at sensor."""
    from ..screenspace.gbuffer import Camera

    origin, target, up = _camera_pose(spec, frame)
    f = target - origin
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    d = np.cross(f, r)
    m = np.eye(4)
    m[:3, :3] = np.stack([r, d, f])
    m[:3, 3] = -m[:3, :3] @ origin
    return Camera.from_fov(width, height, spec.fov_x_deg, world_to_camera=m, world_units_per_mm=1.0)


def _sensor(spec: SceneSpec, width: int, height: int, spp: int, seed: int, frame: int) -> dict:
    origin, target, up = _camera_pose(spec, frame)
    return {"type": "perspective", "fov": spec.fov_x_deg, "fov_axis": "x",
            "to_world": _T()().look_at(origin=origin.tolist(), target=target.tolist(), up=up.tolist()),
            "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp, "seed": seed}}


def _scene_dict(spec, width, height, spp, seed, frame, integrator, bsdf_for) -> dict:
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


def _render(scene_dict: dict) -> np.ndarray:
    """Load and render a Mitsuba scene dict; (H, W, C) float32."""
    mi = _mi()
    try:
        scene = mi.load_dict(scene_dict)
    except Exception as exc:  # noqa: BLE001 - Mitsuba raises RuntimeError with its own text
        raise SceneError(f"Mitsuba could not build the scene: {exc}") from None
    return np.array(mi.render(scene), dtype=np.float32)


def _check_size(width: int, height: int) -> None:
    for v, name in ((width, "width"), (height, "height")):
        if not (isinstance(v, (int, np.integer)) and 8 <= v <= 8192):
            raise SceneError(f"image {name} must be an integer in [8, 8192], got {v!r}")


def render_gbuffer(scene: str, albedo, eta: float = 1.4, width: int = 256, height: int = 192, spp: int = 32,
                   seed: int = 0, frame: int = 0, material: str = "material"):
    """Render the named scene's G-buffer (module docstring) with Mitsuba ``scalar_rgb``.

    ``albedo``: (3,) diffuse albedo of the SSS objects (the profile's total reflectance);
    ``eta``: their refractive index (specular coating). Returns a :class:`GBuffer` with profile id 1
    on the SSS objects and ``materials = (material,)``.
    """
    from ..screenspace.gbuffer import GBuffer

    spec = SCENES.get(scene)
    _check_size(width, height)
    if not (isinstance(spp, (int, np.integer)) and spp >= 1):
        raise SceneError(f"samples per pixel must be a positive integer, got {spp!r}")
    alb = np.broadcast_to(np.asarray(albedo, dtype=float), (3,))
    if np.any(alb < 0) or np.any(alb > 1):
        raise SceneError(f"albedo must lie in [0, 1], got {alb.tolist()}")
    white = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 1.0}}
    black = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.0}}
    coat = {"type": "roughplastic", "diffuse_reflectance": {"type": "rgb", "value": 0.0}, "int_ior": float(eta),
            "alpha": COAT_ROUGHNESS}
    direct = {"type": "direct", "emitter_samples": 1, "bsdf_samples": 1}

    diffuse = _render(_scene_dict(spec, width, height, spp, seed, frame, direct, lambda sid: white))
    specular = _render(_scene_dict(spec, width, height, spp, seed + 1, frame, direct,
                                      lambda sid: coat if sid in spec.sss_shapes else black))
    # Mitsuba merges meshes that share a material, so shapes are told apart by an albedo tag in the
    # AOV pass (1 on SSS objects, 0.25 elsewhere, 0 where no surface) rather than by shape index.
    tagged = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.25}}
    aov_int = {"type": "aov", "aovs": "pos:position,nn:sh_normal,alb:albedo"}
    aov = _render(_scene_dict(spec, width, height, 1, seed + 2, frame, aov_int,
                                 lambda sid: white if sid in spec.sss_shapes else tagged))
    pos, normal, tag = aov[..., 0:3], aov[..., 3:6], aov[..., 6]
    hit = tag > 0.1
    sss = tag > 0.6
    cam = scene_camera(spec, width, height, frame)
    cam_pos = pos @ cam.world_to_camera[:3, :3].T + cam.world_to_camera[:3, 3]
    depth = np.where(hit, cam_pos[..., 2], np.inf).astype(np.float32)
    albedo_layer = np.where(sss[..., None], alb.astype(np.float32), np.float32(FLOOR_ALBEDO))
    albedo_layer[~hit] = 0.0
    meta = {"scene": spec.name, "frame": int(frame), "spp": int(spp), "seed": int(seed), "renderer": "mitsuba3 scalar_rgb",
            "eta": float(eta)}
    return GBuffer(diffuse=np.maximum(diffuse[..., :3], 0), albedo=albedo_layer, depth=depth,
                   profile_id=sss.astype(np.uint32), camera=cam, specular=np.maximum(specular[..., :3], 0),
                   normal=np.where(hit[..., None], normal, 0).astype(np.float32), materials=(material,), meta=meta)


def render_sequence(scene: str, albedo, frames: int, **kw) -> list:
    """G-buffers of ``frames`` consecutive frames along the scene's camera orbit (frame index in meta)."""
    if not (isinstance(frames, (int, np.integer)) and frames >= 1):
        raise SceneError(f"frames must be a positive integer, got {frames!r}")
    return [render_gbuffer(scene, albedo, frame=f, **kw) for f in range(frames)]


# ---- path-traced reference ---------------------------------------------------------------------------

def reference_cache_dir() -> Path:
    from ..profiles.montecarlo import cache_dir

    return cache_dir() / "reference"


def render_reference(scene: str, material, width: int = 128, height: int = 96, spp: int = 64, max_depth: int = 1024,
                     seed: int = 0, frame: int = 0, chunk_spp: int = 8, use_cache: bool = True,
                     progress: bool = True) -> np.ndarray:
    """Volumetric path-traced image (H, W, 3) of the scene: the SSS objects are a homogeneous medium
    with the material's sigma_a, sigma_s (mm^-1 = per world unit), Henyey-Greenstein g, inside a
    smooth dielectric of index eta; Mitsuba ``volpathmis`` with a high ``max_depth`` (high-albedo media
    need long random walks). Rendered in chunks of ``chunk_spp`` (progress bar) and cached on disk.
    """
    spec = SCENES.get(scene)
    _check_size(width, height)
    if not (isinstance(spp, (int, np.integer)) and spp >= 1):
        raise SceneError(f"samples per pixel must be a positive integer, got {spp!r}")
    key = json.dumps({"scene": scene, "sa": list(material.sigma_a), "ss": list(material.sigma_s), "g": list(material.g),
                      "eta": material.eta, "w": width, "h": height, "spp": spp, "d": max_depth, "seed": seed,
                      "frame": frame, "v": 2,
                      "geometry": json.dumps([spec.shapes(), spec.lights(), spec.origin, spec.fov_x_deg], default=str)},
                     sort_keys=True)
    path = reference_cache_dir() / f"{scene}-{hashlib.sha1(key.encode()).hexdigest()[:16]}.npy"
    if use_cache and path.is_file():
        return np.load(path)
    g = float(np.mean(material.g))
    sigma_t = np.asarray(material.sigma_a, float) + np.asarray(material.sigma_s, float)
    scale = float(sigma_t.max())
    if scale <= 0:
        raise SceneError("the material has no extinction (sigma_a + sigma_s = 0)")
    single = np.where(sigma_t > 0, np.asarray(material.sigma_s, float) / np.maximum(sigma_t, 1e-300), 0.0)
    # RGB values of a Mitsuba medium must lie in [0, 1]: sigma_t is given relative to its maximum
    medium = {"type": "homogeneous", "sigma_t": {"type": "rgb", "value": (sigma_t / scale).tolist()},
              "albedo": {"type": "rgb", "value": single.tolist()}, "phase": {"type": "hg", "g": g}, "scale": scale}
    boundary = {"type": "roughdielectric", "int_ior": float(material.eta), "ext_ior": float(material.eta_ambient),
                "alpha": COAT_ROUGHNESS}
    grey = {"type": "diffuse", "reflectance": {"type": "rgb", "value": FLOOR_ALBEDO}}

    def bsdf_for(sid):
        return {**boundary, "__medium": medium} if sid in spec.sss_shapes else grey

    integrator = {"type": "volpathmis", "max_depth": int(max_depth)}
    chunks = [chunk_spp] * (spp // chunk_spp) + ([spp % chunk_spp] if spp % chunk_spp else [])
    from tqdm import tqdm

    acc = np.zeros((height, width, 3))
    for i, n in enumerate(tqdm(chunks, desc=f"path tracing {scene} ({spp} spp)", unit="chunk", disable=not progress)):
        img = _render(_scene_dict(spec, width, height, n, seed * 1000 + i, frame, integrator, bsdf_for))
        acc += img[..., :3] * n
    out = (acc / spp).astype(np.float32)
    if use_cache:
        from ..io import atomic_output

        with atomic_output(path) as tmp:
            with open(tmp, "wb") as fh:
                np.save(fh, out)
    return out
