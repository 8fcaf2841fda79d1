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

import numpy as np

from ...errors import BackendError
from ..base import Backend, check_frame


class GLBackend(Backend):
    name = "gl"
    description = "GLSL compute shaders through moderngl/EGL, float32: a GPU, or Mesa's llvmpipe on the CPU"
    dtype = np.float32
    passes = frozenset({"separable", "burley", "adaptive"})

    def __init__(self):
        self._lock = threading.Lock()

    def availability(self) -> tuple[bool, str]:
        from .context import context, renderer

        try:
            context()
        except BackendError as e:
            return False, str(e)
        return True, renderer()

    def separable(self, plan, diffuse, depth_mm, slots):
        from .separable import SeparableFrame

        check_frame(diffuse, depth_mm, slots, plan)
        slots = np.asarray(slots)
        if slots.size == 0:
            return np.array(diffuse, dtype=np.float32, copy=True)
        return self._run(lambda: SeparableFrame(plan, np.asarray(diffuse, np.float32),
                                                np.asarray(depth_mm, np.float32), slots))

    def burley(self, plan, diffuse, depth_mm, slots, spp, pyramid=None):
        from ..base import check_burley_frame
        from .burley import BurleyFrame

        spp = check_burley_frame(plan, diffuse, depth_mm, slots, spp)
        slots = np.asarray(slots)
        if slots.size == 0:
            return np.array(diffuse, dtype=np.float32, copy=True)
        return self._run(lambda: BurleyFrame(plan, np.asarray(diffuse, np.float32),
                                             np.asarray(depth_mm, np.float32), slots, spp))

    def adaptive_counts(self, plan, history, mask, motion=None, valid=None):
        """The *estimate* of :mod:`ssskit.backends.adaptive_plan` (``adaptive.comp``), host arrays in and out."""
        return self._guide(plan, history, mask, motion, valid, None, None)[1]

    def adaptive_update(self, plan, history, rgb, counts, mask, motion=None, valid=None):
        """The *update* of :mod:`ssskit.backends.adaptive_plan` (``adaptive.comp``), host arrays in and out."""
        from ...errors import PassError

        if rgb is None or counts is None:
            raise PassError("the history update needs the pass's result and the frame's sample counts")
        return self._guide(plan, history, mask, motion, valid, rgb, counts)

    def _guide(self, *args):
        from .adaptive import guide
        from .context import context

        with self._lock:
            ctx = context()
            try:
                return guide(*args)
            finally:
                ctx.__exit__(None, None, None)

    def adaptive_runner(self, plan, history):
        """The frame loop with history, counts and images on the device (:class:`~.adaptive.GLAdaptiveRunner`)."""
        from .adaptive import GLAdaptiveRunner

        return GLAdaptiveRunner(self, plan, history)

    def _run(self, make_frame):
        """Upload, run and read back one frame under the backend's lock, then free its device images; the
        context is released after, so another thread can make it current."""
        from .context import context

        with self._lock:
            ctx = context()
            frame = None
            try:
                frame = make_frame()
                frame.run()
                return frame.read()
            finally:
                if frame is not None:
                    frame.release()
                ctx.__exit__(None, None, None)


__all__ = ["GLBackend"]
