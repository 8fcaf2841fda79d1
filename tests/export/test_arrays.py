"""Shader arrays: the engines' jimenez2012 tables reproduced to 6 digits through the HLSL export, and
every export read back to float32 precision (HLSL and GLSL, rank 1 and rank 2)."""

import math

import numpy as np
import pytest

from ssskit.errors import KernelError, SamplingError
from ssskit.export import (
    arrays_to_tap_kernel,
    export_kernel,
    format_shader_arrays,
    kernel_arrays,
    parse_shader_arrays,
)
from ssskit.export.arrays import demo_order
from ssskit.kernels import build_kernel
from ssskit.kernels.jimenez2012 import kernel_jimenez2012
from ssskit.profiles import profile_for_material

from .demo_tables import TABLES

F32_REL = 2.0**-24  # half an ulp of float32, relative


def _sixth_digit(t: float) -> float:
    """One unit in the 6th significant digit of t (the precision the demo printed)."""
    return 10.0 ** (math.floor(math.log10(abs(t))) - 5)


@pytest.mark.parametrize("taps", [11, 17, 25])
def test_jimenez2012_hlsl_reproduces_the_demo_tables(taps, tmp_path):
    path = tmp_path / "kernel.hlsl"
    export_kernel(kernel_jimenez2012(taps), "hlsl", path)
    text = path.read_text()
    assert f"#define SSSS_N_SAMPLES {taps}" in text and "static const float4 kernel[SSSS_N_SAMPLES]" in text
    (arr,) = parse_shader_arrays(text)
    ours = np.column_stack([arr.weights, arr.offsets_mm])
    table = np.array(TABLES[taps])
    assert ours.shape == table.shape
    for v, t in zip(ours.ravel(), table.ravel()):
        if t == 0:
            assert v == 0
        else:
            # the demo computed in float32 and printed 6 significant digits: agree within one unit of the
            # 6th digit (a few printed values differ by one there: the demo's float32 rounding, which
            # even breaks its table's symmetry, 5.07566e-005 vs 5.07565e-005 in the 11-tap table)
            assert abs(v - t) <= _sixth_digit(t), (v, t)


def test_the_demo_tables_fail_for_other_parameters(tmp_path):
    """The 6-digit comparison can fail: the default falloff, changed by 1%, misses the 11-tap table."""
    k = kernel_jimenez2012(11, falloff=(1.01, 0.37, 0.3))
    (arr,) = parse_shader_arrays(format_shader_arrays(kernel_arrays(k), "hlsl"))
    t = np.array(TABLES[11])
    assert np.max(np.abs(arr.weights[:, 0] - t[:, 0])) > 1e-4


def _check_float32(arr, ref_offsets, ref_weights):
    np.testing.assert_array_equal(arr.offsets_mm, ref_offsets.astype(np.float32).astype(float))
    np.testing.assert_allclose(arr.weights, ref_weights, rtol=F32_REL, atol=0)


@pytest.mark.parametrize("language", ["hlsl", "glsl"])
def test_roundtrip_tap_kernel(language):
    k = kernel_jimenez2012(17)
    arrays = kernel_arrays(k)
    (back,) = parse_shader_arrays(format_shader_arrays(arrays, language))
    _check_float32(back, arrays[0].offsets_mm, arrays[0].weights)
    t = arrays_to_tap_kernel([back])
    np.testing.assert_allclose(t.weights, k.weights, rtol=F32_REL)
    np.testing.assert_allclose(t.offsets_mm, k.offsets_mm, rtol=F32_REL)


@pytest.fixture(scope="module")
def skin():
    return profile_for_material("skin1", "dipole")


@pytest.fixture(scope="module")
def kernels(skin):
    return {"preintegrated": build_kernel("preintegrated", skin, n=101), "svd": build_kernel("svd", skin, n=101, rank=2),
            "artist": build_kernel("artist", skin, n=101)}


@pytest.mark.parametrize("language", ["hlsl", "glsl"])
@pytest.mark.parametrize("spec,taps,method", [("preintegrated", 9, "importance"), ("svd", 7, "uniform"),
                                              ("artist", 5, "quadratic")])
def test_roundtrip_tabulated_kernels(kernels, language, spec, taps, method):
    kernel = kernels[spec]
    arrays = kernel_arrays(kernel, taps, method)
    assert len(arrays) == kernel.rank
    back = parse_shader_arrays(format_shader_arrays(arrays, language))
    assert [a.name for a in back] == [a.name for a in arrays]
    for a, b in zip(arrays, back):
        assert b.offsets_mm[0] == 0.0 and np.all(np.diff(b.offsets_mm[1:]) > 0)  # demo order
        _check_float32(b, a.offsets_mm, a.weights)
        np.testing.assert_array_equal(b.signs, a.signs)
    # the arrays hold a normalised kernel: sum over terms of sign * (sum of weights)^2 = 1 per channel
    total = sum(b.signs * b.weights.sum(axis=0) ** 2 for b in back)
    np.testing.assert_allclose(total, 1.0, rtol=1e-6)


def test_demo_order():
    o, w = demo_order([-1.0, 2.0, 0.0, 1.0, -2.0], np.arange(15.0).reshape(5, 3))
    assert o.tolist() == [0.0, -2.0, -1.0, 1.0, 2.0]
    assert w[:, 0].tolist() == [6.0, 12.0, 0.0, 9.0, 3.0]


def test_array_errors(kernels):
    with pytest.raises(KernelError, match="language"):
        format_shader_arrays(kernel_arrays(kernel_jimenez2012(11)), "metal")
    with pytest.raises(SamplingError, match="ships 11 taps"):  # (make_taps's rule)
        kernel_arrays(kernel_jimenez2012(11), taps=17)
    with pytest.raises(SamplingError, match="odd"):
        kernel_arrays(kernels["preintegrated"], taps=8)
    with pytest.raises(KernelError, match="no float4/vec4"):
        parse_shader_arrays("float x = 1;")
    with pytest.raises(KernelError, match=r"must be a real array of shape \(n, 4\)"):
        parse_shader_arrays("static const float4 kernel[2] = { float4(1, 2, 3), float4(1, 2, 3, 4) };")
    with pytest.raises(KernelError, match="one term"):
        arrays_to_tap_kernel(parse_shader_arrays(format_shader_arrays(
            kernel_arrays(kernels["svd"], 5), "glsl")))


def test_options_a_format_does_not_take_are_refused_before_writing(tmp_path):
    """jitter and depth_mode belong to the whole shaders (glsl-shader, hlsl-shader), taps not to bn / json: given
    to another format they are a KernelError and no file is written (the shaders check their values)."""
    k = kernel_jimenez2012(11)
    for fmt, suffix, opts in (("glsl", "glsl", {"jitter": 2.0, "depth_mode": "bogus"}), ("hlsl", "hlsl", {"jitter": 0.3}),
                              ("glsl", "glsl", {"depth_mode": "follow"}), ("json", "json", {"taps": 9}),
                              ("bn", "bn", {"taps": 9})):
        path = tmp_path / f"kernel.{suffix}"
        with pytest.raises(KernelError, match=r"(jitter|depth_mode|jitter, depth_mode) appl(y|ies) to format glsl-shader or hlsl-shader, "
                                                 r"not format (glsl|hlsl)|taps applies to format .*, not format (json|bn)"):
            export_kernel(k, fmt, path, **opts)
        assert not path.exists()
    export_kernel(k, "glsl", tmp_path / "ok.glsl")  # the defaults pass
    assert (tmp_path / "ok.glsl").exists()
