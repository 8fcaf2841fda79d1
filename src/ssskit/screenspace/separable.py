"""The screen-space separable SSS pass (separable-SSS paper section 6, supplement E).

For every pixel p inside the SSS mask, and every separable term r of its kernel, a horizontal then
a vertical 1D pass over the diffuse layer E:

    out(p) = W_c E(p) + sum_k w_kc sum_j b_j f(z_j - z_p) (E(j) - E(p))          (per channel c)

where the taps k sit at o_k * s(p) pixels from p along the pass axis, s(p) = f_axis / z_p the
pixels per mm at the pixel's linear depth z_p (mm; f_axis = fx or fy, so non-square pixels get
their own horizontal and vertical scale; the same as :meth:`Camera.pixels_per_mm`), j runs over the
bilinear texels of the sample position with weights b_j, and W_c = sum_k w_kc. Samples outside the
image or on another profile id take the centre value (f = 0), so nothing bleeds across the mask or
between materials, a constant signal is unchanged and, for a fronto-parallel surface, energy inside
the mask is conserved exactly (the gather is symmetric).

Depth factor f (``depth_mode``):

* ``gaussian`` f = exp(-d_z^2 / (2 tau_max)), tau_max = max(sigma_near, sigma_far)^2: the
  two-Gaussian model's depth correction, supplement E (equation after S.9);
* ``follow``   f = max(0, 1 - |d_z| / width): a follow-surface depth test for tabulated kernels,
  rejecting samples more than one kernel width (the axis standard deviation, mm) off the surface;
* ``none``     f = 1 inside the region (depth-unaware).

Jitter (paper section 6): taps closer to the centre than ``jitter`` x the kernel size (the taps'
full span, see :meth:`SeparableTaps.jitter_count`) are taken along axes rotated by a per-pixel
random angle theta(x, y, frame, seed) (:func:`ssskit.sampling.hashes.jitter_angles`, a counter-based
hash, so the same seed gives the same image on any thread count and backend), with 2D bilinear
fetches.

All profile ids of a G-buffer are filtered in one pass: a plan (:mod:`ssskit.backends.plan`) holds
each id's tap rows, and a backend (:mod:`ssskit.backends`) executes it.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from ..backends import build_separable_plan, get_backend
from ..backends.plan import SeparablePlan, per_id, profile_ids
from ..errors import GBufferError, PassError
from ..quantities import check_instance
from ..sampling.taps import SeparableTaps
from .gbuffer import GBuffer
from .settings import PassSettings


def default_depth_mode(taps: SeparableTaps | Mapping[int, SeparableTaps]) -> str:
    """``gaussian`` if every kernel has a depth-correction width (the two-Gaussian model,
    supplement E), else ``follow``. ``taps``: one SeparableTaps or a mapping id -> taps."""
    values = [taps] if isinstance(taps, SeparableTaps) else list(taps.values())
    return "gaussian" if values and all(t.tau_max_mm2 is not None for t in values) else "follow"


def _settings(settings: PassSettings | None, overrides: dict[str, Any]) -> PassSettings:
    base = check_instance(PassSettings() if settings is None else settings, PassSettings, "settings", PassError)
    return base.replace(**overrides) if overrides else base


def _taps_by_id(taps: SeparableTaps | Mapping[int, SeparableTaps], ids: Iterable[int]) -> dict[int, SeparableTaps]:
    return per_id(taps, SeparableTaps, ids, "taps")  # (SeparableTaps: ssskit.sampling.make_taps)


def plan_for(taps: SeparableTaps | Mapping[int, SeparableTaps], ids: Iterable[int], fx: float, fy: float, settings: PassSettings) -> SeparablePlan:
    """The pass plan for profile ``ids`` (each with its taps) under ``settings``."""
    by_id = _taps_by_id(taps, ids)
    mode = settings.depth_mode or default_depth_mode(by_id or taps)
    return build_separable_plan(by_id, fx, fy, jitter=settings.jitter, depth_mode=mode, frame=settings.frame,
                                seed=settings.seed)


def separable_sss(gbuffer: GBuffer, taps: SeparableTaps | Mapping[int, SeparableTaps],
                  settings: PassSettings | None = None, **overrides: Any) -> np.ndarray:
    """Blurred diffuse layer (H, W, 3) float32: every profile region filtered with its taps, in one pass.

    ``taps``: one :class:`SeparableTaps` for every region, or a mapping profile id -> taps.
    ``settings`` (:class:`PassSettings`; keyword ``overrides`` such as ``jitter=0.3`` replace its
    fields). Pixels without SSS keep their diffuse value.
    """
    check_instance(gbuffer, GBuffer, "gbuffer", GBufferError)
    s = _settings(settings, overrides)
    backend = get_backend(s.backend)
    ids = profile_ids(gbuffer.profile_id)
    cam = gbuffer.camera
    plan = plan_for(taps, ids, cam.fx, cam.fy, s)
    out = backend.separable(plan, gbuffer.diffuse, gbuffer.depth_mm, plan.slot_map(gbuffer.profile_id))
    return np.asarray(out, dtype=np.float32)


def filter_arrays(diffuse: np.ndarray, depth_mm: np.ndarray, fx: float, fy: float, taps: SeparableTaps,
                  settings: PassSettings | None = None, **overrides: Any) -> np.ndarray:
    """The separable SSS of ``diffuse`` (H, W, 3) for one region given as arrays.

    ``depth_mm`` (H, W): linear depth in mm where the region has SSS and +inf elsewhere (stencil);
    ``fx``/``fy``: focal lengths in pixels. Returns a new (H, W, 3) array in the backend's float type;
    pixels outside the region are copied. 2R passes for a rank-R kernel, horizontal then vertical.
    """
    s = _settings(settings, overrides)  # (taps: refused by plan_for's per_id unless SeparableTaps)
    backend = get_backend(s.backend)
    depth_mm = np.asarray(depth_mm)  # shapes are checked by the backend (backends.SEPARABLE_FRAME)
    plan = plan_for(taps, [1], fx, fy, s)
    slots = np.isfinite(depth_mm).astype(np.int32)
    return backend.separable(plan, diffuse, depth_mm, slots)
