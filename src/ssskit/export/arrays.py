"""Tap kernels as HLSL / GLSL shader arrays, in the layout of the 2012 separable-SSS demo header.

The demo (Jimenez & Gutierrez, ``SeparableSSS.h``, github.com/iryoku/separable-sss, 2012) declares
``float4 kernel[SSSS_N_SAMPLES]``: RGB weights in ``.rgb``, the tap offset in ``.a``, the centre tap
first (the pixel itself: ``SSSSBlurPS`` reads only its ``.rgb``), then the other taps in ascending
offset (``SeparableSSS::calculateKernel`` moves the centre to the front and keeps the rest in order).
Unreal's ``ComputeMirroredSSSKernel``, Godot and legacy Eevee copy that layout.

Units. Offsets are written in **mm** (ssskit's length unit). The demo's pass moves a tap at offset
``a`` by ``a * sssWidth * scale / 3`` ("divide by 3 as the kernels range from -3 to 3", with
``scale = distanceToProjectionWindow / depth``), i.e. offset ``a`` stands for ``a * sssWidth / 3``
scene units. With offsets in mm the kernel is physical when ``sssWidth`` is 3 mm in scene units
(0.003 when a unit is a metre, 0.3 for centimetres); the exported header states it.

Any kernel exports: an engine :class:`~ssskit.kernels.TapKernel` (``jimenez2012``) as shipped, a
tabulated :class:`~ssskit.kernels.Kernel` through :func:`ssskit.sampling.make_taps` (any tap
placement). A rank-R kernel (separable-SSS paper, Eq. 2: A_c = sum_r s_rc k_rc(x) k_rc(y)) is R
arrays ``kernel``, ``kernel1``, ... and, for R > 1, one sign per term and channel
(``kernel1Sign``): each term is a horizontal + vertical pass whose result is added with its sign.

Numbers are printed with 9 significant digits, so every value reads back as the same float32.
:func:`parse_shader_arrays` reads the arrays back (HLSL or GLSL).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import KernelError
from ..quantities import check_choice, check_shape

LANGUAGES = ("hlsl", "glsl")

#: the demo's convention (SeparableSSS.h, SSSSBlurPS): offset a moves a tap by a * sssWidth / 3
DEMO_OFFSET_DIVISOR = 3.0


@dataclass(frozen=True, eq=False)
class ShaderArray:
    """One exported term: offsets (N,) mm and weights (N, 3) in the demo's order, and its signs (3,)."""

    name: str
    offsets_mm: np.ndarray
    weights: np.ndarray
    signs: np.ndarray


def demo_order(offsets: Any, weights: Any) -> tuple[np.ndarray, np.ndarray]:
    """Taps reordered as the demo stores them: the tap nearest 0 first, the others by ascending offset."""
    o = np.asarray(offsets, dtype=float)
    w = np.asarray(weights, dtype=float)
    centre = int(np.argmin(np.abs(o)))
    rest = np.array([i for i in np.argsort(o, kind="stable") if i != centre], dtype=int)
    order = np.r_[centre, rest].astype(int)
    return o[order], w[order]


def kernel_arrays(kernel: Any, taps: int | None = None, tap_method: str = "importance") -> list[ShaderArray]:
    """The arrays of ``kernel`` (a TapKernel as shipped, or a Kernel through ``make_taps``), one per term.

    Weights are normalised so each channel's 2D kernel sums to 1 (what :func:`make_taps` returns);
    the centre tap must sit at offset 0 (the demo's pass never reads the centre tap's offset).
    """
    from ..sampling.taps import make_taps

    st = make_taps(kernel, taps, tap_method)  # (it refuses what is no kernel, and a TapKernel's taps but its own)
    out = []
    for r in range(st.rank):
        o, w = demo_order(st.offsets_mm[r], st.weights[r])
        scale = max(float(np.max(np.abs(o))), 1e-300)
        if abs(o[0]) > 1e-9 * scale:
            raise KernelError(f"term {r} has no tap at offset 0 (nearest: {o[0]:.6g} mm); the demo's layout "
                              "needs a centre tap at 0 (use an odd tap count)")
        o = o.copy()
        o[0] = 0.0
        out.append(ShaderArray("kernel" if r == 0 else f"kernel{r}", o, w, st.signs[r].copy()))
    return out


def _num(v: float) -> str:
    """9 significant digits: every float32 value reads back exactly; integers without a dot (as the demo)."""
    text = f"{float(v):.9g}"
    return "0" if text == "-0" else text


def format_shader_arrays(arrays: list[ShaderArray], language: str, comment: str = "") -> str:
    """The source text of ``arrays`` in ``language`` (``hlsl`` or ``glsl``), demo layout (module docstring)."""
    lang = check_choice("shader language", language, LANGUAGES, KernelError)
    if not arrays:
        raise KernelError("no kernel terms to export")
    n = arrays[0].offsets_mm.size
    if any(a.offsets_mm.size != n for a in arrays):
        raise KernelError("every term of a kernel must have the same number of taps")
    vec4, vec3 = ("float4", "float3") if lang == "hlsl" else ("vec4", "vec3")
    lines = [f"// {line}".rstrip() for line in comment.splitlines()] if comment else []
    lines += [
        "// Layout of the 2012 separable-SSS demo (SeparableSSS.h): RGB weights in .rgb, offset in .a,",
        "// the centre tap first (offset 0), then the other taps in ascending offset.",
        "// Offsets are in mm. The demo's SSSSBlurPS moves a tap at offset a by a * sssWidth / 3 scene",
        "// units: these offsets are physical with sssWidth = 3 mm in scene units (0.003 for metres).",
        "// Each channel's 2D kernel sums to 1: sum over terms of sign * (sum of the term's weights)^2.",
        "// This file replaces the kernel block of the demo's SeparableSSS.h (its SSSS_N_SAMPLES and",
        "// kernel[] definitions); the rest of that header stays as it is.",
        f"#define SSSS_N_SAMPLES {n}",
    ]
    if len(arrays) > 1:
        lines += [f"#define SSSK_KERNEL_TERMS {len(arrays)}  // separable terms: one horizontal + vertical pass "
                  "each, added with its sign"]
    for a in arrays:
        rows = [f"    {vec4}({_num(w[0])}, {_num(w[1])}, {_num(w[2])}, {_num(o)})"
                for o, w in zip(a.offsets_mm, a.weights)]
        body = ",\n".join(rows)
        if lang == "hlsl":
            lines.append(f"static const float4 {a.name}[SSSS_N_SAMPLES] = {{\n{body}\n}};")
        else:
            lines.append(f"const vec4 {a.name}[SSSS_N_SAMPLES] = vec4[SSSS_N_SAMPLES](\n{body}\n);")
        if len(arrays) > 1:
            s = ", ".join(_num(v) for v in a.signs)
            prefix = "static const" if lang == "hlsl" else "const"
            lines.append(f"{prefix} {vec3} {a.name}Sign = {vec3}({s});")
    return "\n".join(lines) + "\n"


_ARRAY = re.compile(r"(?:float4|vec4)\s+(\w+)\s*\[\s*\w*\s*\]\s*=\s*(?:vec4\s*\[\s*\w*\s*\]\s*)?[{(](.*?)[})]\s*;", re.S)
_VEC4 = re.compile(r"(?:float4|vec4)\s*\(([^()]*)\)")
_SIGN = re.compile(r"(?:float3|vec3)\s+(\w+)Sign\s*=\s*(?:float3|vec3)\s*\(([^()]*)\)")


def _floats(text: str, what: str) -> list[float]:
    try:
        return [float(v) for v in text.split(",")]
    except ValueError:
        raise KernelError(f"{what}: cannot read numbers from {text.strip()[:60]!r}") from None


def parse_shader_arrays(text: str) -> list[ShaderArray]:
    """Read back the ``float4``/``vec4`` kernel arrays (and ``...Sign`` vectors) of HLSL or GLSL source.

    Values are float32, as a shader holds them (returned as float64 arrays).
    """
    signs = {m.group(1): np.array(_floats(m.group(2), f"{m.group(1)}Sign"), dtype=np.float32).astype(float)
             for m in _SIGN.finditer(text)}
    out = []
    for m in _ARRAY.finditer(text):
        name = m.group(1)
        rows = [_floats(v.group(1), f"array {name}") for v in _VEC4.finditer(m.group(2))]  # 4-vectors (r, g, b, offset)
        arr = check_shape(rows, f"array {name}", ("n", 4), KernelError, dtype=np.float32).astype(float)
        sign = check_shape(signs.get(name, np.ones(3)), f"{name}Sign", (3,), KernelError)
        out.append(ShaderArray(name, arr[:, 3], arr[:, :3], sign))
    if not out:
        raise KernelError("no float4/vec4 kernel array found in the shader source")
    return out


def arrays_to_tap_kernel(arrays: list[ShaderArray], method: str = "shader") -> Any:
    """A rank-1 export read back as a :class:`~ssskit.kernels.TapKernel` (centre tap first)."""
    from ..kernels.base import TapKernel

    if len(arrays) != 1 or np.any(arrays[0].signs != 1):
        raise KernelError(f"a tap kernel is one term with positive signs; the source has {len(arrays)} terms")
    a = arrays[0]
    return TapKernel(a.offsets_mm, a.weights, method, {"taps": int(a.offsets_mm.size)}, {"source": "shader array"})


__all__ = ["DEMO_OFFSET_DIVISOR", "LANGUAGES", "ShaderArray", "arrays_to_tap_kernel", "demo_order",
           "format_shader_arrays", "kernel_arrays", "parse_shader_arrays"]
