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

``FORMATS`` lists what ``ssskit export --format`` writes and the file suffixes each accepts;
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

#: ``--format bn`` crops the grid to the part holding this fraction of each channel's kernel mass
BN_SUPPORT = 0.999
#: format -> (accepted output suffixes, whether it exports a kernel (True) or engine parameters (False))
FORMATS: dict[str, tuple[tuple[str, ...], bool]] = {
    "hlsl": ((".hlsl", ".hlsli", ".h", ".fx", ".fxh", ".usf", ".ush"), True),
    "glsl": ((".glsl", ".h", ".comp", ".frag", ".inc"), True),
    "bn": ((".bn",), True),
    "json": ((".json",), True),
    # engine parameters: JSON, or the engine's own file (the suffix chooses)
    "unreal": ((".json", ".py"), False),
    "unity": ((".json", ".asset"), False),
    "blender": ((".json", ".py"), False),
    "materialx": ((".mtlx",), False),
    # whole compute shaders of the separable pass, the taps baked in (the gl backend's source); .frag: its
    # GLSL ES 3.00 fragment form (the same per-pixel body; what ssskit view runs)
    "glsl-shader": ((".comp", ".glsl", ".frag"), True),
    "hlsl-shader": ((".hlsl", ".fx", ".usf"), True),
}


def export_kernel(kernel: Any, fmt: str, path: str | Path, taps: int | None = None, tap_method: str = "importance",
                  comment: str = "", jitter: float | None = None, depth_mode: str | None = None) -> None:
    """Write ``kernel`` in a kernel format (``hlsl``, ``glsl``, ``bn``, ``json``, ``glsl-shader``,
    ``hlsl-shader``) to ``path`` (atomic). The shaders take ``jitter`` (None: :func:`~.shaders.separable_shader`'s default, the pass's 0.1) and
    ``depth_mode`` (the pass's); another format given either, or ``bn`` / ``json`` given ``taps`` (they write
    the tabulated kernel itself), is refused before anything is written."""
    from ..io import check_suffix, write_text
    from ..kernels.base import save_kernel

    key = fmt.strip().lower() if isinstance(fmt, str) else fmt
    if key not in FORMATS or not FORMATS[key][1]:
        raise KernelError(f"{fmt!r} is not a kernel format; choose from "
                          f"{', '.join(k for k, (_, kern) in FORMATS.items() if kern)}")
    shader = key in ("glsl-shader", "hlsl-shader")
    if not shader and (jitter is not None or depth_mode is not None):
        raise KernelError(f"jitter and depth_mode apply to the whole shaders only (glsl-shader, hlsl-shader), not to "
                          f"the {key} format; got jitter={jitter!r}, depth_mode={depth_mode!r}")
    if key in ("bn", "json") and taps is not None:
        raise KernelError(f"taps do not apply to the {key} format (it writes the tabulated kernel itself), got {taps!r}")
    check_suffix(path, FORMATS[key][0], f"{key} output")
    if key in ("glsl-shader", "hlsl-shader"):
        from ..kernels import TapKernel
        from ..sampling.taps import make_taps
        from .shaders import separable_shader

        n = kernel.taps if isinstance(kernel, TapKernel) else (taps or 7)
        given = {} if jitter is None else {"jitter": jitter}  # None: the shader's own default
        stage = "fragment" if Path(path).suffix.lower() == ".frag" else "compute"
        text = separable_shader(make_taps(kernel, n, tap_method), key.split("-")[0], depth_mode=depth_mode,
                                stage=stage, **given)
        if comment and stage == "fragment":  # GLSL ES: the #version line comes before anything, comments too
            version, _, rest = text.partition("\n")
            text = f"{version}\n// {comment}\n{rest}"
        elif comment:
            text = f"// {comment}\n{text}"
        write_text(path, text)
    elif key in LANGUAGES:
        write_text(path, format_shader_arrays(kernel_arrays(kernel, taps, tap_method), key, comment))
    elif key == "bn":
        save_bn(kernel, path, support=BN_SUPPORT)
    else:
        save_kernel(kernel, path)


__all__ = ["ENGINES", "ENGINE_MODELS", "FORMATS", "LANGUAGES", "ShaderArray", "arrays_to_tap_kernel", "bn_bytes",
           "engine_parameters", "export_kernel", "fit_burley", "format_shader_arrays", "kernel_arrays", "load_bn",
           "parse_shader_arrays", "profile_error", "read_bn", "reimport", "save_bn"]
