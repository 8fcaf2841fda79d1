"""G-buffers: the per-pixel inputs of a screen-space SSS pass, and their multi-layer EXR files.

Layers (all pixel-aligned, shape (H, W[, 3])):

* ``diffuse``   linear-light diffuse lighting of a white Lambertian surface (RGB), the signal the
  SSS pass blurs (the "irradiance" buffer of Jimenez et al. 2009 / separable-SSS paper section 6);
* ``specular``  linear-light specular reflection (RGB), added after the blur;
* ``albedo``    diffuse albedo (RGB), multiplied after the blur;
* ``depth``     linear camera-space depth z in world units (> 0; +inf where no surface);
* ``normal``    world-space unit normals (RGB; zero where no surface);
* ``profile_id`` uint32: 0 = no SSS (stencil culled), k >= 1 = the k-th entry of ``materials``.

A :class:`Camera` holds what the pass needs to turn a width in mm into pixels: focal lengths in
pixels (fx, fy; fx != fy for non-square pixels), the principal point, the world-to-camera matrix
(camera looks down +z, x right, y down, so pixel (u, v) = (fx x/z + cx, fy y/z + cy)), and
``world_units_per_mm``.

EXR files are written and read with the official OpenEXR Python bindings (imageio writes TIFF bytes
into .exr files). The camera and material list travel as string attributes of the header.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SsskitError
from ..io import atomic_output, check_suffix

LAYERS = ("diffuse", "specular", "albedo", "depth", "normal", "profile_id")


class GBufferError(SsskitError):
    """A G-buffer or G-buffer file that cannot be used (the message names the layer)."""


@dataclass(frozen=True)
class Camera:
    """Pinhole camera: intrinsics in pixels, world-to-camera matrix, and the scene's unit scale."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    world_to_camera: np.ndarray = field(default_factory=lambda: np.eye(4))
    world_units_per_mm: float = 1.0

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            v = getattr(self, name)
            if not (isinstance(v, (int, np.integer)) and v >= 1):
                raise GBufferError(f"camera: {name} must be a positive integer, got {v!r}")
        for name in ("fx", "fy", "world_units_per_mm"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v > 0):
                raise GBufferError(f"camera: {name} must be a positive finite number, got {v!r}")
        m = np.asarray(self.world_to_camera, dtype=float)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise GBufferError(f"camera: world_to_camera must be a finite 4x4 matrix, got shape {m.shape}")
        object.__setattr__(self, "world_to_camera", m)
        for name in ("fx", "fy", "cx", "cy", "world_units_per_mm"):
            object.__setattr__(self, name, float(getattr(self, name)))

    @classmethod
    def from_fov(cls, width: int, height: int, fov_x_deg: float, pixel_aspect: float = 1.0,
                 world_to_camera=None, world_units_per_mm: float = 1.0) -> "Camera":
        """A camera with horizontal field of view ``fov_x_deg``; ``pixel_aspect`` = pixel height / width.

        fx = (W/2) / tan(fov_x/2); fy = fx / pixel_aspect (a pixel that is taller than wide covers
        more of the scene vertically, so fewer pixels per unit length).
        """
        if not (0 < fov_x_deg < 180):
            raise GBufferError(f"camera: field of view must lie in (0, 180) degrees, got {fov_x_deg!r}")
        if not (pixel_aspect > 0 and math.isfinite(pixel_aspect)):
            raise GBufferError(f"camera: pixel aspect must be positive, got {pixel_aspect!r}")
        fx = 0.5 * width / math.tan(math.radians(fov_x_deg) / 2.0)
        return cls(int(width), int(height), fx, fx / pixel_aspect, width / 2.0, height / 2.0,
                   np.eye(4) if world_to_camera is None else world_to_camera, world_units_per_mm)

    @property
    def pixel_aspect(self) -> float:
        """Pixel height / pixel width (1 for square pixels)."""
        return self.fx / self.fy

    @property
    def aspect(self) -> float:
        """Image aspect ratio of the viewed region, width / height in scene units."""
        return (self.width / self.fx) / (self.height / self.fy)

    def projection_matrix(self, near: float = 0.01, far: float = 1000.0) -> np.ndarray:
        """OpenGL-style 4x4 projection (camera looking down -z, y up) equivalent to these intrinsics."""
        p = np.zeros((4, 4))
        p[0, 0] = 2.0 * self.fx / self.width
        p[1, 1] = 2.0 * self.fy / self.height
        p[0, 2] = 1.0 - 2.0 * self.cx / self.width
        p[1, 2] = 2.0 * self.cy / self.height - 1.0
        p[2, 2] = -(far + near) / (far - near)
        p[2, 3] = -2.0 * far * near / (far - near)
        p[3, 2] = -1.0
        return p

    def pixels_per_mm(self, depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Horizontal and vertical pixels per mm of surface at linear depth ``depth`` (world units),
        for a fronto-parallel surface: f * world_units_per_mm / z."""
        z = np.asarray(depth, dtype=float)
        return self.fx * self.world_units_per_mm / z, self.fy * self.world_units_per_mm / z

    def project(self, points_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (..., 2) (u, v; pixel centres at integer + 0.5) and depth z of world points."""
        p = np.asarray(points_world, dtype=float)
        cam = p @ self.world_to_camera[:3, :3].T + self.world_to_camera[:3, 3]
        z = cam[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([self.fx * cam[..., 0] / z + self.cx, self.fy * cam[..., 1] / z + self.cy], axis=-1)
        return uv, z

    def unproject(self, depth: np.ndarray) -> np.ndarray:
        """World positions (H, W, 3) of the pixel centres at linear depth ``depth`` (H, W)."""
        z = np.asarray(depth, dtype=float)
        v, u = np.mgrid[0:z.shape[0], 0:z.shape[1]] + 0.5
        cam = np.stack([(u - self.cx) / self.fx * z, (v - self.cy) / self.fy * z, z], axis=-1)
        inv = np.linalg.inv(self.world_to_camera)
        return cam @ inv[:3, :3].T + inv[:3, 3]

    def to_dict(self) -> dict[str, Any]:
        return {"width": self.width, "height": self.height, "fx": self.fx, "fy": self.fy, "cx": self.cx,
                "cy": self.cy, "world_to_camera": self.world_to_camera.tolist(),
                "world_units_per_mm": self.world_units_per_mm}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Camera":
        try:
            return cls(int(d["width"]), int(d["height"]), float(d["fx"]), float(d["fy"]), float(d["cx"]),
                       float(d["cy"]), np.array(d["world_to_camera"], dtype=float), float(d["world_units_per_mm"]))
        except (KeyError, TypeError, ValueError) as exc:
            if isinstance(exc, GBufferError):
                raise
            raise GBufferError(f"camera: not an ssskit camera record ({exc})") from None


def motion_vectors(depth: np.ndarray, camera: Camera, previous: Camera) -> np.ndarray:
    """Screen-space motion (H, W, 2) in pixels, from this frame's pixel to where the same world point
    was in ``previous`` (static scene): what temporal reprojection needs. Zero where depth is inf."""
    z = np.asarray(depth, dtype=float)
    finite = np.isfinite(z)
    world = camera.unproject(np.where(finite, z, 1.0))
    uv_prev, _ = previous.project(world)
    v, u = np.mgrid[0:z.shape[0], 0:z.shape[1]] + 0.5
    mv = uv_prev - np.stack([u, v], axis=-1)
    mv[~finite] = 0.0
    return mv


@dataclass(frozen=True, eq=False)
class GBuffer:
    """Validated, pixel-aligned layers (see the module docstring) plus camera and material names."""

    diffuse: np.ndarray
    albedo: np.ndarray
    depth: np.ndarray
    profile_id: np.ndarray
    camera: Camera
    specular: np.ndarray | None = None
    normal: np.ndarray | None = None
    materials: tuple[str, ...] = ()
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        diffuse = _float_layer("diffuse", self.diffuse, rgb=True)
        h, w = diffuse.shape[:2]
        layers = {"diffuse": diffuse}
        for name in ("specular", "albedo", "normal"):
            value = getattr(self, name)
            if value is None:
                value = np.zeros((h, w, 3), np.float32)
            layers[name] = _float_layer(name, value, rgb=True)
        layers["depth"] = _float_layer("depth", self.depth, rgb=False, allow_inf=True)
        layers["profile_id"] = _id_layer(self.profile_id)
        for name, arr in layers.items():
            if arr.shape[:2] != (h, w):
                raise GBufferError(f"layer {name!r} has shape {arr.shape[:2]}, but 'diffuse' is {(h, w)}")
        depth = layers["depth"]
        if np.any(depth <= 0):
            raise GBufferError("layer 'depth' must be positive (linear camera-space depth), found values <= 0")
        if not np.all(np.isfinite(depth[layers["profile_id"] > 0])):
            raise GBufferError("layer 'depth' is infinite on pixels whose 'profile_id' marks SSS")
        if np.any(layers["diffuse"] < 0):
            raise GBufferError("layer 'diffuse' has negative values (it must be linear-light radiance)")
        if not isinstance(self.camera, Camera):
            raise GBufferError(f"camera must be a Camera, got {type(self.camera).__name__}")
        if (self.camera.width, self.camera.height) != (w, h):
            raise GBufferError(f"camera is {self.camera.width}x{self.camera.height} but the layers are {w}x{h}")
        mats = tuple(str(m) for m in self.materials)
        top = int(layers["profile_id"].max(initial=0))
        if top > len(mats) and mats:
            raise GBufferError(f"layer 'profile_id' uses id {top} but only {len(mats)} materials are named")
        for name, arr in layers.items():
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "materials", mats)

    @property
    def shape(self) -> tuple[int, int]:
        return tuple(self.depth.shape)

    @property
    def mask(self) -> np.ndarray:
        """Pixels that receive SSS (profile_id > 0), (H, W) bool."""
        return self.profile_id > 0

    def with_layers(self, **layers) -> "GBuffer":
        return replace(self, **layers)

    def composite(self, diffuse: np.ndarray | None = None) -> np.ndarray:
        """Final linear image: albedo * diffuse + specular (separable-SSS paper section 6), (H, W, 3).

        ``diffuse`` is the (blurred) diffuse layer; by default the unblurred one.
        """
        d = self.diffuse if diffuse is None else np.asarray(diffuse, dtype=np.float32)
        if d.shape != self.diffuse.shape:
            raise GBufferError(f"diffuse to composite has shape {d.shape}, expected {self.diffuse.shape}")
        return self.albedo * d + self.specular

    # ---- EXR ---------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write a multi-layer EXR (float32 layers, uint32 ids, ZIP), atomically."""
        check_suffix(path, (".exr",), "G-buffer file")
        import OpenEXR

        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                  "ssskit_camera": json.dumps(self.camera.to_dict()),
                  "ssskit_materials": json.dumps(list(self.materials)),
                  "ssskit_meta": json.dumps(self.meta, default=str)}
        channels = {name: np.ascontiguousarray(getattr(self, name)) for name in LAYERS}
        with atomic_output(path) as tmp:
            with OpenEXR.File(header, channels) as f:
                f.write(str(tmp))

    @classmethod
    def load(cls, path: str | Path) -> "GBuffer":
        """Read a G-buffer EXR written by :meth:`save` or by any tool using the same layer names.

        ``specular`` and ``normal`` are optional (zero when missing); the camera header attribute is
        required unless ``camera`` is given to :func:`load_gbuffer`.
        """
        return load_gbuffer(path)


def load_gbuffer(path: str | Path, camera: Camera | None = None) -> GBuffer:
    """:meth:`GBuffer.load`, optionally supplying the camera for EXRs made by other tools."""
    p = Path(path)
    if not p.is_file():
        raise GBufferError(f"G-buffer file {str(p)!r} does not exist")
    import OpenEXR

    try:
        if not OpenEXR.isOpenExrFile(str(p)):
            raise GBufferError(f"{str(p)!r} is not an OpenEXR file")
        with OpenEXR.File(str(p)) as f:
            header = dict(f.header())
            channels = {name: ch.pixels for name, ch in f.channels().items()}
    except GBufferError:
        raise
    except Exception as exc:  # the bindings raise RuntimeError / ValueError with C++ text
        raise GBufferError(f"cannot read G-buffer {str(p)!r}: {exc}") from None
    for name in ("diffuse", "albedo", "depth", "profile_id"):
        if name not in channels:
            raise GBufferError(f"G-buffer {str(p)!r} has no layer {name!r} (found: {', '.join(sorted(channels))})")
    if camera is None:
        if "ssskit_camera" not in header:
            raise GBufferError(f"G-buffer {str(p)!r} has no 'ssskit_camera' header attribute; pass a camera")
        try:
            camera = Camera.from_dict(json.loads(header["ssskit_camera"]))
        except json.JSONDecodeError:
            raise GBufferError(f"G-buffer {str(p)!r}: header 'ssskit_camera' is not JSON") from None
    try:
        materials = tuple(json.loads(header.get("ssskit_materials", "[]")))
        meta = json.loads(header.get("ssskit_meta", "{}"))
    except json.JSONDecodeError:
        raise GBufferError(f"G-buffer {str(p)!r}: material or meta header attribute is not JSON") from None
    return GBuffer(diffuse=channels["diffuse"], albedo=channels["albedo"], depth=channels["depth"],
                   profile_id=channels["profile_id"], camera=camera, specular=channels.get("specular"),
                   normal=channels.get("normal"), materials=materials, meta=meta)


def _float_layer(name: str, value, rgb: bool, allow_inf: bool = False) -> np.ndarray:
    arr = np.asarray(value)
    if not np.issubdtype(arr.dtype, np.floating):
        raise GBufferError(f"layer {name!r} must be floating point (half or float), got {arr.dtype}")
    want = 3 if rgb else 2
    if arr.ndim != want or (rgb and arr.shape[2] != 3):
        raise GBufferError(f"layer {name!r} must have shape {'(H, W, 3)' if rgb else '(H, W)'}, got {arr.shape}")
    if arr.shape[0] < 1 or arr.shape[1] < 1:
        raise GBufferError(f"layer {name!r} is empty")
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    if np.any(np.isnan(arr)):
        raise GBufferError(f"layer {name!r} contains NaN")
    if not allow_inf and not np.all(np.isfinite(arr)):
        raise GBufferError(f"layer {name!r} contains infinity")
    return arr


def _id_layer(value) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype == bool:
        arr = arr.astype(np.uint32)
    if not np.issubdtype(arr.dtype, np.integer):
        raise GBufferError(f"layer 'profile_id' must be an integer (uint32) layer, got {arr.dtype}")
    if arr.ndim != 2:
        raise GBufferError(f"layer 'profile_id' must have shape (H, W), got {arr.shape}")
    if np.any(arr < 0):
        raise GBufferError("layer 'profile_id' has negative ids")
    return np.ascontiguousarray(arr, dtype=np.uint32)
