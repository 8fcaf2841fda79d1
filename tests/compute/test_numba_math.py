"""The vectorisable float32 functions of the numba kernels (ssskit.compute.numba_math) against numpy's
float64 functions, and the Burley kernel's error bound on a sample's position (the float32 lanes hand a
sample to the float64 path when it lies within that bound of a texel edge, so the bound must hold)."""

import math

import numpy as np
import pytest

numba = pytest.importorskip("numba")
from numba import njit  # noqa: E402

from ssskit.compute import numba_math as nm  # noqa: E402
from ssskit.backends._numba_burley import GUARD  # noqa: E402
from ssskit.profiles.burley import burley_inverse_cdf  # noqa: E402


@njit(fastmath=nm.FM32)
def _apply(x, which):
    out = np.empty(x.size, np.float32)
    for i in range(x.size):
        if which == 0:
            out[i] = nm.exp_f32(x[i])
        elif which == 1:
            out[i] = nm.log_f32(x[i])
        elif which == 2:
            out[i] = nm.log1p_f32(x[i])
        else:
            out[i] = nm.burley_rho_f32(x[i])
    return out


@njit(fastmath=nm.FM32)
def _sincos(m):
    c = np.empty(m.size, np.float32)
    s = np.empty(m.size, np.float32)
    for i in range(m.size):
        c[i], s[i] = nm.sincos_u24(m[i])
    return c, s


@njit(fastmath=nm.FM32)
def _hashes(h, j, a):
    out = np.empty((3, h.size), np.uint32)
    for i in range(h.size):
        out[0, i] = nm.u32_madd(h[i], j[i], a)
        out[1, i] = nm.mix32_u32(nm.u32_xor(h[i], j[i]))
        out[2, i] = np.uint32(nm.u24_f32(h[i]))
    return out


def test_exp_and_log_are_within_a_few_ulp():
    x = np.linspace(-87, 88, 400_001).astype(np.float32)
    np.testing.assert_allclose(_apply(x, 0), np.exp(x.astype(np.float64)), rtol=2e-7)
    assert _apply(np.array([-200.0, -87.0], np.float32), 0)[0] == np.float32(math.exp(-87.0))  # clamped, normal
    y = np.exp(np.linspace(-87, 88, 400_001)).astype(np.float32)
    ref = np.log(y.astype(np.float64))
    np.testing.assert_allclose(_apply(y, 1), ref, rtol=2e-7, atol=5e-7)
    t = np.concatenate([np.linspace(-0.9, 5, 200_001), np.logspace(-30, 0, 20_000), -np.logspace(-30, -0.5, 2_000)])
    t = t.astype(np.float32)
    np.testing.assert_allclose(_apply(t, 2), np.log1p(t.astype(np.float64)), rtol=3e-7)


def test_sincos_of_24_bit_angles():
    m = np.arange(0, 1 << 24, 5).astype(np.float32)
    c, s = _sincos(m)
    phi = 2 * np.pi * (m.astype(np.float64) + 0.5) * 2.0**-24
    assert np.abs(c - np.cos(phi)).max() < 3e-7
    assert np.abs(s - np.sin(phi)).max() < 3e-7


def test_uint32_intrinsics_match_the_64_bit_hashes():
    from ssskit.sampling.hashes import mix32

    rng = np.random.default_rng(5)
    h = rng.integers(0, 2**32, 10_000, dtype=np.uint64).astype(np.uint32)
    j = rng.integers(0, 2**32, 10_000, dtype=np.uint64).astype(np.uint32)
    out = _hashes(h, j, np.uint32(0xC13FA9A9))
    h64, j64 = h.astype(np.uint64), j.astype(np.uint64)
    np.testing.assert_array_equal(out[0], (h64 + j64 * np.uint64(0xC13FA9A9)) & np.uint64(0xFFFFFFFF))
    np.testing.assert_array_equal(out[1], mix32(h64 ^ j64))
    np.testing.assert_array_equal(out[2], h64 >> np.uint64(8))


def test_burley_inverse_in_float32_is_the_oracles_root():
    """Error below 1e-6 (r + 1) for every 24-bit uniform (plan step 3), against burley_inverse_cdf."""
    k = np.arange(0, 1 << 24, 3)
    eta = ((k + 0.5) * 2.0**-24).astype(np.float32)  # exact
    r = _apply(eta, 3).astype(np.float64)
    ref = burley_inverse_cdf(1.0 - eta.astype(np.float64), 1.0)
    assert np.max(np.abs(r - ref) / (ref + 1.0)) < 1e-6


@njit(fastmath=nm.FM32)
def _offsets(eta, m2, ds, sx):
    out = np.empty(eta.size, np.float32)
    for i in range(eta.size):
        r = ds[i] * nm.burley_rho_f32(eta[i])
        c, _s = nm.sincos_u24(m2[i])
        out[i] = r * c * sx[i]
    return out


def test_the_kernels_position_error_is_far_inside_its_guard():
    """The Burley kernel's float32 offset r cos(phi) sx (steps 4-5) against the float64 oracle's: the
    kernel treats a position within GUARD (sx (r + d_s) + 1) of a texel edge as uncertain; the real
    error must be far smaller (here: below a tenth of it) for any d_s, footprint and uniform."""
    rng = np.random.default_rng(7)
    n = 400_000
    m1 = rng.integers(0, 1 << 24, n)
    m1[:1000] = np.arange(1000)  # both ends of the inverse
    m1[1000:2000] = (1 << 24) - 1 - np.arange(1000)
    eta = ((((1 << 24) - 1 - m1) + 0.5) * 2.0**-24).astype(np.float32)
    m2 = rng.integers(0, 1 << 24, n).astype(np.float32)
    ds = np.exp(rng.uniform(np.log(0.05), np.log(20.0), n)).astype(np.float32)
    sx = np.exp(rng.uniform(np.log(0.1), np.log(50.0), n)).astype(np.float32)
    got = _offsets(eta, m2, ds, sx).astype(np.float64)
    xi = (m1 + 0.5) * 2.0**-24
    r = burley_inverse_cdf(xi, 1.0) * ds.astype(np.float64)
    want = r * np.cos(2 * np.pi * (m2.astype(np.float64) + 0.5) * 2.0**-24) * sx.astype(np.float64)
    bound = float(GUARD) * (sx * (r + ds) + 1.0)
    assert np.max(np.abs(got - want) / bound) < 0.1


def test_the_polynomials_are_the_documented_fits():
    """EXP2_POLY and BURLEY_U_POLY are what their comments say: least-squares Chebyshev fits, converted to
    monomials (refitted here), and accurate: 2^f within 1.1e-7, u(eta) / eta within 5e-8 in float64."""
    from numpy.polynomial import chebyshev as C

    x = np.cos(np.pi * (np.arange(2000) + 0.5) / 2000) * 0.5
    mono = C.cheb2poly(C.chebfit(2 * x, 2.0**x, 5)) * 2.0 ** np.arange(6)
    np.testing.assert_allclose(nm.EXP2_POLY, mono, rtol=1e-9, atol=1e-12)
    f = np.linspace(-0.5, 0.5, 10_001)
    assert np.max(np.abs(np.polyval(nm.EXP2_POLY[::-1], f) / 2.0**f - 1)) < 1.1e-7
    eta = np.cos(np.pi * (np.arange(4000) + 0.5) / 4000) * 0.5 + 0.5
    u = 2 * np.sinh(np.arcsinh(2 * eta) / 3)
    np.testing.assert_allclose(nm.BURLEY_U_POLY, C.cheb2poly(C.chebfit(2 * eta - 1, u / eta, 11)), rtol=1e-9,
                               atol=1e-12)
    e = np.linspace(0, 1, 20_001)[1:]
    ue = 2 * np.sinh(np.arcsinh(2 * e) / 3)
    assert np.max(np.abs(np.polyval(nm.BURLEY_U_POLY[::-1], 2 * e - 1) * e / ue - 1)) < 5e-8
    # u solves Cardano's cubic u^3 + 3u = 4 eta (the inverse of Eq. 20 with u = exp(-r/3))
    np.testing.assert_allclose(ue**3 + 3 * ue, 4 * e, rtol=1e-12)


def test_exp2():
    y = np.linspace(-126, 127, 500_001).astype(np.float32)
    got = _exp2(y)
    np.testing.assert_allclose(got, 2.0 ** y.astype(np.float64), rtol=3e-7)


@njit(fastmath=nm.FM32)
def _exp2(y):
    out = np.empty(y.size, np.float32)
    for i in range(y.size):
        out[i] = nm.exp2_f32(y[i])
    return out


@njit
def _pairs(arr, idx):
    out = np.empty((idx.size, 2), np.float32)
    for k in range(idx.size):
        out[k, 0], out[k, 1] = nm.load_pair_at(arr, idx[k])
    return out


def test_load_pair_at_reads_two_neighbours_at_any_offset():
    """One 64-bit load gives (arr[i], arr[i + 1]) in that order, also at odd (8-byte unaligned) i and on the last
    pair of the array."""
    arr = np.arange(1, 12, dtype=np.float32) * np.float32(1.5)
    idx = np.array([0, 1, 4, 9], np.int32)
    np.testing.assert_array_equal(_pairs(arr, idx), np.stack([arr[idx], arr[idx + 1]], -1))
