"""GLSL compute shaders to HLSL: glslangValidator (GLSL -> SPIR-V), then spirv-cross (SPIR-V -> HLSL).

The translation step for whole-shader exports: the ``gl`` backend's GLSL compute source (OpenGL
GLSL, loose uniforms allowed) is compiled to SPIR-V with OpenGL semantics (``glslangValidator -G``,
locations and bindings mapped automatically), which spirv-cross turns into HLSL for a chosen
shader model. :func:`check_hlsl` compiles HLSL back to SPIR-V with glslang's own HLSL front end:
that proves the HLSL parses and type-checks, not what a D3D compiler (fxc/dxc) would say.

The tools come from the Debian packages ``glslang-tools`` and ``spirv-cross``; when one is missing,
:class:`ShaderToolError` says which and how to install it.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

from ..errors import SsskitError

GLSLANG = "glslangValidator"
SPIRV_CROSS = "spirv-cross"
_PACKAGES = {GLSLANG: "glslang-tools", SPIRV_CROSS: "spirv-cross"}
_TIMEOUT_S = 120


class ShaderToolError(SsskitError):
    """A shader tool is missing, or refused the source (its first error line is in the message)."""


def tool_path(name: str) -> str:
    """The executable of ``glslangValidator`` or ``spirv-cross``, or a :class:`ShaderToolError`."""
    path = shutil.which(name)
    if path is None:
        raise ShaderToolError(f"{name} is not installed: it comes with the Debian package {_PACKAGES[name]} "
                              f"(apt-get install glslang-tools spirv-cross)")
    return path


def tools_available() -> tuple[bool, str]:
    """(whether both tools run here, why not)."""
    try:
        tool_path(GLSLANG)
        tool_path(SPIRV_CROSS)
    except ShaderToolError as exc:
        return False, str(exc)
    return True, "glslangValidator and spirv-cross found"


def _run(args: list[str], what: str) -> str:
    proc = subprocess.run(args, capture_output=True, text=True, timeout=_TIMEOUT_S, check=False)
    if proc.returncode != 0:
        lines = [ln.strip() for ln in (proc.stdout + "\n" + proc.stderr).splitlines()]
        first = next((ln for ln in lines if ln.startswith("ERROR")), next((ln for ln in lines if ln), "no output"))
        raise ShaderToolError(f"{what} failed: {first}")
    return proc.stdout


def glsl_to_spirv(source: str, stage: str = "comp") -> bytes:
    """SPIR-V of an OpenGL GLSL shader (``glslangValidator -G --aml --amb -S stage``)."""
    exe = tool_path(GLSLANG)
    with tempfile.TemporaryDirectory(prefix="ssskit-glsl-") as tmp:
        src = Path(tmp) / f"shader.{stage}"
        out = Path(tmp) / "shader.spv"
        src.write_text(source, encoding="utf-8")
        _run([exe, "-G", "--aml", "--amb", "-S", stage, str(src), "-o", str(out)], "glslangValidator (GLSL -> SPIR-V)")
        return out.read_bytes()


def spirv_to_hlsl(spirv: bytes, shader_model: int = 50) -> str:
    """HLSL of a SPIR-V module (``spirv-cross --hlsl --shader-model N``)."""
    exe = tool_path(SPIRV_CROSS)
    with tempfile.TemporaryDirectory(prefix="ssskit-spv-") as tmp:
        spv = Path(tmp) / "shader.spv"
        spv.write_bytes(spirv)
        return _run([exe, str(spv), "--hlsl", "--shader-model", str(int(shader_model))], "spirv-cross (SPIR-V -> HLSL)")


def glsl_to_hlsl(source: str, stage: str = "comp", shader_model: int = 50) -> str:
    """HLSL translated from an OpenGL GLSL shader (a compute shader by default), via SPIR-V.

    Raises :class:`ShaderToolError` if a tool is missing or rejects the source.
    """
    if not isinstance(source, str) or not source.strip():
        raise ShaderToolError("the GLSL source is empty")
    return spirv_to_hlsl(glsl_to_spirv(source, stage), shader_model)


def check_hlsl(source: str, stage: str = "comp", entry: str = "main") -> bytes:
    """Compile HLSL back to SPIR-V with glslang's HLSL front end (``-D -e entry``); returns the SPIR-V."""
    exe = tool_path(GLSLANG)
    with tempfile.TemporaryDirectory(prefix="ssskit-hlsl-") as tmp:
        src = Path(tmp) / "shader.hlsl"
        out = Path(tmp) / "shader.spv"
        src.write_text(source, encoding="utf-8")
        _run([exe, "-D", "-V", "-e", entry, "-S", stage, str(src), "-o", str(out)], "glslangValidator (HLSL -> SPIR-V)")
        return out.read_bytes()


__all__ = ["ShaderToolError", "check_hlsl", "glsl_to_hlsl", "glsl_to_spirv", "spirv_to_hlsl", "tool_path",
           "tools_available"]
