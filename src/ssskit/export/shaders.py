"""GLSL compute shaders to HLSL: glslangValidator (GLSL -> SPIR-V), then spirv-cross (SPIR-V -> HLSL).

Whole-shader exports: the separable pass (:func:`separable_shader`) and the transmittance pass
(:func:`transmission_shader`), the gl backend's own GLSL with the parameters baked in. The translation step: the ``gl`` backend's GLSL compute source (OpenGL
GLSL, loose uniforms allowed) is compiled to SPIR-V with OpenGL semantics (``glslangValidator -G``,
locations and bindings mapped automatically), which spirv-cross turns into HLSL for a chosen
shader model. :func:`check_hlsl` compiles HLSL back to SPIR-V with glslang's own HLSL front end:
that proves the HLSL parses and type-checks, not what a D3D compiler (fxc/dxc) would say.

The tools come from the Debian packages ``glslang-tools`` and ``spirv-cross``; when one is missing,
:class:`ShaderToolError` says which and how to install it.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Any

from ..errors import SsskitError
from ..quantities import Choice

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


def check_hlsl(source: str, stage: str = "comp", entry: str = "main", defines: dict | None = None) -> bytes:
    """Compile HLSL back to SPIR-V with glslang's HLSL front end (``-D -e entry``, ``-DNAME=value`` for
    ``defines``); returns the SPIR-V."""
    exe = tool_path(GLSLANG)
    with tempfile.TemporaryDirectory(prefix="ssskit-hlsl-") as tmp:
        src = Path(tmp) / "shader.hlsl"
        out = Path(tmp) / "shader.spv"
        src.write_text(source, encoding="utf-8")
        flags = [f"-D{k}={int(v)}" for k, v in (defines or {}).items()]
        _run([exe, "-D", "-V", *flags, "-e", entry, "-S", stage, str(src), "-o", str(out)],
             "glslangValidator (HLSL -> SPIR-V)")
        return out.read_bytes()


def with_defines(source: str, **defines: int) -> str:
    """``source`` with ``#define NAME value`` lines right after its ``#version`` line."""
    head, sep, rest = source.partition("\n#version 430\n")
    if not sep:
        raise ShaderToolError("the shader has no '#version 430' line")
    lines = "".join(f"#define {k} {int(v)}\n" for k, v in defines.items())
    return head + sep + lines + rest


#: a loose, non-opaque uniform declaration of the gl backend's GLSL (one per line, a comment may follow)
_LOOSE_UNIFORM = re.compile(r"^uniform\s+(bool|int|uint|float|[biu]?vec[234]|mat[234])\s+(\w+)\s*;[^\n]*\n", re.M)

#: the constant buffer of the HLSL export: its name and register (b0)
PARAMS_BLOCK = "SSSParams"


def uniform_block(source: str, name: str = PARAMS_BLOCK, binding: int = 0) -> tuple[str, list[tuple[str, str]]]:
    """``source`` with its loose non-opaque uniforms gathered, in declaration order, into one
    ``layout(std140, binding = binding) uniform name { ... };`` block where the first of them stood, and the
    (type, name) list of its members.

    The gl backend sets loose uniforms by name; a D3D engine binds one constant buffer, whose layout must
    not depend on the pass. Compiled alone, each pass lists only the uniforms it uses, in its own order
    (spirv-cross's ``$Globals``); in a block, every member keeps its std140 offset in every pass
    (OpenGL 4.3 core specification, Sec. 7.6.2.2, "Standard Uniform Block Layout").
    """
    members = [(m.group(1), m.group(2)) for m in _LOOSE_UNIFORM.finditer(source)]
    if not members:
        return source, []
    first = _LOOSE_UNIFORM.search(source)
    assert first is not None
    body = "".join(f"    {t} {n};\n" for t, n in members)
    block = f"layout(std140, binding = {int(binding)}) uniform {name} {{\n{body}}};\n"
    rest = _LOOSE_UNIFORM.sub("", source[first.start():])
    return source[:first.start()] + block + rest, members


def separable_shader(taps: Any, language: str, jitter: float = 0.1, depth_mode: str | None = None,
                     stage: str = "compute") -> str:
    """The whole separable-SSS compute shader for ``taps`` (:class:`~ssskit.sampling.SeparableTaps`), the
    same source the ``gl`` backend runs (:func:`ssskit.backends.gl.separable.export_source`), the taps
    baked in as constants.

    ``glsl``: one GLSL 4.30 file; each pass is the file compiled with ``VERTICAL`` (0, 1) and ``TERM``
    (0 .. rank - 1) defined. ``hlsl``: every pass translated (glslangValidator, spirv-cross) and kept in
    ``#if VERTICAL == v && TERM == r`` blocks of one file, so the engine compiles it the same way; the
    parameters are one constant buffer, ``cbuffer SSSParams : register(b0)``, laid out alike in every pass
    (:func:`uniform_block`).
    ``depth_mode`` None: the kernel's default (:func:`ssskit.screenspace.separable.default_depth_mode`).
    ``stage`` ``fragment`` (``glsl`` only): the GLSL ES 3.00 fragment form of the same per-pixel body
    (:func:`ssskit.backends.gl.separable.export_fragment_source`), for WebGL2 and OpenGL ES 3; the text the
    live viewer (``ssskit view``) runs.
    """
    from ..backends import build_separable_plan
    from ..backends.gl.separable import export_source
    from ..screenspace.separable import default_depth_mode

    language, stage = _form(language, stage)
    plan = build_separable_plan({1: taps}, 1.0, 1.0, jitter=jitter, depth_mode=depth_mode or default_depth_mode(taps))
    if stage == "fragment":
        from ..backends.gl.separable import export_fragment_source

        return export_fragment_source(plan)
    glsl = export_source(plan)
    if language == "glsl":
        return glsl
    notes = glsl[glsl.index("// ---- how to run it"):glsl.index("// ---- generated by")]
    blocked, members = uniform_block(glsl)
    blocks = []
    for term in range(len(plan.terms)):
        for vertical in (0, 1):
            hlsl = glsl_to_hlsl(with_defines(blocked, VERTICAL=vertical, TERM=term))
            # spirv-cross names an unnamed block's members _<id>_<member>, the id differing by pass
            hlsl = re.sub(r"\b_\d+_(" + "|".join(n for _, n in members) + r")\b", r"\1", hlsl)
            blocks.append(f"#if VERTICAL == {vertical} && TERM == {term}\n{hlsl.rstrip()}\n#endif\n")
    head = ("// ssskit: the separable SSS compute shader, HLSL translated from ssskit's GLSL by glslangValidator\n"
            "// and spirv-cross (shader model 5.0). Compile each pass with VERTICAL (0, 1) and TERM defined;\n"
            "// texture t0 / sampler s0: the source, u0: the destination (and t1: slots with several ids);\n"
            f"// constant buffer b0 ({PARAMS_BLOCK}, one layout for every pass): "
            + ", ".join(n for _, n in members) + ".\n"
            + notes)
    return head + "#ifndef VERTICAL\n#define VERTICAL 0\n#endif\n#ifndef TERM\n#define TERM 0\n#endif\n" + "".join(blocks)


def _form(language: str, stage: str) -> tuple[str, str]:
    """A whole shader's language and stage, checked: the fragment form is GLSL ES 3.00 only."""
    language = Choice("shader language", ("glsl", "hlsl")).check(language, error=ShaderToolError)
    stage = Choice("shader stage", ("compute", "fragment")).check(stage, error=ShaderToolError)
    if stage == "fragment" and language != "glsl":
        raise ShaderToolError("the fragment form is GLSL ES 3.00 (language glsl); HLSL is written as compute shaders")
    return language, stage


def transmission_shader(plan: Any, language: str, stage: str = "compute") -> str:
    """The transmittance pass's compute shader for ``plan`` (:class:`~ssskit.backends.transmission_plan.TransmissionPlan`:
    a material's model per profile id), the same source the ``gl`` backend runs
    (:func:`ssskit.backends.gl.transmission.transmission_export_source`) with the model's parameter arrays baked in
    as constants (``COEF_A``, ``COEF_B``, ``COEF_C``, ``SCALE``, ``WRAP``; an ``unreal`` slot's ``LUT``, ``OD_PER_MM``,
    ``OD_OFFSET``). ``glsl``: that file; ``hlsl``: its translation (glslangValidator, spirv-cross), the two
    uniforms in one constant buffer ``cbuffer SSSParams : register(b0)`` (:func:`uniform_block`), each table a
    ``static const`` array ``NAME_VALUES`` copied into ``NAME``. ``stage`` ``fragment`` (``glsl`` only): the GLSL
    ES 3.00 fragment form of the same per-pixel body
    (:func:`ssskit.backends.gl.transmission.transmission_fragment_source`), what the live viewer runs."""
    from ..backends.gl.transmission import transmission_export_source, transmission_fragment_source

    language, stage = _form(language, stage)
    if stage == "fragment":
        return transmission_fragment_source(plan)
    glsl = transmission_export_source(plan)
    if language == "glsl":
        return glsl
    notes = glsl[glsl.index("// ---- how to run it"):glsl.index("// ---- generated by")]
    # the tables as named (private) arrays: a const array would reach HLSL as an anonymous constant (_31 ...)
    named = re.sub(r"^const (float|int) (\w+)\[", r"\1 \2[", glsl, flags=re.M)
    blocked, members = uniform_block(named)
    hlsl = glsl_to_hlsl(blocked)
    hlsl = re.sub(r"\b_\d+_(" + "|".join(n for _, n in members) + r")\b", r"\1", hlsl)
    tables = set(re.findall(r"^static (?:float|int) (\w+)\[", hlsl, re.M))
    for name, const in re.findall(r"^\s*(\w+) = (_\d+);$", hlsl, re.M):  # TABLE = _31;  ->  TABLE_VALUES
        if name in tables:
            hlsl = re.sub(rf"\b{const}\b", f"{name}_VALUES", hlsl)
    head = ("// ssskit: the transmittance compute shader, HLSL translated from ssskit's GLSL by glslangValidator and\n"
            "// spirv-cross (shader model 5.0); the buffers are ByteAddressBuffers t0-t4 (inputs) and u5 (the result)\n"
            "// in the GLSL's binding order, the constant buffer b0 (" + PARAMS_BLOCK + "): "
            + ", ".join(n for _, n in members) + ".\n" + notes)
    return head + hlsl


__all__ = ["PARAMS_BLOCK", "ShaderToolError", "check_hlsl", "glsl_to_hlsl", "glsl_to_spirv", "separable_shader", "spirv_to_hlsl",
           "tool_path", "tools_available", "transmission_shader", "uniform_block", "with_defines"]
