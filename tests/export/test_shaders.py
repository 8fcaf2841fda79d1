"""GLSL -> SPIR-V -> HLSL on a small real compute shader, the HLSL compiled back by glslang's HLSL
front end, and the exported kernel arrays compiled in both languages. Skipped (with the reason)
where glslangValidator or spirv-cross is not installed; the missing-tool error is tested anywhere."""

import numpy as np
import pytest

from ssskit.export import format_shader_arrays, kernel_arrays
from ssskit.export import shaders
from ssskit.export.shaders import ShaderToolError, check_hlsl, glsl_to_hlsl, glsl_to_spirv, tools_available
from ssskit.kernels.jimenez2012 import kernel_jimenez2012

OK, WHY = tools_available()
needs_tools = pytest.mark.skipif(not OK, reason=WHY)

#: OpenGL GLSL as the gl backend writes it: SSBOs, loose uniforms
COPY = """#version 430
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Src { float src[]; };
layout(std430, binding = 1) writeonly buffer Dst { float dst[]; };
uniform int width;
uniform int height;
uniform float gain;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= width || p.y >= height) return;
    int i = p.y * width + p.x;
    dst[i] = gain * src[i];
}
"""

SPIRV_MAGIC = b"\x03\x02\x23\x07"


@needs_tools
def test_copy_kernel_translates_and_compiles_back():
    assert glsl_to_spirv(COPY)[:4] == SPIRV_MAGIC
    hlsl = glsl_to_hlsl(COPY)
    assert "[numthreads(8, 8, 1)]" in hlsl and "SV_DispatchThreadID" in hlsl
    for name in ("width", "height", "gain"):
        assert name in hlsl
    assert check_hlsl(hlsl)[:4] == SPIRV_MAGIC


@needs_tools
def test_compile_errors_are_one_clear_message():
    with pytest.raises(ShaderToolError, match=r"glslangValidator \(GLSL -> SPIR-V\) failed: ERROR"):
        glsl_to_hlsl(COPY.replace("gain * src[i]", "gain * undeclared[i]"))
    with pytest.raises(ShaderToolError, match="empty"):
        glsl_to_hlsl("  ")


@needs_tools
def test_exported_arrays_compile_in_both_languages():
    arrays = kernel_arrays(kernel_jimenez2012(17))
    glsl = ("#version 430\nlayout(local_size_x = 1) in;\n"
            "layout(std430, binding = 0) writeonly buffer Out { vec4 o[]; };\n"
            + format_shader_arrays(arrays, "glsl")
            + "void main() { vec4 s = vec4(0.0); for (int i = 0; i < SSSS_N_SAMPLES; i++) s += kernel[i]; o[0] = s; }\n")
    assert glsl_to_spirv(glsl)[:4] == SPIRV_MAGIC
    hlsl = ("RWStructuredBuffer<float4> o : register(u0);\n" + format_shader_arrays(arrays, "hlsl")
            + "[numthreads(1, 1, 1)] void main() { float4 s = 0; for (int i = 0; i < SSSS_N_SAMPLES; i++) "
              "s += kernel[i]; o[0] = s; }\n")
    assert check_hlsl(hlsl)[:4] == SPIRV_MAGIC


def test_missing_tool_says_which_package(monkeypatch):
    monkeypatch.setattr(shaders.shutil, "which", lambda name: None)
    with pytest.raises(ShaderToolError, match="glslang-tools"):
        glsl_to_hlsl(COPY)
    assert tools_available()[0] is False


def _skin_taps(spec="preintegrated", material="skin1", n=7):
    from ssskit.kernels import build_kernel, default_grid, parse_method_spec
    from ssskit.profiles import profile_for_material
    from ssskit.sampling.taps import make_taps

    prof = profile_for_material(material, "dipole")
    m, params, _ = parse_method_spec(spec)
    cell, size = default_grid(prof)
    return make_taps(build_kernel(m.name, prof, cell, size, **params), n)


def test_whole_glsl_shader_is_the_gl_backends_source():
    """The exported GLSL is the backend's shader for that plan (whose text runs against the oracle in
    tests/backends/test_gl.py), with per-pass defines; every pass compiles with glslangValidator."""
    from ssskit.backends import build_separable_plan
    from ssskit.backends.gl.separable import export_source
    from ssskit.export.shaders import separable_shader, with_defines

    taps = _skin_taps("svd:2", "marble", 5)
    text = separable_shader(taps, "glsl", jitter=0.2, depth_mode="follow")
    plan = build_separable_plan({1: taps}, 1.0, 1.0, jitter=0.2, depth_mode="follow")
    assert text == export_source(plan)
    if OK:
        for term in range(taps.rank):
            for vertical in (0, 1):
                assert glsl_to_spirv(with_defines(text, VERTICAL=vertical, TERM=term))[:4] == SPIRV_MAGIC


@needs_tools
def test_whole_hlsl_shader_has_every_pass_and_compiles_back():
    from ssskit.export.shaders import separable_shader

    taps = _skin_taps("svd:2", "marble", 5)
    hlsl = separable_shader(taps, "hlsl")
    assert hlsl.count("#if VERTICAL ==") == 2 * taps.rank and "[numthreads(16, 16, 1)]" in hlsl
    for term in range(taps.rank):
        for vertical in (0, 1):
            assert check_hlsl(hlsl, defines={"VERTICAL": vertical, "TERM": term})[:4] == SPIRV_MAGIC


def _constant_layout(hlsl: str, **defines: int) -> dict[str, tuple[int, str]]:
    """The constant-buffer members of one pass as glslang's HLSL front end lays them out (its reflection,
    ``-q``): name -> (byte offset, GL type code); the textures and images (offset -1) left out."""
    import re
    import subprocess
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "s.hlsl"
        src.write_text(hlsl)
        flags = [f"-D{k}={v}" for k, v in defines.items()]
        out = subprocess.run([shaders.tool_path(shaders.GLSLANG), "-D", "-V", "-l", "-q", "--reflect-all-block-variables",
                              *flags, "-e", "main", "-S", "comp", str(src), "-o", str(Path(tmp) / "s.spv")],
                             capture_output=True, text=True, check=True).stdout
    section = out.split("Uniform reflection:")[1].split("Uniform block reflection:")[0]
    rows = re.findall(r"^(\w+): offset (-?\d+), type (\w+),", section, re.M)
    return {name: (int(off), typ) for name, off, typ in rows if int(off) >= 0}


@needs_tools
def test_whole_hlsl_shader_binds_one_constant_buffer_layout_in_every_pass():
    """Issue 24: each pass compiled alone listed its uniforms in its own order (the horizontal pass
    u_size, u_f, u_base, u_pitch, u_accumulate; the vertical one u_accumulate second), so one constant
    buffer could not feed both. Judged by glslang's reflection of the exported HLSL: every pass has the
    same members at the same offsets, and they are every loose uniform of the GLSL the gl backend runs."""
    import re

    from ssskit.export.shaders import separable_shader

    taps = _skin_taps("svd:2", "marble", 5)
    hlsl = separable_shader(taps, "hlsl")
    layouts = [_constant_layout(hlsl, VERTICAL=v, TERM=t) for t in range(taps.rank) for v in (0, 1)]
    assert all(layout == layouts[0] for layout in layouts), layouts
    glsl = separable_shader(taps, "glsl")
    declared = re.findall(r"^uniform\s+(?:int|uint|float|ivec2)\s+(\w+)\s*;", glsl, re.M)
    assert sorted(layouts[0]) == sorted(declared) and len(declared) == 5
    offsets = sorted(off for off, _ in layouts[0].values())
    assert offsets == sorted(set(offsets))  # no two members share bytes
    assert hlsl.count("cbuffer SSSParams : register(b0)") == 2 * taps.rank


# ---- the transmittance pass (--pass transmission) --------------------------------------------------------------


def _arrays(text, pattern):
    """name -> float64 array of every baked table matching ``pattern`` (groups: name, comma-separated values)."""
    import re

    out = {}
    for name, body in re.findall(pattern, text, re.S):
        vals = [v.strip().rstrip("f") for v in body.replace("\n", " ").split(",") if v.strip()]
        out[name] = np.array([float(v) for v in vals])
    return out


GLSL_TABLE = r"const (?:float|int) (\w+)\[\d+\] = (?:float|int)\[\]\(\s*(.*?)\);"
HLSL_TABLE = r"static const (?:float|int) (\w+)_VALUES\[\d+\] = \{\s*(.*?)\};"


def _shader_transmittance(tables, slot, t, terms):
    """T(t) of one slot evaluated from the shader's baked tables as its main() does (steps 4 of both kinds)."""
    if "LUT_SLOT" in tables and tables["LUT_SLOT"][slot] == 1:
        od = np.clip(tables["OD_PER_MM"][slot] * t + tables["OD_OFFSET"][slot], 0.15, 5.0) + 0.25
        enc = 1.0 - od / 5.0
        x = (1.0 - enc * enc) * 31
        fi = np.minimum(np.floor(x), 30).astype(int)
        f = x - fi
        lut = tables["LUT"].reshape(-1, 3, 32)[slot]
        return np.stack([(1 - f) * lut[c, fi] + f * lut[c, fi + 1] for c in range(3)], -1)
    u = tables["SCALE"][slot] * t
    a, b, c = (tables[k].reshape(-1, 3, terms)[slot] for k in ("COEF_A", "COEF_B", "COEF_C"))
    return np.stack([np.sum(a[ch] * np.exp(-b[ch] * u[:, None] - c[ch] * (u * u)[:, None]), -1) for ch in range(3)], -1)


@pytest.fixture(scope="module")
def transmission_plan_():
    from ssskit.materials import get_material
    from ssskit.screenspace.transmission import mcml_model, transmission_plan, unreal_model

    return transmission_plan({1: mcml_model(get_material("skin1")), 2: unreal_model((2.0, 0.8, 0.4), (1, 0.9, 0.7), 3.0)})


def test_transmission_glsl_is_the_backends_source_and_computes_the_pass(transmission_plan_):
    """The exported GLSL is the gl backend's transmittance shader (run against the oracle in
    tests/backends/test_transmission.py); glslangValidator compiles it; its baked parameter arrays, evaluated by
    the shader's formula, give the plan's T(t) within float32 rounding (an MCML slot and an Unreal table slot)."""
    from ssskit.backends.gl.transmission import transmission_export_source
    from ssskit.export.shaders import transmission_shader

    plan = transmission_plan_
    glsl = transmission_shader(plan, "glsl")
    assert glsl == transmission_export_source(plan) and "// ---- how to run it" in glsl
    if OK:
        assert glsl_to_spirv(glsl)[:4] == SPIRV_MAGIC
    tables = _arrays(glsl, GLSL_TABLE)
    assert {"COEF_A", "COEF_B", "COEF_C", "SCALE", "WRAP", "LUT", "OD_PER_MM", "OD_OFFSET"} <= set(tables)
    t = np.concatenate([np.linspace(0.01, 5, 60), np.linspace(5, 60, 40)])
    for slot in (1, 2):
        got, want = _shader_transmittance(tables, slot, t, plan.terms), plan.transmittance(slot, t)
        # the baked coefficients are float32: a term a exp(x) moves by 2^-24 (1 + |x|) of itself (|x| up to ~100);
        # the MCML model's terms may subtract (its scattered part is 0 at t = 0), so the bound is the sum of the
        # terms' magnitudes, not of T
        x = -plan.b[slot][None] * t[:, None, None] - plan.c[slot][None] * (t * t)[:, None, None]
        terms = np.sum(np.abs(plan.a[slot][None]) * np.exp(x) * (1.0 + np.abs(x)), axis=-1)
        bound = 2.0 * 2.0**-24 * (terms if slot == 1 else 101 * np.abs(want)) + 1e-12
        assert np.all(np.abs(got - want) <= bound), f"slot {slot}: worst {np.max(np.abs(got - want) / bound):.3g}x"


@needs_tools
def test_transmission_hlsl_compiles_back_and_bakes_the_same_numbers(transmission_plan_):
    """The HLSL translation compiles with glslang's HLSL front end, binds its two uniforms in one constant
    buffer, and its baked tables (static const NAME_VALUES) are the GLSL's, number for number."""
    from ssskit.export.shaders import transmission_shader

    plan = transmission_plan_
    hlsl = transmission_shader(plan, "hlsl")
    assert check_hlsl(hlsl)[:4] == SPIRV_MAGIC
    assert hlsl.count("cbuffer SSSParams : register(b0)") == 1
    assert sorted(_constant_layout(hlsl)) == ["u_n", "u_shadow_size"]
    glsl_tables = _arrays(transmission_shader(plan, "glsl"), GLSL_TABLE)
    hlsl_tables = _arrays(hlsl, HLSL_TABLE)
    assert set(hlsl_tables) == set(glsl_tables)
    for name, values in glsl_tables.items():
        np.testing.assert_array_equal(hlsl_tables[name].astype(np.float32), values.astype(np.float32))
