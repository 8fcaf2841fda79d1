"""The gl backend's OpenGL context: :mod:`ssskit.compute.gl` (the context, compute shaders with readable
errors, GPU timing), which lives below ``profiles`` so that the Monte Carlo engine can share it."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...compute.gl import (REQUIREMENTS, ShaderError, checked_times, compile_compute, context, is_software, renderer,
                           time_gpu)

if TYPE_CHECKING:
    import moderngl

#: every gl pass's compiled compute shaders, by source (cleared when full)
_PROGRAMS: dict[str, moderngl.ComputeShader] = {}


def program(source: str, name: str) -> moderngl.ComputeShader:
    """The compute shader of ``source``, compiled once (``name``: the pass, in a compile error)."""
    prog = _PROGRAMS.get(source)
    if prog is None:
        if len(_PROGRAMS) > 64:
            _PROGRAMS.clear()
        prog = _PROGRAMS[source] = compile_compute(source, name)
    return prog


__all__ = ["REQUIREMENTS", "ShaderError", "checked_times", "compile_compute", "context", "is_software", "program",
           "renderer", "time_gpu"]
