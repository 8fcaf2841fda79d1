"""G-buffers: the per-pixel inputs of a screen-space SSS pass, and their multi-layer EXR files.

Layers (all pixel-aligned, shape (H, W[, 3])):

* ``diffuse``   linear-light diffuse lighting of a white Lambertian surface (RGB), the signal the
  SSS pass blurs (the "irradiance" buffer of Jimenez et al. 2009 / separable-SSS paper section 6);
* ``specular``  linear-light specular reflection (RGB), added after the blur;
* ``albedo``    diffuse albedo (RGB), multiplied after the blur;
* ``depth``     linear camera-space depth z in world units (> 0; +inf where no surface);
* ``normal``    world-space unit normals (RGB; zero where no surface);
* ``profile_id`` uint32: 0 = no SSS (stencil culled), k >= 1 = the k-th entry of ``materials``.

Optional, for the transmittance pass (:mod:`ssskit.backends.transmission_plan`), both or neither:

* ``light_depth`` (H, W) float32: the key light's translucency shadow map, the light-space depth (mm along
  the light) of the first surface it meets per texel (+inf where none), rendered at the frame's size (one
  EXR data window);
* the light projection, header attribute ``ssskit_light`` (JSON,
  :meth:`~ssskit.screenspace.transmission.LightView.to_dict`: an orthographic view, its ``direction``,
  ``origin``, map axes ``u``, ``v``, ``texel_mm``, ``size`` = [W, H] of ``light_depth``), with
  ``irradiance`` [r, g, b], the light's irradiance on a surface facing it.

The camera (:class:`~ssskit.screenspace.camera.Camera`) travels with the layers.

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
from numpy.typing import ArrayLike

from ..backends.plan import DEPTH_MM
from ..errors import GBufferError
from ..quantities import Quantity, check_finite, check_instance, check_shape
from ..io import check_suffix, read_exr, write_exr
from .camera import Camera

#: the layers' quantities: a linear camera-space depth (inf: no surface), linear-light radiance, profile ids,
#: the light projection's irradiance (the transmittance pass's inputs are float32)
DEPTH_LAYER = Quantity("depth", 0.0, math.inf, "mm", "a linear camera-space depth; inf where there is no surface",
                       lo_open=True)
RADIANCE = Quantity("diffuse", 0.0, math.inf, "", "linear-light radiance", hi_open=True)
PROFILE_ID = Quantity("profile_id", 0, 2**32 - 1, "", "0 is no SSS, k the k-th material named", integer=True)
IRRADIANCE = Quantity("irradiance", 0.0, float(np.finfo(np.float32).max), "", "an irradiance the float32 pass carries")
LIGHT_DEPTH = Quantity("light_depth", -math.inf, math.inf, "mm", "a light-space depth; +-inf where the light meets "
                       "no surface (the transmittance pass's SHADOW_MM)")

#: the layers (module docstring), declared once: name -> (the channels after (H, W), the array kinds it may be, the
#: dtype it is kept as, the quantity of its values (an infinity where the range holds it: no surface; None: any finite
#: value), what they are)
LAYER_RULES: dict[str, tuple[tuple[int, ...], str, type, Quantity | None, str]] = {
    "diffuse": ((3,), "f", np.float32, RADIANCE, "colour values"),
    "specular": ((3,), "f", np.float32, None, "values"),
    "albedo": ((3,), "f", np.float32, None, "values"),
    "depth": ((), "f", np.float32, DEPTH_LAYER, "pixels"),
    "normal": ((3,), "f", np.float32, None, "values"),
    "profile_id": ((), "iub", np.uint32, PROFILE_ID, "pixels"),
    "light_depth": ((), "f", np.float32, LIGHT_DEPTH, "values"),
}
LAYERS = ("diffuse", "specular", "albedo", "depth", "normal", "profile_id")


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
    light_depth: np.ndarray | None = None
    light: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        layers = {"diffuse": _layer("diffuse", self.diffuse, ("H", "W"))}
        h, w = layers["diffuse"].shape[:2]  # (an empty layer is not the camera's size: the camera has a pixel at least)
        for name in LAYERS[1:]:
            value = getattr(self, name)
            zeros = value is None and name in ("specular", "albedo", "normal")  # (an RGB layer not given: zeros)
            layers[name] = _layer(name, np.zeros((h, w, 3), np.float32) if zeros else value, (h, w))
        ids = layers["profile_id"]
        DEPTH_MM.check_array(layers["depth"][ids > 0], "layer 'depth'", GBufferError, "pixels with SSS")
        check_instance(self.camera, Camera, "camera", GBufferError)
        if (self.camera.width, self.camera.height) != (w, h):
            raise GBufferError(f"camera is {self.camera.width}x{self.camera.height} but the layers are {w}x{h}")
        # one name (or file) is one material, not its characters
        given = [self.materials] if isinstance(self.materials, (str, Path, bytes, bytearray)) else list(self.materials)
        if any(isinstance(m, (bytes, bytearray)) for m in given):
            raise GBufferError(f"materials must be names (str), not bytes, got {self.materials!r}")
        mats = tuple(str(m) for m in given)
        if mats:
            PROFILE_ID.within(hi=len(mats), reason=f"0 is no SSS, k the k-th of the {len(mats)} materials named").check(
                int(ids.max(initial=0)), "layer 'profile_id'", GBufferError)
        for name, arr in layers.items():
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "materials", mats)
        self._check_light(h, w)

    def _check_light(self, h: int, w: int) -> None:
        """The optional light layers: both or neither, the map the projection's size, finite irradiance."""
        if self.light_depth is None and self.light is None:
            return
        if self.light is None:
            raise GBufferError("layer 'light_depth' needs the light projection (header 'ssskit_light'), which is missing")
        if self.light_depth is None:
            raise GBufferError("the light projection (header 'ssskit_light') is given without a 'light_depth' layer")
        from .transmission import LightView

        ld = _layer("light_depth", self.light_depth, (h, w))
        view = LightView.from_dict(self.light, GBufferError)
        if view.size != (w, h):
            raise GBufferError(f"the light projection's size {list(view.size)} is not the 'light_depth' layer's "
                               f"[{w}, {h}]")
        label = "the light projection's 'irradiance'"
        IRRADIANCE.check_array(check_shape(self.light.get("irradiance"), label, (3,), GBufferError), label, GBufferError)
        object.__setattr__(self, "light_depth", ld)

    @property
    def has_light(self) -> bool:
        """Whether the G-buffer carries the transmittance pass's layers."""
        return self.light_depth is not None

    def transmission_inputs(self, dtype: Any = np.float64) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(light_uvz (H, W, 3), shadow_mm (H, W), n_dot_l (H, W), light_rgb (H, W, 3)): the transmittance pass's
        frame inputs (:mod:`ssskit.backends.transmission_plan`) from the light layers, the positions (mm) and
        the normals, computed in float64 and stored as ``dtype`` (a float32 backend's inputs: no second
        conversion); a GBufferError without the layers.

        Each pixel's point in the light's view is affine in the camera-space point, itself z times the pixel's
        ray (:meth:`Camera.unproject`): a light coordinate is z (r_k(y) + c_k(x)) + o_k, one row and one
        column term per coordinate, the same numbers as ``view.project(positions())`` (tests/screenspace/
        test_gbuffer_light.py) without the (H, W, 3) float64 temporaries."""
        from .transmission import LightView

        if self.light_depth is None or self.light is None:
            raise GBufferError("the G-buffer has no light layers ('light_depth' and header 'ssskit_light')")
        view = LightView.from_dict(self.light)
        cam = self.camera
        h, w = self.shape
        k = cam.world_units_per_mm
        inv = np.linalg.inv(cam.world_to_camera)
        rot, shift = inv[:3, :3], inv[:3, 3]
        xs = (np.arange(w) + 0.5 - cam.cx) / cam.fx
        ys = (np.arange(h) + 0.5 - cam.cy) / cam.fy
        origin = np.asarray(view.origin)
        terms = []  # per light coordinate: row and column terms and the offset
        for axis, half in ((np.asarray(view.u) / view.texel_mm, 0.5 * view.size[0]),
                           (np.asarray(view.v) / view.texel_mm, 0.5 * view.size[1]), (np.asarray(view.direction), 0.0)):
            g = rot.T @ axis / k  # world = rot (z ray) + shift, in world units; / k: mm
            terms.append((ys * g[1] + g[2], xs * g[0], shift @ axis / k - origin @ axis + half))
        to_light = -np.asarray(view.direction, np.float64)  # L, towards the light, is -direction
        uvz = np.empty((h, w, 3), dtype)
        ndl = np.zeros((h, w), dtype)
        step = max(1, (1 << 16) // max(w, 1))  # rows per chunk: float64 temporaries of 512 kB stay in the cache
        for y0 in range(0, h, step):
            rows = slice(y0, min(h, y0 + step))
            d = self.depth[rows]
            z = np.where(np.isfinite(d), d, np.float32(1.0)).astype(np.float64)
            for i, (row, col, off) in enumerate(terms):
                acc = np.add.outer(row[rows], col)
                acc *= z
                acc += off
                uvz[rows, :, i] = acc
            if self.normal is not None:
                n = self.normal[rows]
                acc = np.multiply(n[..., 0], to_light[0], dtype=np.float64)
                for j in (1, 2):
                    acc += np.multiply(n[..., j], to_light[j], dtype=np.float64)
                ndl[rows] = acc
        rgb = np.empty((h, w, 3), dtype)
        rgb[...] = np.asarray(self.light["irradiance"], float)
        shadow = self.light_depth if k == 1.0 else self.light_depth.astype(np.float64) / k
        return uvz, np.asarray(shadow, dtype), ndl, rgb

    @property
    def shape(self) -> tuple[int, int]:
        return tuple(self.depth.shape)

    @property
    def depth_mm(self) -> np.ndarray:
        """Linear camera depth in mm (H, W) float32 like the layer: depth / world_units_per_mm (+inf where
        empty)."""
        return self.depth if self.camera.world_units_per_mm == 1.0 else (
            self.depth / np.float32(self.camera.world_units_per_mm))

    @property
    def mask(self) -> np.ndarray:
        """Pixels that receive SSS (profile_id > 0), (H, W) bool."""
        return self.profile_id > 0

    def positions(self) -> np.ndarray:
        """World positions (H, W, 3) float64 of the pixels' surface points (:meth:`Camera.unproject`);
        pixels without a surface (infinite depth) are placed at depth 1."""
        return self.camera.unproject(np.where(np.isfinite(self.depth), self.depth, 1.0))

    def view_cosine(self) -> np.ndarray:
        """(H, W) float64: |normal . unit direction to the camera| per pixel, 0 where there is no
        surface (the cosine of the angle a pixel's surface is seen at)."""
        assert self.normal is not None, "view_cosine needs the G-buffer's normal layer"
        pos = self.positions()
        view = np.linalg.inv(self.camera.world_to_camera)[:3, 3] - pos
        view /= np.maximum(np.linalg.norm(view, axis=-1, keepdims=True), 1e-300)
        n = self.normal.astype(np.float64)
        cos = np.abs(np.sum(n * view, axis=-1)) / np.maximum(np.linalg.norm(n, axis=-1), 1e-300)
        return np.where(np.isfinite(self.depth), cos, 0.0)

    def with_layers(self, **layers: Any) -> "GBuffer":
        return replace(self, **layers)

    def composite(self, diffuse: np.ndarray | None = None) -> np.ndarray:
        """Final linear image: albedo * diffuse + specular (separable-SSS paper section 6), (H, W, 3).

        ``diffuse`` is the (blurred) diffuse layer; by default the unblurred one.
        """
        if diffuse is None:
            return self.albedo * self.diffuse + self.specular
        d = check_shape(diffuse, "diffuse to composite", self.diffuse.shape, GBufferError, dtype=np.float32)
        return self.albedo * d + self.specular

    # ---- EXR ---------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write a multi-layer EXR (float32 layers, uint32 ids, ZIP), atomically (:func:`ssskit.io.write_exr`); the
        header names the materials where the G-buffer does (an empty list would name none for ids that are used)."""
        check_suffix(path, (".exr",), "G-buffer file")
        attributes = {"ssskit_camera": json.dumps(self.camera.to_dict()), "ssskit_meta": json.dumps(self.meta, default=str)}
        if self.materials:
            attributes["ssskit_materials"] = json.dumps(list(self.materials))
        channels = {name: np.ascontiguousarray(getattr(self, name)) for name in LAYERS}
        if self.light_depth is not None and self.light is not None:
            channels["light_depth"] = np.ascontiguousarray(self.light_depth)
            attributes["ssskit_light"] = json.dumps(self.light)
        write_exr(path, channels, attributes, what="G-buffer file")

    @classmethod
    def load(cls, path: str | Path) -> "GBuffer":
        """Read a G-buffer EXR written by :meth:`save` or by any tool using the same layer names.

        ``specular`` and ``normal`` are optional (zero when missing); the camera header attribute is
        required unless ``camera`` is given to :func:`load_gbuffer`.
        """
        return load_gbuffer(path)


def load_gbuffer(path: str | Path, camera: Camera | None = None) -> GBuffer:
    """:meth:`GBuffer.load`, optionally supplying the camera for EXRs made by other tools.

    File errors (missing, a directory, not OpenEXR, truncated, a multi-part file whose layers are not
    all in one part) are one :class:`GBufferError` line (:func:`ssskit.io.read_exr`); a multi-part
    file is read from the part that holds the required layers.
    """
    p = Path(path)
    header, channels = read_exr(p, "G-buffer file", required=("diffuse", "albedo", "depth", "profile_id"))
    for name in ("diffuse", "albedo", "depth", "profile_id"):
        if name not in channels:
            raise GBufferError(f"G-buffer {str(p)!r} has no layer {name!r} (found: {', '.join(sorted(channels))})")
    if camera is None and "ssskit_camera" not in header:
        raise GBufferError(f"G-buffer {str(p)!r} has no 'ssskit_camera' header attribute; pass a camera")
    record: Any = None if camera is not None else _header(p, header, "ssskit_camera")
    named, meta = _header(p, header, "ssskit_materials"), _header(p, header, "ssskit_meta", {})
    materials: tuple[str, ...] = ()
    if named is not None:  # a file that names its materials names one for every profile id it uses (GBuffer's rule)
        if not (isinstance(named, list) and named and all(isinstance(m, str) and m.strip() for m in named)):
            raise GBufferError(f"G-buffer {str(p)!r}: header 'ssskit_materials' must be a non-empty list of material "
                               f"names, got {header['ssskit_materials']!r}")
        materials = tuple(named)
    light = _header(p, header, "ssskit_light")  # (a table: LightView.from_dict's rule, in GBuffer)
    try:  # (the camera record's and the layers' errors alike name the file)
        return GBuffer(diffuse=channels["diffuse"], albedo=channels["albedo"], depth=channels["depth"],
                       profile_id=channels["profile_id"], camera=camera if camera is not None else Camera.from_dict(record),
                       specular=channels.get("specular"), normal=channels.get("normal"), materials=materials, meta=meta,
                       light_depth=channels.get("light_depth"), light=light)
    except GBufferError as exc:  # name the file in the layer's message
        raise GBufferError(f"G-buffer {str(p)!r}: {exc}") from None


def _header(p: Path, header: dict[str, Any], key: str, default: Any = None) -> Any:
    """The JSON value of the EXR header attribute ``key`` (``default`` where absent), or a GBufferError naming the
    file."""
    if key not in header:
        return default
    try:  # (an int, float or V3f attribute was a TypeError)
        return json.loads(check_instance(header[key], (str, bytes), f"G-buffer {str(p)!r}: header {key!r}",
                                         GBufferError))
    except json.JSONDecodeError:
        raise GBufferError(f"G-buffer {str(p)!r}: header {key!r} is not JSON") from None


def _layer(name: str, value: ArrayLike, size: tuple[int | str, int | str]) -> np.ndarray:
    """The layer ``name`` of ``size`` (H, W) by its rule (:data:`LAYER_RULES`), contiguous in its dtype, or a
    GBufferError naming it."""
    channels, kinds, dtype, quantity, where = LAYER_RULES[name]
    # (floats as kept, so a float32 overflow is refused; ids checked before they are made unsigned)
    arr = check_shape(value, f"layer {name!r}", (*size, *channels), GBufferError, kinds, dtype if kinds == "f" else None)
    if quantity is None:
        return np.ascontiguousarray(check_finite(arr, f"layer {name!r}", GBufferError, where))
    held = [v for v in (math.inf, -math.inf) if quantity.contains(v)]  # no surface: the infinities the range holds
    quantity.check_array(np.where(np.isin(arr, held), 1.0, arr), f"layer {name!r}", GBufferError, where)
    return np.ascontiguousarray(arr, dtype)
