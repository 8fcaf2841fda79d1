"""A global temporal anti-aliasing (TAA) resolve, as engines have it (Karis 2014), separate from the
adaptive sampler (:mod:`.adaptive`), which must work with it on and off and does not read its state.

Per frame and pixel (Karis 2014, "High quality temporal supersampling", SIGGRAPH Advances course;
Xie 2020 Eq. 6 with C the clamped history and M the per-pixel weight):

1. **Reprojection.** The previous TAA output is fetched at the pixel's previous position
   x + motion(x) (``motion``: pixels, (u, v), as :func:`ssskit.screenspace.motion_vectors` returns),
   with a bilinear or a Catmull-Rom bicubic filter (Karis 2014 uses Catmull-Rom to keep the history
   sharp; its weights, Catmull and Rom 1974 / Keys 1981 with a = -1/2, sum to 1 so a constant stays
   constant). Texels outside the image are clamped to the edge.
2. **Neighbourhood clamping in YCoCg** (Karis 2014): the history is clamped, component by component,
   to a box around this frame's 3x3 neighbourhood in YCoCg (Malvar and Sullivan 2003):
   ``"minmax"`` (default): the box of the 9 values' minimum and maximum (Karis 2014);
   ``"variance"``: mu +- gamma * sigma of the 9 values (variance clipping, Salvi 2016, "An excursion
   in temporal supersampling", GDC; gamma = 1 there), intersected with the min/max box;
   ``"none"``: no clamping (a plain exponential moving average, for tests and comparisons).
3. **Blend** (Xie 2020 Eq. 6, Karis 2014): out = (1 - a) * clamped history + a * current, a = ``alpha``
   (the current frame's weight; Karis 2014 and UE4: 0.04-0.2; default 0.1) where the history is
   available, a = 1 where it is not: off-screen previous positions, pixels where ``valid`` is False
   (a disocclusion test such as :func:`reprojection_valid`), and the first frame.

Only the blend runs on linear RGB; the box is built and applied in YCoCg, which is linear in RGB,
so the result is RGB again by the inverse transform (clamped at 0: a box corner can be negative).

API::

    taa = TemporalAA(TAASettings(alpha=0.1, neighbourhood="minmax", fetch="catmull-rom"))
    out = taa.resolve(frame_rgb, motion=None, valid=None)   # (H, W, 3) float32, keeps the history
    out = taa_resolve(frame_rgb, history_rgb, motion, valid, settings)   # the same, stateless
    ok = reprojection_valid(depth, camera, previous_depth, previous_camera)   # disocclusion test

    >>> import numpy as np
    >>> taa = TemporalAA(TAASettings(alpha=0.5, neighbourhood="none"))
    >>> _ = taa.resolve(np.zeros((4, 4, 3), np.float32))
    >>> float(taa.resolve(np.ones((4, 4, 3), np.float32))[0, 0, 0])
    0.5
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import PassError, SettingsError
from ..quantities import CHOICE, Choice, Quantity, check_instance, check_shape, fail
from ..settings import Settings, setting
from .camera import Camera

#: neighbourhood boxes the history is clamped to (module docstring)
NEIGHBOURHOODS = ("minmax", "variance", "none")
#: history fetch filters
FETCHES = ("bilinear", "catmull-rom")
#: :func:`reprojection_valid`'s depth tolerance
_TOLERANCE = Quantity("tolerance", 0.0, math.inf, "", "a relative depth difference", hi_open=True)


@dataclass(frozen=True)
class TAASettings(Settings):
    """TAA parameters (module docstring). ``alpha``: the current frame's blend weight where the history
    is available, in (0, 1] (Karis 2014: about 0.04-0.1; Xie 2020: UE4's maximum 0.2); ``neighbourhood``:
    ``"minmax"``, ``"variance"`` or ``"none"``; ``gamma``: the width of the variance box in standard
    deviations (Salvi 2016: 1; > 0); ``fetch``: ``"bilinear"`` or ``"catmull-rom"``."""

    alpha: float = setting(Quantity("alpha", 0.0, 1.0, "", "the current frame's TAA weight", lo_open=True), 0.1)
    neighbourhood: str = setting(Choice("neighbourhood", NEIGHBOURHOODS), "minmax")
    gamma: float = setting(Quantity("gamma", 0.0, 100.0, "", "the variance box's width in standard deviations",
                                    lo_open=True), 1.0)
    fetch: str = setting(Choice("fetch", FETCHES), "catmull-rom")


# ---- colour space --------------------------------------------------------------------------------------

def rgb_to_ycocg(rgb: ArrayLike) -> np.ndarray:
    """YCoCg (..., 3) of RGB (Malvar and Sullivan 2003): Y = R/4 + G/2 + B/4, Co = (R - B)/2,
    Cg = -R/4 + G/2 - B/4."""
    a = np.asarray(rgb)
    r, g, b = a[..., 0], a[..., 1], a[..., 2]
    return np.stack([0.25 * r + 0.5 * g + 0.25 * b, 0.5 * (r - b), -0.25 * r + 0.5 * g - 0.25 * b], axis=-1)


def ycocg_to_rgb(ycocg: ArrayLike) -> np.ndarray:
    """The inverse of :func:`rgb_to_ycocg`: R = Y + Co - Cg, G = Y + Cg, B = Y - Co - Cg."""
    a = np.asarray(ycocg)
    y, co, cg = a[..., 0], a[..., 1], a[..., 2]
    return np.stack([y + co - cg, y + cg, y - co - cg], axis=-1)


# ---- history fetch ---------------------------------------------------------------------------------------

def _catmull_rom_weights(t: np.ndarray) -> tuple[np.ndarray, ...]:
    """Weights of the 4 taps at offsets -1, 0, 1, 2 for fractional position t in [0, 1) (Catmull-Rom,
    i.e. Keys 1981 cubic convolution with a = -1/2); they sum to 1."""
    t2 = t * t
    t3 = t2 * t
    return (-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t, 0.5 * t3 - 0.5 * t2)


def fetch(image: ArrayLike, x: ArrayLike, y: ArrayLike, filter: str = "bilinear") -> NDArray[np.float64]:
    """``image`` (H, W, C) sampled at continuous pixel positions (x, y) (each (H, W); pixel centres at
    integer + 0.5), with a bilinear or Catmull-Rom filter and clamp-to-edge addressing; (H, W, C) float64."""
    img = np.asarray(image, dtype=np.float64)
    hh, ww = img.shape[:2]
    fx = np.asarray(x, dtype=np.float64) - 0.5
    fy = np.asarray(y, dtype=np.float64) - 0.5
    x0 = np.floor(fx)
    y0 = np.floor(fy)
    tx = (fx - x0)[..., None]
    ty = (fy - y0)[..., None]
    x0 = x0.astype(np.int64)
    y0 = y0.astype(np.int64)
    offsets: tuple[int, ...]
    wx: tuple[np.ndarray, ...]
    wy: tuple[np.ndarray, ...]
    if filter == "bilinear":
        offsets, wx, wy = (0, 1), (1.0 - tx, tx), (1.0 - ty, ty)
    elif filter == "catmull-rom":
        offsets, wx, wy = (-1, 0, 1, 2), _catmull_rom_weights(tx), _catmull_rom_weights(ty)
    else:
        raise fail(PassError, CHOICE, name="fetch filter", choices=", ".join(FETCHES), actual=repr(filter))
    out = np.zeros(fx.shape + img.shape[2:], np.float64)
    for j, oy in enumerate(offsets):
        rows = np.clip(y0 + oy, 0, hh - 1)
        row = np.zeros_like(out)
        for i, ox in enumerate(offsets):
            row += wx[i] * img[rows, np.clip(x0 + ox, 0, ww - 1)]
        out += wy[j] * row
    return out


# ---- neighbourhood -----------------------------------------------------------------------------------------

def _shifted(a: np.ndarray) -> Iterator[np.ndarray]:
    """The 9 images of a's 3x3 neighbourhood (clamp-to-edge)."""
    p = np.pad(a, ((1, 1), (1, 1), (0, 0)), mode="edge")
    hh, ww = a.shape[:2]
    for dy in range(3):
        for dx in range(3):
            yield p[dy:dy + hh, dx:dx + ww]


def neighbourhood_box(ycocg: ArrayLike, kind: str = "minmax", gamma: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) (H, W, 3): the box of each pixel's 3x3 neighbourhood of ``ycocg`` the history is
    clamped to: its component-wise min/max (Karis 2014), or mu +- gamma * sigma of the 9 values
    (Salvi 2016) intersected with the min/max box (``kind="variance"``)."""
    kind = Choice("neighbourhood", ("minmax", "variance")).check(kind, "neighbourhood", PassError)
    a = np.asarray(ycocg, dtype=np.float64)
    taps = np.stack(list(_shifted(a)), axis=0)
    low, high = taps.min(axis=0), taps.max(axis=0)
    if kind == "variance":
        mu = taps.mean(axis=0)
        sd = np.sqrt(np.maximum((taps * taps).mean(axis=0) - mu * mu, 0.0))
        low = np.maximum(low, mu - gamma * sd)
        high = np.minimum(high, mu + gamma * sd)
    return low, high


# ---- disocclusion ------------------------------------------------------------------------------------------

def reprojection_valid(depth: ArrayLike, camera: Camera, previous_depth: ArrayLike, previous_camera: Camera,
                       tolerance: float = 0.05) -> NDArray[np.bool_]:
    """(H, W) bool: True where this frame's pixel was visible in the previous frame (a depth test, as
    engines reject disoccluded history): its world point projects inside the previous image and its
    depth there agrees with ``previous_depth`` at the nearest pixel within ``tolerance`` relative.
    Pixels without a surface (depth inf) are valid where the previous frame had none there either."""
    z = check_shape(depth, "depth", ("H", "W"), PassError, dtype=np.float64)
    zp = check_shape(previous_depth, "previous depth", z.shape, PassError, dtype=np.float64)
    for name, cam in (("camera", camera), ("previous_camera", previous_camera)):
        check_instance(cam, Camera, name, PassError)
    tol = float(_TOLERANCE.check(tolerance, "tolerance", SettingsError))
    hh, ww = z.shape
    finite = np.isfinite(z)
    world = camera.unproject(np.where(finite, z, 1.0))
    uv, zprev = previous_camera.project(world)
    with np.errstate(invalid="ignore"):
        px = np.floor(uv[..., 0])
        py = np.floor(uv[..., 1])
        inside = (px >= 0) & (px < ww) & (py >= 0) & (py < hh) & (zprev > 0)
    ix = np.clip(np.nan_to_num(px, nan=0.0), 0, ww - 1).astype(np.int64)
    iy = np.clip(np.nan_to_num(py, nan=0.0), 0, hh - 1).astype(np.int64)
    seen = zp[iy, ix]
    with np.errstate(invalid="ignore"):
        same = np.isfinite(seen) & (np.abs(seen - zprev) <= tol * np.abs(zprev))
    out = finite & inside & same
    # background: no surface now, none at the same pixel before (the motion there is zero)
    out |= ~finite & ~np.isfinite(zp)
    return out


# ---- the resolve ---------------------------------------------------------------------------------------------

def _settings(settings: object) -> TAASettings:
    """The TAA settings given (None: the defaults), or a PassError: the rule of :func:`taa_resolve` and
    :class:`TemporalAA`."""
    return check_instance(TAASettings() if settings is None else settings, TAASettings, "settings", PassError)


@overload
def taa_resolve(current: ArrayLike, history: ArrayLike | None = None, motion: ArrayLike | None = None,
                valid: ArrayLike | None = None, settings: TAASettings | None = None,
                return_weight: Literal[False] = False) -> NDArray[np.float32]: ...


@overload
def taa_resolve(current: ArrayLike, history: ArrayLike | None = None, motion: ArrayLike | None = None,
                valid: ArrayLike | None = None, settings: TAASettings | None = None, *,
                return_weight: Literal[True]) -> tuple[NDArray[np.float32], NDArray[np.float64]]: ...


@overload
def taa_resolve(current: ArrayLike, history: ArrayLike | None = None, motion: ArrayLike | None = None,
                valid: ArrayLike | None = None, settings: TAASettings | None = None,
                return_weight: bool = False) -> NDArray[np.float32] | tuple[NDArray[np.float32], NDArray[np.float64]]: ...


def taa_resolve(current: ArrayLike, history: ArrayLike | None = None, motion: ArrayLike | None = None,
                valid: ArrayLike | None = None, settings: TAASettings | None = None,
                return_weight: bool = False) -> NDArray[np.float32] | tuple[NDArray[np.float32], NDArray[np.float64]]:
    """One TAA frame (module docstring): ``current`` (H, W, 3) linear RGB, ``history`` (H, W, 3) the
    previous output (None: the first frame, which is ``current``), ``motion`` (H, W, 2) pixels from each
    pixel to its previous position (None: a static camera), ``valid`` (H, W) bool (False: disoccluded,
    take the current frame). Returns the (H, W, 3) float32 output, and with ``return_weight`` also the
    (H, W) weight a of the current frame used per pixel (1 where the history was rejected)."""
    s = _settings(settings)
    cur = check_shape(current, "the TAA input frame", ("H", "W", 3), PassError, dtype=np.float64, finite=True)
    hh, ww = cur.shape[:2]
    if history is None:
        out = cur.astype(np.float32)
        return (out, np.ones((hh, ww))) if return_weight else out
    hist = check_shape(history, "the TAA history", cur.shape, PassError, dtype=np.float64, finite=True)
    v, u = np.mgrid[0:hh, 0:ww] + 0.5
    ok = np.ones((hh, ww), bool)
    if valid is not None:
        ok &= check_shape(valid, "valid", (hh, ww), PassError, "iufb", bool)
    if motion is not None:
        mv = check_shape(motion, "the motion vectors", (hh, ww, 2), PassError, dtype=np.float64, finite=True)
        u = u + mv[..., 0]
        v = v + mv[..., 1]
        ok &= (u >= 0) & (u < ww) & (v >= 0) & (v < hh)  # off-screen: no history
    # a static camera fetches at the pixel centres, where every filter returns the texel itself (its weights are
    # 0, 1, 0...: the same numbers, bit for bit): no fetch
    prev = rgb_to_ycocg(hist) if motion is None else fetch(rgb_to_ycocg(hist), u, v, s.fetch)
    cur_y = rgb_to_ycocg(cur)
    if s.neighbourhood != "none":
        low, high = neighbourhood_box(cur_y, s.neighbourhood, s.gamma)
        prev = np.clip(prev, low, high)
    a = np.where(ok, s.alpha, 1.0)
    out_y = (1.0 - a)[..., None] * prev + a[..., None] * cur_y
    out = np.maximum(ycocg_to_rgb(out_y), 0.0).astype(np.float32)
    return (out, a) if return_weight else out


class TemporalAA:
    """A TAA resolve that keeps its history between frames: ``resolve(current, motion, valid)`` returns
    this frame's output (:func:`taa_resolve`) and remembers it; ``reset()`` forgets it (the next frame
    is taken as is). ``history``: the last output, or None."""

    def __init__(self, settings: TAASettings | None = None) -> None:
        self.settings = _settings(settings)
        self.history: np.ndarray | None = None

    def resolve(self, current: ArrayLike, motion: ArrayLike | None = None,
                valid: ArrayLike | None = None) -> NDArray[np.float32]:
        self.history = taa_resolve(current, self.history, motion, valid, self.settings)
        return self.history

    def reset(self) -> None:
        self.history = None


def halton(index: int, base: int) -> float:
    """The ``index``-th (from 1) element of the radical-inverse (van der Corput) sequence in ``base``, one
    coordinate of the Halton sequence (Halton 1960, [Hal60])."""
    f, r, i = 1.0, 0.0, int(index)
    while i > 0:
        f /= base
        r += f * (i % base)
        i //= base
    return r


def taa_jitter(frame: int, samples: int = 8) -> tuple[float, float]:
    """The sub-pixel offset (pixels, each in [-1/2, 1/2)) of frame ``frame``'s jittered projection: the
    Halton(2, 3) points 1..``samples`` in turn (Karis 2014, [Kar14]: the TAA renders every frame through a
    jittered projection; 8 samples, Unreal's default), less 1/2. A G-buffer rendered with it:
    :attr:`ssskit.scenes.SceneSpec.pixel_jitter`."""
    k = int(frame) % int(samples) + 1
    return halton(k, 2) - 0.5, halton(k, 3) - 0.5


__all__ = ["FETCHES", "NEIGHBOURHOODS", "TAASettings", "TemporalAA", "fetch", "halton", "neighbourhood_box",
           "reprojection_valid", "rgb_to_ycocg", "taa_jitter", "taa_resolve", "ycocg_to_rgb"]
