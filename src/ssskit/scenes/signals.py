"""Irradiance test signals for kernel evaluation, (H, W, 3) float64 in [0, 1] (same in all channels).

Geometry is rasterised with exact-ish pixel coverage (8 x 8 supersampling) so edges are
anti-aliased the same way for every method. Coordinates: pixel centres at integers, the image
centre at ((W - 1) / 2, (H - 1) / 2).
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..errors import SignalError
from ..quantities import SIZE_PX, Quantity, checks
from ..registry import Registry

#: a width or radius of a test signal's shape (pixels)
PIXELS = Quantity("width", 0.0, 1e6, "px", "a shape inside a test image", lo_open=True)

_SUPER = 8


def _coverage(size: int, inside: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> np.ndarray:
    """Fraction of each pixel where inside(x, y) holds, x, y relative to the image centre (pixels)."""
    sub = (np.arange(_SUPER) + 0.5) / _SUPER - 0.5
    c = (size - 1) / 2.0
    coords = (np.arange(size)[:, None] + sub[None, :]).ravel() - c  # (size * S,)
    acc = np.zeros((size, size))
    for row in range(size):  # one pixel row at a time keeps memory at size * S^2
        ys = coords[row * _SUPER:(row + 1) * _SUPER]
        mask = inside(coords[None, :], ys[:, None]).astype(float)  # (S, size * S)
        acc[row] = mask.reshape(_SUPER, size, _SUPER).mean(axis=(0, 2))
    return acc


def _rgb(gray: np.ndarray) -> np.ndarray:
    return np.repeat(gray[..., None], 3, axis=2)


def edge(size: int = 256, angle_deg: float = 0.0) -> np.ndarray:
    """A straight shadow edge through the centre: lit where x cos(a) + y sin(a) > 0 (a = 0: vertical edge)."""
    size = SIZE_PX.check(size, "signal size", SignalError)
    a = np.deg2rad(float(angle_deg))
    if a == 0.0:  # the axis-aligned edge is exactly additively separable: E = E1(x)
        x = np.arange(size) - (size - 1) / 2.0
        return _rgb(np.broadcast_to((x > 0).astype(float) + 0.5 * (x == 0), (size, size)).copy())
    ca, sa = np.cos(a), np.sin(a)
    return _rgb(_coverage(size, lambda x, y: x * ca + y * sa > 0))


def edge_rotated(size: int = 256, angle_deg: float = 30.0) -> np.ndarray:
    """A straight shadow edge at ``angle_deg`` from vertical (default 30 degrees)."""
    return edge(size, angle_deg)


@checks(SignalError, size=(SIZE_PX, "signal size"), radius_px=(PIXELS, "disk radius"))
def disk(size: int = 256, radius_px: float | None = None) -> np.ndarray:
    """A white disk on black (the 'dot' of supplement Fig. S.5); default radius size / 16."""
    r = size / 16.0 if radius_px is None else float(radius_px)
    return _rgb(_coverage(size, lambda x, y: x * x + y * y < r * r))


@checks(SignalError, size=(SIZE_PX, "signal size"), width_px=(PIXELS, "line width"))
def line(size: int = 256, width_px: float = 1.0, angle_deg: float = 0.0) -> np.ndarray:
    """A thin bright line of ``width_px`` through the centre (angle from vertical)."""
    a = np.deg2rad(float(angle_deg))
    ca, sa = np.cos(a), np.sin(a)
    return _rgb(_coverage(size, lambda x, y: np.abs(x * ca + y * sa) < width_px / 2.0))


def texture(size: int = 256, seed: int = 7) -> np.ndarray:
    """Seeded band-limited noise with pore-scale detail: 0.6 coarse (sigma 6 px) + 0.4 fine (sigma 0.7 px)."""
    from scipy.ndimage import gaussian_filter

    size = SIZE_PX.check(size, "signal size", SignalError)
    rng = np.random.default_rng(seed)
    coarse = gaussian_filter(rng.standard_normal((size, size)), 6.0, mode="wrap")
    fine = gaussian_filter(rng.standard_normal((size, size)), 0.7, mode="wrap")
    g = 0.6 * coarse / coarse.std() + 0.4 * fine / fine.std()
    g = (g - g.min()) / (g.max() - g.min())
    return _rgb(g)


SIGNALS: Registry[Callable[..., np.ndarray]] = Registry("signal", SignalError)
SIGNALS.register("edge", edge)
SIGNALS.register("edge-rotated", edge_rotated)
SIGNALS.register("disk", disk)
SIGNALS.register("line", line)
SIGNALS.register("texture", texture)


def make_signal(name: str, size: int = 256, **params: Any) -> np.ndarray:
    """The named signal at ``size`` x ``size`` pixels."""
    return SIGNALS.get(name)(size, **params)
