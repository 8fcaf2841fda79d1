"""The ``gl`` backend: the screen-space passes as GLSL 4.30 compute shaders through moderngl and EGL.

It runs on any GPU with an EGL driver and OpenGL 4.3, and on Mesa's llvmpipe (the CPU) where there
is none, so the tests run the very shader a GPU runs. Images are RGBA32F textures read with
``texelFetch`` and written with ``imageStore``; the pass plan's tables are baked into each shader as
constants (:func:`~ssskit.backends.gl.separable.separable_source`). Arithmetic is float32.

Needs the Python package ``moderngl`` and, on Debian/Ubuntu, ``libegl1 libgl1-mesa-dri
libegl-mesa0``; without them :meth:`GLBackend.availability` says what is missing and the CPU
backends keep working.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...errors import BackendError
from ..base import Backend

if TYPE_CHECKING:
    from ..adaptive_plan import AdaptivePlan, GuideFrame
    from ..base import AdaptiveRunner
    from ..burley_plan import BurleyPlan, MipPyramid
    from ..plan import SeparablePlan
    from ..spread_plan import SpreadPlan
    from ..transmission_plan import TransmissionPlan


class _Frame(Protocol):
    """A frame on the device (SeparableFrame, BurleyFrame): run, read back, free."""

    def run(self) -> None: ...

    def read(self) -> np.ndarray: ...

    def release(self) -> None: ...


class GLBackend(Backend):
    name = "gl"
    description = "GLSL compute shaders through moderngl/EGL, float32: a GPU, or Mesa's llvmpipe on the CPU"
    dtype = np.float32
    passes = frozenset({"separable", "burley", "adaptive", "transmission", "spread"})

    def __init__(self) -> None:
        self._lock = threading.Lock()

    def availability(self) -> tuple[bool, str]:
        from .context import context, renderer

        try:
            context()
        except BackendError as e:
            return False, str(e)
        return True, renderer()

    def _separable(self, plan: SeparablePlan, diffuse: np.ndarray, depth_mm: np.ndarray,
                   slots: np.ndarray) -> np.ndarray:
        from .separable import SeparableFrame

        return self._run(lambda: SeparableFrame(plan, np.asarray(diffuse, np.float32),
                                                np.asarray(depth_mm, np.float32), np.asarray(slots)))

    def _burley(self, plan: BurleyPlan, diffuse: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
                spp: NDArray[np.int64] | int, pyramid: MipPyramid | None) -> np.ndarray:
        from .burley import BurleyFrame

        return self._run(lambda: BurleyFrame(plan, np.asarray(diffuse, np.float32),
                                             np.asarray(depth_mm, np.float32), np.asarray(slots), spp))

    def _transmission(self, plan: TransmissionPlan, slots: np.ndarray, light_uvz: np.ndarray, shadow_mm: np.ndarray,
                      n_dot_l: np.ndarray, light_rgb: np.ndarray) -> np.ndarray:
        """The transmittance pass (``gl/transmission.py``), host arrays in and out."""
        from .context import context
        from .transmission import run_transmission

        with self._lock:
            ctx = context()
            try:
                return run_transmission(plan, slots, light_uvz, shadow_mm, n_dot_l, light_rgb)
            finally:
                ctx.__exit__(None, None, None)

    def _transmission_spread(self, plan: SpreadPlan, exitance: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
                             light_uvz: np.ndarray, shadow_mm: np.ndarray) -> np.ndarray:
        """The transmitted light's lateral spread (``gl/spread.py``), host arrays in and out."""
        from .context import context
        from .spread import run_spread

        with self._lock:
            ctx = context()
            try:
                return run_spread(plan, exitance, depth_mm, slots, light_uvz, shadow_mm)
            finally:
                ctx.__exit__(None, None, None)

    def _adaptive_counts(self, plan: AdaptivePlan, frame: GuideFrame) -> NDArray[np.int64]:
        """The *estimate* of :mod:`ssskit.backends.adaptive_plan` (``adaptive.comp``), host arrays in and out."""
        return self._guide(plan, frame)[1]

    def _adaptive_update(self, plan: AdaptivePlan, frame: GuideFrame) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        """The *update* of :mod:`ssskit.backends.adaptive_plan` (``adaptive.comp``), host arrays in and out."""
        new, n = self._guide(plan, frame)
        assert new is not None  # an update returns the new history
        return new, n

    def _guide(self, plan: AdaptivePlan, frame: GuideFrame) -> tuple[NDArray[np.float32] | None, NDArray[np.int64]]:
        from .adaptive import guide
        from .context import context

        with self._lock:
            ctx = context()
            try:
                return guide(plan, frame)
            finally:
                ctx.__exit__(None, None, None)

    def adaptive_runner(self, plan: AdaptivePlan, history: ArrayLike) -> AdaptiveRunner:
        """The frame loop with history, counts and images on the device (:class:`~.adaptive.GLAdaptiveRunner`)."""
        from .adaptive import GLAdaptiveRunner

        return GLAdaptiveRunner(self, plan, history)

    def _run(self, make_frame: Callable[[], _Frame]) -> np.ndarray:
        """Upload, run and read back one frame under the backend's lock, then free its device images; the
        context is released after, so another thread can make it current."""
        from .context import context

        with self._lock:
            ctx = context()
            frame: _Frame | None = None
            try:
                frame = make_frame()
                frame.run()
                return frame.read()
            finally:
                if frame is not None:
                    frame.release()
                ctx.__exit__(None, None, None)


__all__ = ["GLBackend"]
