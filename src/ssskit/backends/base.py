"""The backend contract: one small method per screen-space pass, and whether the backend can run here.

A backend turns a pass's *plan* (what to compute, built once per frame by ``ssskit.screenspace``)
and the frame's images into the result. Backends own their scratch buffers; every result they
return is a new array that nothing else writes to (results never alias scratch space).

Frame inputs of the separable pass (all pixel-aligned):

* ``diffuse`` (H, W, 3) linear light, the signal blurred;
* ``depth_mm`` (H, W) linear camera depth in mm, finite wherever ``slots`` > 0;
* ``slots`` (H, W) int32, the plan's profile slot of each pixel (0 = no SSS: copied unchanged).

The Burley pass (:mod:`ssskit.backends.burley_plan`) takes the same images and ``spp``, one sample
count or an (H, W) integer count image. Every backend has the separable pass; a backend that also
implements the Burley pass names it in ``passes``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING

import numpy as np

from .plan import SeparablePlan

if TYPE_CHECKING:
    from .burley_plan import BurleyPlan


class Backend(ABC):
    """A way to run the screen-space passes (numpy reference, numba CPU, ...)."""

    #: registry name
    name: str = ""
    #: one line for ``ssskit backends``
    description: str = ""
    #: the float type the backend computes in (the parity tolerance table is keyed by it)
    dtype: type = np.float64
    #: the passes this backend implements ("separable" always; "burley" where :meth:`burley` is overridden)
    passes: frozenset[str] = frozenset({"separable"})

    def availability(self) -> tuple[bool, str]:
        """(True, details) if the backend can run on this machine, else (False, why not)."""
        return True, ""

    @abstractmethod
    def separable(self, plan: SeparablePlan, diffuse: np.ndarray, depth_mm: np.ndarray,
                  slots: np.ndarray) -> np.ndarray:
        """The separable pass (see :mod:`ssskit.backends.plan`): a new (H, W, 3) array."""

    def burley(self, plan: BurleyPlan, diffuse: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
               spp) -> np.ndarray:
        """The Burley Monte Carlo pass (see :mod:`ssskit.backends.burley_plan`): a new (H, W, 3) array.

        ``spp``: samples per pixel, an int or an (H, W) integer image (checked by
        :func:`check_burley_frame`). A backend without it raises :class:`~ssskit.errors.BackendError`.
        """
        from ..errors import BackendError

        raise BackendError(f"backend {self.name!r} has no Burley pass")


def check_frame(diffuse: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray, plan: SeparablePlan,
                values: bool = True) -> None:
    """Shapes and slot range of the separable pass's inputs, or a precise error; with ``values`` also
    that every pixel with SSS has a positive finite depth (a backend may check that in its own pass)."""
    from ..errors import PassError

    if np.ndim(depth_mm) != 2 or np.shape(diffuse) != tuple(np.shape(depth_mm)) + (3,):
        raise PassError(f"diffuse must be (H, W, 3) and depth (H, W) of the same size, got {np.shape(diffuse)} "
                        f"and {np.shape(depth_mm)}")
    if np.shape(slots) != np.shape(depth_mm):
        raise PassError(f"slots must be (H, W) like depth, got {np.shape(slots)}")
    if slots.size and (int(slots.min()) < 0 or int(slots.max()) >= plan.slots):
        raise PassError(f"slots must lie in [0, {plan.slots - 1}]")
    if not values:
        return
    inside = slots > 0
    if not np.all(np.isfinite(depth_mm[inside])) or np.any(depth_mm[inside] <= 0):
        raise PassError("depth must be positive and finite on every pixel with SSS")


def check_burley_frame(plan: BurleyPlan, diffuse: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray, spp,
                       values: bool = True):
    """:func:`check_frame` for the Burley pass plus its sample counts; returns the counts (an int, or an
    (H, W) int64 image) or raises :class:`~ssskit.errors.PassError`."""
    from .burley_plan import check_counts

    check_frame(diffuse, depth_mm, slots, plan, values)  # type: ignore[arg-type]
    return check_counts(spp, np.shape(depth_mm))
