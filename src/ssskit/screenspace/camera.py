"""The pinhole camera of a G-buffer, and screen-space motion between two cameras.

A :class:`Camera` holds what the passes need to turn a width in mm into pixels: focal lengths in
pixels (fx, fy; fx != fy for non-square pixels), the principal point, the world-to-camera matrix
(camera looks down +z, x right, y down, so pixel (u, v) = (fx x/z + cx, fy y/z + cy)), and
``world_units_per_mm``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GBufferError
from ..quantities import Quantity, check_fields, check_shape

#: a camera's image sides (pixels), its positive factors (focal lengths in pixels, world units per mm, the pixel
#: aspect) and its horizontal field of view
PIXELS = Quantity("width", 1, 2**31 - 1, "px", "an image side", integer=True)
FACTOR = Quantity("factor", 0.0, math.inf, "", "a positive scale", lo_open=True, hi_open=True)
FOV_DEG = Quantity("field of view", 0.0, 180.0, "degrees", "a pinhole camera's", lo_open=True, hi_open=True)
_FROM_FOV = {"field of view": FOV_DEG, "pixel aspect": FACTOR}  # Camera.from_fov's arguments


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
        for name in ("width", "height", "fx", "fy", "world_units_per_mm"):
            (PIXELS if name in ("width", "height") else FACTOR).check(getattr(self, name), f"camera: {name}",
                                                                     GBufferError)
        object.__setattr__(self, "world_to_camera", check_shape(self.world_to_camera, "camera: world_to_camera",
                                                                (4, 4), GBufferError, finite=True, dtype=float))
        for name in ("fx", "fy", "cx", "cy", "world_units_per_mm"):
            object.__setattr__(self, name, float(getattr(self, name)))

    @classmethod
    def from_fov(cls, width: int, height: int, fov_x_deg: float, pixel_aspect: float = 1.0,
                 world_to_camera: ArrayLike | None = None, world_units_per_mm: float = 1.0) -> "Camera":
        """A camera with horizontal field of view ``fov_x_deg``; ``pixel_aspect`` = pixel height / width.

        fx = (W/2) / tan(fov_x/2); fy = fx / pixel_aspect (a pixel that is taller than wide covers
        more of the scene vertically, so fewer pixels per unit length).
        """
        check_fields({"field of view": fov_x_deg, "pixel aspect": pixel_aspect}, _FROM_FOV, "camera", GBufferError)
        fx = 0.5 * width / math.tan(math.radians(fov_x_deg) / 2.0)
        return cls(int(width), int(height), fx, fx / pixel_aspect, width / 2.0, height / 2.0,
                   np.eye(4) if world_to_camera is None else np.asarray(world_to_camera, dtype=float),
                   world_units_per_mm)

    @property
    def pixel_aspect(self) -> float:
        """Pixel height / pixel width (1 for square pixels)."""
        return self.fx / self.fy

    def pixels_per_mm(self, depth: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Horizontal and vertical pixels per mm of surface at linear depth ``depth`` (world units),
        for a fronto-parallel surface: f * world_units_per_mm / z."""
        z = np.asarray(depth, dtype=float)
        return self.fx * self.world_units_per_mm / z, self.fy * self.world_units_per_mm / z

    def project(self, points_world: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (..., 2) (u, v; pixel centres at integer + 0.5) and depth z of world points."""
        p = np.asarray(points_world, dtype=float)
        cam = p @ self.world_to_camera[:3, :3].T + self.world_to_camera[:3, 3]
        z = cam[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([self.fx * cam[..., 0] / z + self.cx, self.fy * cam[..., 1] / z + self.cy], axis=-1)
        return uv, z

    def unproject(self, depth: ArrayLike) -> np.ndarray:
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
        except GBufferError:  # (a value the camera itself refuses: its own message)
            raise
        except (KeyError, TypeError, ValueError) as exc:
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
