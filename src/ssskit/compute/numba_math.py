"""Branch-free float32 elementary functions for numba kernels that LLVM can vectorise.

numba lowers ``math.exp``, ``math.log``, ``math.cos`` ... to calls into libm, one lane at a time, so
a loop that calls them is never vectorised (there is no vector maths library here). The functions
below are plain arithmetic, selects and integer bit operations on float32 values, inlined into the
caller's loop, so a lane loop over them compiles to 8-wide AVX2 code. Their accuracy is tested against
numpy's float64 functions (``tests/compute/test_numba_math.py``).

* :func:`exp_f32`, :func:`log_f32`: Moshier's Cephes single-precision ``expf`` / ``logf`` (Cephes
  Mathematical Library 2.x, 1984-1992: range reduction by ln 2, resp. to a mantissa in
  [sqrt(1/2), sqrt(2)), and the library's minimax polynomials), about 1 ulp;
* :func:`log1p_f32`: log(1 + t) as log(u) t / (u - 1) with u = 1 + t rounded (Goldberg 1991, "What every
  computer scientist should know about floating-point arithmetic", Theorem 4): relative
  accuracy for small t;
* :func:`sincos_u24`: cos and sin of 2 pi (U + 1/2) 2^-24 for a 24-bit integer U, by its quadrant and
  Taylor polynomials of the offset from the octant's middle (|theta| <= pi/4);
* :func:`exp2_f32`: 2^y by a degree-5 polynomial of the fractional part;
* :func:`burley_rho_f32`: the exact inverse of Xie 2020's Eq. 20 for d = 1 in float32 (Cardano's root
  of u^3 + 3u = 4 eta, u = 2 sinh(asinh(2 eta) / 3), by a polynomial fit of u / eta: no cancellation
  at either end).

Small LLVM intrinsics do the bit work in 32-bit arithmetic (numba widens integer arithmetic to 64
bits, which halves the lanes per register): a float32's mantissa and exponent, 2^n, and the uint32
operations of the counter-based hashes (:func:`u32_madd`, :func:`u32_xor`, :func:`mix32_u32`,
:func:`u24_f32`), a float32's bits as an int32 and back for integer min/max reductions (:func:`f32_bits`,
:func:`bits_f32`), loads without numba's negative-index wraparound (:func:`load_at`, :func:`load_pair_at`: two
neighbours in one 64-bit load). :func:`stack_empty` gives a lane loop scratch arrays that alias nothing.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from llvmlite import ir
from numba import njit
from numba.core import cgutils, types
from numba.extending import intrinsic as _numba_intrinsic

#: numba's @intrinsic, seen by mypy as giving Any: an intrinsic is called from jitted code without the typing
#: context its Python signature starts with
intrinsic: Callable[[Callable[..., Any]], Any] = _numba_intrinsic
#: what an intrinsic's typing function returns: (signature, codegen), or None for argument types it does not take
_Typed = tuple[Any, Callable[..., Any]] | None
#: a float32 scalar of numba-compiled code (numba types it; the functions below are only called from there)
Float32 = Any

#: contraction into FMAs only: the algorithms below rely on the order of their roundings
#: (reassociation would fold log1p's correction away)
FM32 = {"contract"}

_F = np.float32
_ONE = _F(1.0)
_HALF = _F(0.5)
_ZERO = _F(0.0)
_LOG2E = _F(1.44269504088896341)
_EXP_C1 = _F(0.693359375)  # ln 2 = C1 - C2, C1 exact in a few bits (Cephes)
_EXP_C2 = _F(-2.12194440e-4)
_EXP_LO = _F(-87.0)  # exp(-87) = 1.6e-38: still a normal float32
_EXP_HI = _F(88.0)
_E0, _E1, _E2 = _F(1.9875691500e-4), _F(1.3981999507e-3), _F(8.3334519073e-3)
_E3, _E4, _E5 = _F(4.1665795894e-2), _F(1.6666665459e-1), _F(5.0000001201e-1)
_SQRTHF = _F(0.707106781186547524)
_L0, _L1, _L2 = _F(7.0376836292e-2), _F(-1.1514610310e-1), _F(1.1676998740e-1)
_L3, _L4, _L5 = _F(-1.2420140846e-1), _F(1.4249322787e-1), _F(-1.6668057665e-1)
_L6, _L7, _L8 = _F(2.0000714765e-1), _F(-2.4999993993e-1), _F(3.3333331174e-1)
_THIRD = _F(1.0 / 3.0)
_TWO = _F(2.0)
_THREE = _F(3.0)
_QPI = _F(0.5 * math.pi)
_RSQRT2 = _F(0.7071067811865476)
_U22 = _F(2.0**-22)
_P22 = _F(2.0**22)
_E126 = _F(126.0)
_E127 = _F(127.0)
# Taylor coefficients: sin, cos, sinh
_SN3, _SN5, _SN7, _SN9 = (_F((-1) ** k / math.factorial(2 * k + 1)) for k in range(1, 5))
_CS2, _CS4, _CS6, _CS8, _CS10 = (_F((-1) ** k / math.factorial(2 * k)) for k in range(1, 6))
_SH3, _SH5, _SH7, _SH9, _SH11 = (_F(1 / math.factorial(2 * k + 1)) for k in range(1, 6))
_M126 = _F(-126.0)
_P127 = _F(127.0)
#: 2^f on [-1/2, 1/2], monomial coefficients of the degree-5 least-squares Chebyshev fit (numpy chebfit on
#: 2000 Chebyshev nodes, converted by cheb2poly)
EXP2_POLY = (1.0000000754953493, 0.6931472067106206, 0.24022107355830383, 0.055503272142086946,
             0.00967603709787357, 0.0013400432165524283)
_X0, _X1, _X2, _X3, _X4, _X5 = (_F(c) for c in EXP2_POLY)
#: u(eta) / eta with u = 2 sinh(asinh(2 eta) / 3), as a polynomial in t = 2 eta - 1 on [0, 1]: monomial
#: coefficients of the degree-11 least-squares Chebyshev fit (numpy chebfit on 4000 Chebyshev nodes,
#: cheb2poly); tests/compute/test_numba_math.py fits them again
BURLEY_U_POLY = (1.1921432814955428, -0.20835182999119606, -0.004481160885400362, 0.038011517220720326,
                 -0.024485928993407853, 0.007671226327674953, 0.0014248289835822978, -0.003954701930635585,
                 0.0028180006545531306, -0.00039411371249556155, -0.0007523746835563596, 0.00035127215855746877)
(_U0, _U1, _U2, _U3, _U4, _U5, _U6, _U7, _U8, _U9, _U10, _U11) = (_F(c) for c in BURLEY_U_POLY)


def _i32(builder, v, ty):
    """An integer argument as an LLVM i32 (numba widens 32-bit arithmetic to 64 bits)."""
    if ty.bitwidth > 32:
        return builder.trunc(v, ir.IntType(32))
    if ty.bitwidth < 32:
        return builder.zext(v, ir.IntType(32))
    return v


def _bits(builder, x):
    return builder.bitcast(x, ir.IntType(32))


@intrinsic
def _mantissa(typingctx: object, x: types.Type) -> _Typed:
    """m in [1/2, 1) with x = m 2^e, for a positive normal float32 x (frexp's mantissa)."""
    if x != types.float32:
        return None

    def codegen(context, builder, sig, args):
        b = builder.and_(_bits(builder, args[0]), ir.Constant(ir.IntType(32), 0x007FFFFF))
        b = builder.or_(b, ir.Constant(ir.IntType(32), 0x3F000000))
        return builder.bitcast(b, ir.FloatType())

    return types.float32(types.float32), codegen


@intrinsic
def _exponent(typingctx: object, x: types.Type) -> _Typed:
    """The biased exponent field of a positive float32 as a float32 (e + 126 with x = m 2^e, m in [1/2, 1))."""
    if x != types.float32:
        return None

    def codegen(context, builder, sig, args):
        b = builder.lshr(_bits(builder, args[0]), ir.Constant(ir.IntType(32), 23))
        return builder.sitofp(b, ir.FloatType())

    return types.float32(types.float32), codegen


@intrinsic
def _pow2(typingctx: object, n: types.Type) -> _Typed:
    """2^n as a float32 for an integer-valued float32 n in [-126, 127]."""
    if n != types.float32:
        return None

    def codegen(context, builder, sig, args):
        i = builder.fptosi(args[0], ir.IntType(32))
        i = builder.shl(builder.add(i, ir.Constant(ir.IntType(32), 127)), ir.Constant(ir.IntType(32), 23))
        return builder.bitcast(i, ir.FloatType())

    return types.float32(types.float32), codegen


@intrinsic
def u32_madd(typingctx: object, h: types.Type, j: types.Type, a: types.Type) -> _Typed:
    """(h + j a) mod 2^32 as a uint32, in 32-bit arithmetic (the low 32 bits of each argument)."""
    if not all(isinstance(t, types.Integer) for t in (h, j, a)):
        return None

    def codegen(context, builder, sig, args):
        hh, jj, aa = (_i32(builder, v, t) for v, t in zip(args, (h, j, a)))
        return builder.add(hh, builder.mul(jj, aa))

    return types.uint32(h, j, a), codegen


@intrinsic
def u32_xor(typingctx: object, a: types.Type, b: types.Type) -> _Typed:
    """a ^ b on the low 32 bits, as a uint32."""
    if not (isinstance(a, types.Integer) and isinstance(b, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        return builder.xor(_i32(builder, args[0], a), _i32(builder, args[1], b))

    return types.uint32(a, b), codegen


@intrinsic
def mix32_u32(typingctx: object, h: types.Type) -> _Typed:
    """lowbias32 (Wellons 2018; ssskit.sampling.hashes.mix32) in 32-bit arithmetic, as a uint32:
    h ^= h >> 16; h *= 0x7FEB352D; h ^= h >> 15; h *= 0x846CA68B; h ^= h >> 16."""
    if not isinstance(h, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        i32 = ir.IntType(32)
        v = _i32(builder, args[0], h)
        for shift, mul in ((16, 0x7FEB352D), (15, 0x846CA68B)):
            v = builder.xor(v, builder.lshr(v, ir.Constant(i32, shift)))
            v = builder.mul(v, ir.Constant(i32, mul))
        return builder.xor(v, builder.lshr(v, ir.Constant(i32, 16)))

    return types.uint32(h), codegen


@intrinsic
def u24_f32(typingctx: object, u: types.Type) -> _Typed:
    """float32(u >> 8) for the low 32 bits of u: its top 24 bits, exact."""
    if not isinstance(u, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        v = builder.lshr(_i32(builder, args[0], u), ir.Constant(ir.IntType(32), 8))
        return builder.sitofp(v, ir.FloatType())

    return types.float32(u), codegen


@intrinsic
def i32(typingctx: object, v: types.Type) -> _Typed:
    """An integer-valued float32 (truncated toward 0) or the low 32 bits of an integer, as an int32."""
    if v == types.float32:
        def codegen(context, builder, sig, args):
            return builder.fptosi(args[0], ir.IntType(32))
    elif isinstance(v, types.Integer):
        def codegen(context, builder, sig, args):
            return _i32(builder, args[0], v)
    else:
        return None
    return types.int32(v), codegen


@intrinsic
def f32_bits(typingctx: object, x: types.Type) -> _Typed:
    """The bits of a float32 as an int32. For non-negative floats (+inf included) the order of the bits is the
    order of the values, so min/max reductions over them vectorise as integer reductions (LLVM vectorises
    float min/max reductions only under 'nnan', which kernels that mark empty texels with +inf cannot use)."""
    if x != types.float32:
        return None

    def codegen(context, builder, sig, args):
        return _bits(builder, args[0])

    return types.int32(x), codegen


@intrinsic
def bits_f32(typingctx: object, i: types.Type) -> _Typed:
    """The float32 whose bits are the low 32 bits of integer i (the inverse of :func:`f32_bits`)."""
    if not isinstance(i, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        return builder.bitcast(_i32(builder, args[0], i), ir.FloatType())

    return types.float32(i), codegen


@intrinsic
def i32_madd(typingctx: object, a: types.Type, b: types.Type, c: types.Type) -> _Typed:
    """a b + c in 32-bit signed arithmetic (no overflow: an index into an array of < 2^31 elements)."""
    if not all(isinstance(t, types.Integer) for t in (a, b, c)):
        return None

    def codegen(context, builder, sig, args):
        x, y, z = (_i32(builder, v, t) for v, t in zip(args, (a, b, c)))
        return builder.add(builder.mul(x, y, flags=["nsw"]), z, flags=["nsw"])

    return types.int32(a, b, c), codegen


@intrinsic
def load_at(typingctx: object, arr: types.Type, i: types.Type) -> _Typed:
    """arr[i] for a 1D C-contiguous array and a non-negative int32 index, without numba's wraparound of
    negative indices: the address is data + sext(i), which LLVM turns into a 32-bit-index gather
    (8 lanes per instruction, not 4) when a vectorised loop loads it."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and i == types.int32):
        return None

    def codegen(context, builder, sig, args):
        ary = context.make_array(arr)(context, builder, value=args[0])
        ptr = builder.gep(ary.data, [builder.sext(args[1], ir.IntType(64))], inbounds=True)
        return builder.load(ptr)

    return arr.dtype(arr, i), codegen


@intrinsic
def load_pair_at(typingctx: object, arr: types.Type, i: types.Type) -> _Typed:
    """(arr[i], arr[i + 1]) of a 1D C-contiguous float32 array and a non-negative int32 index i < size - 1, as
    one 64-bit load: a vectorised loop gathers both with one 64-bit element per lane (half the elements of
    two 32-bit gathers)."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.dtype == types.float32 and i == types.int32):
        return None
    pair = types.UniTuple(types.float32, 2)

    def codegen(context, builder, sig, args):
        ary = context.make_array(arr)(context, builder, value=args[0])
        ptr = builder.gep(ary.data, [builder.sext(args[1], ir.IntType(64))], inbounds=True)
        bits = builder.load(builder.bitcast(ptr, ir.IntType(64).as_pointer()), align=4)
        i32t, f32t = ir.IntType(32), ir.FloatType()
        lo = builder.bitcast(builder.trunc(bits, i32t), f32t)
        hi = builder.bitcast(builder.trunc(builder.lshr(bits, ir.Constant(ir.IntType(64), 32)), i32t), f32t)
        return context.make_tuple(builder, pair, (lo, hi))

    return pair(arr, i), codegen


@intrinsic
def stack_empty(typingctx: object, size: types.Type, dtype: types.Type) -> _Typed:
    """A 1D C-contiguous array of ``size`` (a literal int) elements of ``dtype`` on the caller's stack
    (an LLVM alloca in its entry block, no reference count): LLVM knows that it aliases no argument,
    so lane loops that store into it and gather from the arguments vectorise without runtime alias
    checks (which data-dependent gathers would make impossible). Valid only inside the calling
    (inlined) function; never return it."""
    if not isinstance(size, types.IntegerLiteral) or not isinstance(dtype, types.NumberClass):
        return None
    n = size.literal_value
    arr_t = types.Array(dtype.dtype, 1, "C")

    def codegen(context, builder, sig, args):
        ty = context.get_data_type(dtype.dtype)
        ptr = cgutils.alloca_once(builder, ty, size=n)
        ary = context.make_array(arr_t)(context, builder)
        itemsize = context.get_abi_sizeof(ty)
        intp = lambda v: context.get_constant(types.intp, v)  # noqa: E731
        context.populate_array(ary, data=ptr, shape=[intp(n)], strides=[intp(itemsize)], itemsize=intp(itemsize),
                               meminfo=None)
        return ary._getvalue()

    return arr_t(size, dtype), codegen


@njit(cache=True, fastmath=FM32)
def exp_f32(x: Float32) -> Float32:
    """exp(x) for float32 x (Cephes expf: x = n ln 2 + g, |g| <= ln 2 / 2, a degree-7 polynomial in g);
    arguments are clamped to [-87, 88], so the result is a normal number (exp(-87) for anything below)."""
    x = min(max(x, _EXP_LO), _EXP_HI)
    n = np.floor(x * _LOG2E + _HALF)
    g = x - n * _EXP_C1
    g = g - n * _EXP_C2
    p = (((((_E0 * g + _E1) * g + _E2) * g + _E3) * g + _E4) * g + _E5) * (g * g) + g + _ONE
    return p * _pow2(n)


@njit(cache=True, fastmath=FM32)
def log_f32(x: Float32) -> Float32:
    """log(x) for a positive, normal float32 x (Cephes logf): x = m 2^e with m in [sqrt(1/2), sqrt(2)),
    a degree-9 polynomial in m - 1, e ln 2 in two parts."""
    m = _mantissa(x)  # in [0.5, 1)
    small = m < _SQRTHF
    fe = _exponent(x) - (_E127 if small else _E126)
    m = (m + m - _ONE) if small else (m - _ONE)
    z = m * m
    y = ((((((((_L0 * m + _L1) * m + _L2) * m + _L3) * m + _L4) * m + _L5) * m + _L6) * m + _L7) * m + _L8) * m * z
    y = y + _EXP_C2 * fe
    y = y - _HALF * z
    return m + y + _EXP_C1 * fe


@njit(cache=True, fastmath=FM32)
def log1p_f32(t: Float32) -> Float32:
    """log(1 + t) for float32 t > -1, relative accuracy near 0 (module docstring)."""
    u = _ONE + t
    d = u - _ONE
    lg = log_f32(u)
    return t if d == _ZERO else lg * (t / d)


@njit(cache=True, fastmath=FM32)
def sincos_u24(m: Float32) -> tuple[Float32, Float32]:
    """(cos phi, sin phi) in float32 for phi = 2 pi (m + 1/2) 2^-24, m an integer-valued float32 in
    [0, 2^24) (:func:`u24_f32`).

    The quadrant is q = floor(m 2^-22); inside it psi = pi/2 f with f = (m - q 2^22 + 1/2) 2^-22 (exact in
    float32) is pi/4 + theta, |theta| < pi/4, whose sine and cosine are Taylor polynomials to theta^9 /
    theta^10 (truncation < 2e-9; with the float32 roundings the error is below 3e-7). Floating-point
    operations only: 8 lanes per AVX2 register."""
    q = np.floor(m * _U22)
    f = (m - q * _P22 + _HALF) * _U22
    th = (f - _HALF) * _QPI
    t2 = th * th
    s = th * (_ONE + t2 * (_SN3 + t2 * (_SN5 + t2 * (_SN7 + t2 * _SN9))))
    c = _ONE + t2 * (_CS2 + t2 * (_CS4 + t2 * (_CS6 + t2 * (_CS8 + t2 * _CS10))))
    cp = (c - s) * _RSQRT2  # cos(pi/4 + theta)
    sp = (s + c) * _RSQRT2  # sin(pi/4 + theta)
    half = np.floor(q * _HALF)
    odd = q - half - half > _HALF  # rotate by q quarter turns, without branches
    neg = _ONE - half - half
    return neg * (-sp if odd else cp), neg * (cp if odd else sp)


@njit(cache=True, fastmath=FM32)
def exp2_f32(y: Float32) -> Float32:
    """2^y for float32 y, clamped to [-126, 127] (a normal result): y = n + f, |f| <= 1/2, and 2^f by a
    degree-5 polynomial (least-squares Chebyshev fit on [-1/2, 1/2]; relative error 1.0e-7, 2.5e-7 with the
    float32 roundings)."""
    y = min(max(y, _M126), _P127)
    n = np.floor(y + _HALF)
    f = y - n
    p = ((((_X5 * f + _X4) * f + _X3) * f + _X2) * f + _X1) * f + _X0
    return p * _pow2(n)


@njit(cache=True, fastmath=FM32)
def burley_rho_f32(eta: Float32) -> Float32:
    """r(xi) for d = 1, the inverse of Xie 2020's Eq. 20 cdf(r) = 1 - exp(-r)/4 - 3 exp(-r/3)/4, from
    eta = 1 - xi in (0, 1], in float32: u = exp(-r/3) is the real root of u^3 + 3u = 4 eta (Cardano:
    u = 2 sinh(asinh(2 eta) / 3)), evaluated as u = eta P(2 eta - 1) with P the degree-11 least-squares
    Chebyshev fit of u / eta on [0, 1] (relative error 4.3e-8; :data:`BURLEY_U_POLY`), then r = -3 log(u).
    No cancellation at either end: error below 1e-6 (r + 1) (tests/compute/test_numba_math.py)."""
    t = eta + eta - _ONE
    p = _U11
    p = p * t + _U10
    p = p * t + _U9
    p = p * t + _U8
    p = p * t + _U7
    p = p * t + _U6
    p = p * t + _U5
    p = p * t + _U4
    p = p * t + _U3
    p = p * t + _U2
    p = p * t + _U1
    p = p * t + _U0
    return -_THREE * log_f32(p * eta)


@intrinsic
def xoshiro128p(typingctx: object, s0: types.Type, s1: types.Type, s2: types.Type, s3: types.Type) -> _Typed:
    """One step of xoshiro128+ (Blackman and Vigna 2018, "Scrambled linear pseudorandom number generators",
    https://prng.di.unimi.it/xoshiro128plus.c) on the state (s0, s1, s2, s3) in 32-bit arithmetic:
    (output, s0', s1', s2', s3'), all uint32. The output's upper bits are the good ones (use its top 24
    bits for a float, :func:`u24_f32`)."""
    if not all(isinstance(t, types.Integer) for t in (s0, s1, s2, s3)):
        return None
    ret = types.UniTuple(types.uint32, 5)

    def codegen(context, builder, sig, args):
        i32 = ir.IntType(32)
        a, b, c, d = (_i32(builder, v, t) for v, t in zip(args, (s0, s1, s2, s3)))
        result = builder.add(a, d)
        t = builder.shl(b, ir.Constant(i32, 9))
        c = builder.xor(c, a)
        d = builder.xor(d, b)
        b = builder.xor(b, c)
        a = builder.xor(a, d)
        c = builder.xor(c, t)
        d = builder.or_(builder.shl(d, ir.Constant(i32, 11)), builder.lshr(d, ir.Constant(i32, 21)))
        return context.make_tuple(builder, ret, [result, a, b, c, d])

    return ret(s0, s1, s2, s3), codegen
