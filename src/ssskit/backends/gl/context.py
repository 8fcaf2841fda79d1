"""The gl backend's OpenGL context: :mod:`ssskit.compute.gl` (the context, compute shaders with readable
errors, GPU timing), which lives below ``profiles`` so that the Monte Carlo engine can share it."""

from __future__ import annotations

from ...compute.gl import (REQUIREMENTS, ShaderError, checked_times, compile_compute, context, is_software, renderer,
                           time_gpu)

__all__ = ["REQUIREMENTS", "ShaderError", "checked_times", "compile_compute", "context", "is_software", "renderer",
           "time_gpu"]
