"""Exports engines load: tap kernels as shader arrays, the pre-integrated kernel as ``.bn``, engine
material parameters (Unreal, Unity HDRP, Blender), and GLSL-to-HLSL translation.

* :mod:`.arrays` -- HLSL / GLSL ``float4 kernel[N]`` in the 2012 separable-SSS demo layout, and back;
* :mod:`.bn` -- the binary kernel files of the 2015 separable-SSS code, write and read;
* :mod:`.engines` -- engine parameters from a profile, their re-import and the error of the round trip;
* :mod:`.blender`, :mod:`.unreal`, :mod:`.unity`, :mod:`.materialx` -- each tool's importable file (a Blender
  script and the Cycles slab that judges it, an Unreal editor script, an HDRP .asset, a MaterialX document);
* :mod:`.readers` -- engine files read back into (A, d) and a material;
* :mod:`.shaders` -- the whole separable compute shader (``separable_shader``: the ``gl`` backend's
  GLSL with the taps baked in, and its HLSL translation through glslangValidator and spirv-cross).

* :mod:`.api` -- one export request: :class:`ExportSettings`, :func:`export` and ``FORMATS``, the registry of
  formats (:class:`Format`: suffixes, writer, reader, the options that apply), filled by :mod:`.formats`.

:func:`export_kernel` writes a kernel format.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import KernelError
from .arrays import (
    LANGUAGES,
    ShaderArray,
    arrays_to_tap_kernel,
    format_shader_arrays,
    kernel_arrays,
    parse_shader_arrays,
)
from .bn import bn_bytes, load_bn, read_bn, save_bn
from .engines import ENGINE_MODELS, ENGINES, engine_parameters, fit_burley, profile_error, reimport
from .api import FORMATS, ExportSettings, Format, export
from .formats import BN_SUPPORT, export_kernel  # (importing formats registers the formats in FORMATS)

__all__ = ["ENGINES", "ENGINE_MODELS", "ExportSettings", "FORMATS", "Format", "LANGUAGES", "export", "ShaderArray", "arrays_to_tap_kernel", "bn_bytes",
           "engine_parameters", "export_kernel", "fit_burley", "format_shader_arrays", "kernel_arrays", "load_bn",
           "parse_shader_arrays", "profile_error", "read_bn", "reimport", "save_bn"]
