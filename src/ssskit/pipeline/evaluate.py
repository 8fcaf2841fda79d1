"""Compare kernel approximations with the exact 2D convolution on test signals.

The pixel size is tied to the profile: the largest channel radius holding 99.9% of the energy
spans ``size / 6`` pixels, so every material is seen at the same relative scale. All kernels are
built on the ground truth's own pixel grid (n x n cells, n = 2 ceil(R / pixel) + 1), so a method
that is exact (the pre-integrated kernel on axis-aligned edges) reproduces the truth to rounding.
Kernels normalised to 1 by construction (``jimenez2012``) are scaled to the profile's discrete
||Rd||_1 per channel, standing in for the albedo an engine multiplies afterwards.

Kernels and discrete profiles depend only on (profile, method, grid), not on the signal: they are
built once per profile object and reused by later evaluations in the process (a small memo), so
the figures and tables of one profile on several signals do not rebuild them (the guided kernel
takes seconds). Likewise the metrics of a method on a named test signal are computed once per
profile object (the images are not kept: ``keep_images`` recomputes them).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from ..errors import ProfileError, SignalError
from ..kernels import build_kernel, parse_method_spec
from ..kernels.base import AnyKernel, TapKernel
from ..profiles.base import RGBProfile
from ..quantities import check_instance
from ..metrics import all_metrics, check_ssim_size
from ..scenes.signals import make_signal
from ..truth import apply_separable, convolve_2d

#: The methods of paper Fig. 7 / supplement Fig. S.3, in its row order.
FIG7_METHODS = (
    [f"gaussians:{i}" for i in range(1, 7)]
    + [f"svd:{i}" for i in range(1, 7)]
    + ["artist:close fit", "artist:production", "guided:0", "guided:2", "preintegrated"]
)


def evaluation_grid(profile: RGBProfile, size: int = 256, fraction: float = 0.999) -> tuple[float, int]:
    """(pixel_mm, n): pixel size making the ``fraction`` radius span size / 6 pixels; kernel grid size n."""
    radius = float(np.max(profile.radius_at_fraction(fraction)))
    radius_px = max(size / 6.0, 4.0)
    pixel_mm = radius / radius_px
    return pixel_mm, 2 * int(math.ceil(radius_px)) + 1


@dataclass
class Evaluation:
    """Truth and per-method results of one (profile, signal) evaluation."""

    signal: str
    pixel_mm: float
    n: int
    irradiance: np.ndarray
    truth: np.ndarray
    images: dict[str, np.ndarray] = field(default_factory=dict)
    results: dict[str, dict[str, Any]] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """Method label -> metrics (non-finite numbers, e.g. PSNR of an exact result, become null)."""
        return {label: {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()}
                for label, r in self.results.items()}


class _Identity:
    """A profile hashed and compared by identity (profiles hold arrays), as a memo key; the memo's
    reference keeps the object alive, so its id is not reused while cached."""

    __slots__ = ("obj",)

    def __init__(self, obj: RGBProfile) -> None:
        self.obj = obj

    def __hash__(self) -> int:
        return id(self.obj)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Identity) and other.obj is self.obj


#: metrics of (profile, named signal, size, method, perceptual), oldest dropped first
_RESULTS: dict[tuple, dict[str, Any]] = {}
_RESULTS_MAX = 512


@functools.lru_cache(maxsize=8)
def _cells(profile: _Identity, pixel_mm: float, n: int) -> np.ndarray:
    return profile.obj.discretize_2d(pixel_mm, n)


@functools.lru_cache(maxsize=64)
def _kernel(profile: _Identity, method: str, params: tuple[tuple[str, Any], ...], pixel_mm: float, n: int) -> AnyKernel:
    return build_kernel(method, profile.obj, pixel_mm, n, **dict(params))


def evaluate(profile: RGBProfile, signal: str | np.ndarray, methods: Iterable[str], size: int = 256,
             perceptual: bool | tuple[str, ...] = True, progress: Callable[[str], object] | None = None,
             keep_images: bool = False) -> Evaluation:
    """Errors of each method spec (``"svd:3"``...; one spec may be given as a string) against E * Rd on
    ``signal`` (a name or an (H, W, 3) image).

    ``perceptual``: SSIM and FLIP too (True), neither (False), or the named ones (``("flip",)``;
    :func:`ssskit.metrics.all_metrics`).
    """
    check_instance(profile, RGBProfile, "evaluate's profile (profile_for_material(material, model))", ProfileError)
    if isinstance(methods, (bytes, bytearray)):  # (iterated, its codes read as methods '115', ...)
        raise SignalError(f"methods must be a spec string or a list of them (str), not bytes, got {methods!r}")
    specs = [parse_method_spec(m) for m in ([methods] if isinstance(methods, str) else methods)]
    if not specs:
        raise SignalError("no kernel methods given")
    pixel_mm, n = evaluation_grid(profile, size)
    if isinstance(signal, str):
        name, image = signal, make_signal(signal, size)
    else:
        name, image = "image", np.asarray(signal, dtype=float)
    ssim = perceptual is True or (not isinstance(perceptual, bool) and "ssim" in perceptual)
    if ssim:  # before any kernel is built
        check_ssim_size(*np.shape(image)[:2])
    key = _Identity(profile)
    rd = _cells(key, pixel_mm, n)
    truth = convolve_2d(image, rd)
    ev = Evaluation(name, pixel_mm, n, image, truth)
    for method, params, label in specs:
        if progress is not None:
            progress(label)
        memo = (key, name, size, label, perceptual if isinstance(perceptual, bool) else tuple(perceptual)) \
            if isinstance(signal, str) else None
        if memo in _RESULTS and not keep_images:
            ev.results[label] = dict(_RESULTS[memo])
            continue
        kernel = _kernel(key, method.name, tuple(sorted(params.items())), pixel_mm, n)
        matched = False
        if method.unit_energy:
            kernel = kernel.scaled(rd.sum(axis=(0, 1)) / kernel.total())
            matched = True
        out = apply_separable(image, kernel, pixel_mm)
        res: dict[str, Any] = all_metrics(truth, out, perceptual=perceptual)
        res.update({"convolutions_1d": int(kernel.convolutions_1d), "rank": int(kernel.rank),
                    "energy_matched": matched, "pixel_mm": pixel_mm, "signal": name})
        if isinstance(kernel, TapKernel):
            res["taps"] = kernel.taps
        ev.results[label] = res
        if memo is not None:
            _RESULTS[memo] = dict(res)
            while len(_RESULTS) > _RESULTS_MAX:
                _RESULTS.pop(next(iter(_RESULTS)))
        if keep_images:
            ev.images[label] = out
    return ev
