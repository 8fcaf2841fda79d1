"""numba kernels of the separable pass (:mod:`ssskit.backends.plan` for the maths; float32).

Layout. Both 1D passes read *planar, padded* buffers: colour planes R, G, B (``col``) and a depth
plane and a slot plane (``zs``), each (H + 2 pad) rows of ``wps`` = W + 2 pad + LANES texels. Pads
hold depth +inf and slot 0, so a texel is valid exactly when its slot equals the centre's: no
bounds tests. With one profile the slot plane is neither written nor read: a texel is valid exactly
when its depth is finite, which every depth factor already tests (f(+inf) = 0). Tap distances are
clamped to ``cap`` = pad - 3 pixels; pad covers the largest tap reach or, for taps reaching past the
image diagonal, the diagonal (a clamped tap still lands off the image, where it is invalid anyway).

Work is done in blocks of LANES pixels along a row, written so that LLVM vectorises the lane loops
(contiguous loads, unsigned indices: numba's negative-index wraparound makes every address a
select that blocks vectorisation). A block starts with its lane data and the range of its slots
and depths (:func:`_lane_data`: integer min/max reductions over the float bits, one vector step);
the footprint o s = o f / z of every tap row then lies between o f / z_max and o f / z_min (division
rounds monotonically), so a block is classified per tap row by two scalar products, not a loop over
its lanes. Small lane loops whose trip count LLVM sees as the constant LANES are unrolled into
scalar code before the vectoriser runs (reductions and selects are then never vectorised), so those
helpers take LANES as a run-time argument (``lanes``).

* plain rows (unjittered taps): the integer part m of a tap's footprint o s(x) changes by at most 1
  across a block (depth is smooth), so with m0 = min m the three texels m0, m0+1, m0+2 on each side,
  weighted by the hat function of o s - m0, give every lane's bilinear sample from contiguous loads;
  where every lane's m is m0 (most blocks) the third texel's weight is exactly 0 and its loads read
  the second texel again, so the vertical pass reads 4 image rows per tap, not 6 (the rows are the
  vertical pass's cost: more concurrent streams than the hardware prefetcher follows);
  blocks where m spans more take a per-lane loop;
* jittered rows (paper section 6: axes rotated by a per-pixel angle): every lane's two samples
  p +- v lie in a window of texels around it; each texel (i, j) is weighted by the separable hat
  weights hat(vx - i) hat(vy - j) of the + sample plus hat(vx + i) hat(vy + j) of the - sample, which
  is exactly the two 2D bilinear fetches, and is swept for all lanes with contiguous loads. The window
  is the set of texels the block's largest footprint rho = max |v| can reach, swept ring by ring
  (``RING_D2``: 8 texels for rho <= 1, 20 for rho <= sqrt 2, 24 for rho <= 2, up to 48 for rho <= 3;
  a full (2R+1)^2 square would take 9, 25, 25, 49, the centre included, whose term is 0), one lane
  loop per texel pair (:func:`_window`; the sums and hats in stack scratch). Windows wider than
  rho = RMAX use per-lane 2D bilinear fetches;
* blocks that straddle two profile slots take a per-lane loop with each lane's own tap table.

The jitter angle comes from the same counter-based hash as the other backends
(:mod:`ssskit.sampling.hashes`, in 32-bit arithmetic, in :func:`_lane_data`); its cosine and sine are
evaluated by a vectorisable float32 polynomial (error < 2e-7) instead of libm calls.

Every pass is compiled once per depth mode (:func:`_specialise`: the body and its helpers copied with
the mode's depth factor as a global, i.e. a compile-time constant; plain calls that LLVM inlines, no
numba-level inlining) and cached on disk (``cache=True``), so a new process compiles nothing it
compiled before. The passes release the
GIL and run over ranges of rows; the backend runs the ranges on a thread pool (rows are independent,
so the result does not depend on the number of threads).
"""

from __future__ import annotations

import math
import types
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit

from ..compute.numba_math import bits_f32, f32_bits, mix32_u32, stack_empty, u32_xor

_FM = {"nsz", "arcp", "contract", "afn", "reassoc"}  # no 'nnan'/'ninf': +inf marks empty texels
LANES = 16
RMAX = 3  # the widest jitter window: footprints rho <= RMAX pixels
_L = LANES
_W = 2 * RMAX + 1
_WL = _W * _L
_L3 = 3 * _L
_L4 = 4 * _L
_L6 = 6 * _L
_IMAX = 0x7FFFFFFF  # the largest int32, above the bits of every float32 >= 0 (+inf included)


@njit(cache=True, fastmath=_FM)
def f_gaussian(dz, p):
    """Supplement E: exp(-d_z^2 p), p = 1 / (2 tau_max)."""
    return np.float32(math.exp(-dz * dz * p))


@njit(cache=True, fastmath=_FM)
def f_follow(dz, p):
    """Follow-surface test: max(0, 1 - |d_z| p), p = 1 / width."""
    return max(np.float32(0.0), np.float32(1.0) - abs(dz) * p)


@njit(cache=True, fastmath=_FM)
def f_none(dz, p):
    """No depth test: 1 unless the texel has no surface (infinite depth)."""
    return np.float32(1.0) if abs(dz) < np.float32(np.inf) else np.float32(0.0)


@njit(cache=True, inline="always")
def _mix32(h):
    """lowbias32 (ssskit.sampling.hashes.mix32) on a uint64 holding 32 bits."""
    h = h ^ (h >> np.uint64(16))
    h = (h * np.uint64(0x7FEB352D)) & np.uint64(0xFFFFFFFF)
    h = h ^ (h >> np.uint64(15))
    h = (h * np.uint64(0x846CA68B)) & np.uint64(0xFFFFFFFF)
    return h ^ (h >> np.uint64(16))


@njit(cache=True, fastmath=_FM)
def _unit(h):
    """(cos theta, sin theta) in float32 for theta = 2 pi h / 2^32: quadrant q = h >> 30, then the angle
    psi = pi/2 f in the quadrant (f the low 30 bits / 2^30, rounded to float32) as pi/4 + phi with
    |phi| <= pi/4, whose sine and cosine are Taylor polynomials to phi^9 / phi^10 (truncation error
    < 2e-9; with float32 rounding the error is < 2e-7, i.e. < 6e-7 px for a 3 px footprint). float32
    arithmetic: 8 lanes per AVX2 vector, twice the float64 polynomial's throughput."""
    q = np.int32(h >> np.uint64(30))
    f = np.float32(np.int32(h & np.uint64(0x3FFFFFFF))) * np.float32(1.0 / 1073741824.0)
    phi = (f - np.float32(0.5)) * np.float32(0.5 * math.pi)
    x2 = phi * phi
    one = np.float32(1.0)
    s = phi * (one - x2 * np.float32(1 / 6) * (one - x2 * np.float32(1 / 20) * (one - x2 * np.float32(1 / 42) * (
        one - x2 * np.float32(1 / 72)))))
    c = one - x2 * np.float32(1 / 2) * (one - x2 * np.float32(1 / 12) * (one - x2 * np.float32(1 / 30) * (
        one - x2 * np.float32(1 / 56) * (one - x2 * np.float32(1 / 90)))))
    r = np.float32(0.7071067811865476)
    cp = (c - s) * r  # cos(pi/4 + phi)
    sp = (s + c) * r  # sin(pi/4 + phi)
    odd = (q & np.int32(1)) != np.int32(0)  # rotate by q quarter turns, without branches
    neg = one - np.float32(2.0) * np.float32(q >> np.int32(1))
    return neg * (-sp if odd else cp), neg * (cp if odd else sp)


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _lane_data(buf, sc, zo, so, c0, fa, multi, jit, hrow, x0, axis, lanes):
    """The lane data of the block at flat index c0 (x0 in the image) into ``sc``: depth, slot, pixels per mm
    fa / z where the slot is > 0 (one profile, ``multi`` False: the slot is 1 where the depth is finite, the
    slot plane unread) and, if ``jit``, the jitter axis: the unit vector at the angle theta(x, y) of
    :mod:`ssskit.sampling.hashes` (lowbias32 in 32-bit arithmetic; row hash ``hrow``), (cos, sin) horizontally
    (``axis`` 0), (-sin, cos) vertically. Returns the bits of the block's (smallest, largest) slot and depth
    among the lanes with SSS (_IMAX and 0 if none): slots and depths are >= 0, so their bits sort as the
    values do, and integer min/max reductions vectorise (float ones need 'nnan', which +inf texels rule out).
    ``lanes`` = LANES, passed at run time: with a constant trip count LLVM unrolls the loops into scalar code
    (one hash and one polynomial sine and cosine per pixel); with it, one 16-lane vector step each."""
    U = np.uintp
    imax = np.int32(_IMAX)
    izero = np.int32(0)
    zero = np.float32(0.0)
    qlo = imax
    qhi = izero
    zlo = imax
    zhi = izero
    for l in range(lanes):
        lu = U(l)
        z = buf[zo + U(c0) + lu]
        q = buf[so + U(c0) + lu] if multi else (np.float32(1.0) if z < np.float32(np.inf) else zero)
        sc[U(_LN) + lu] = z
        sc[U(_LN + _L) + lu] = q
        sc[U(_LN + 2 * _L) + lu] = fa / z if q > zero else zero
        qi = f32_bits(q)
        zi = f32_bits(z)
        ok = qi > izero
        qhi = max(qhi, qi)
        qlo = min(qlo, qi if ok else imax)
        zlo = min(zlo, zi if ok else imax)
        zhi = max(zhi, zi if ok else izero)
    if jit:
        for l in range(lanes):
            lu = U(l)
            c, s = _unit(mix32_u32(u32_xor(hrow, x0 + l)))
            sc[U(_LN + 3 * _L) + lu] = c if axis == 0 else -s
            sc[U(_LN + 4 * _L) + lu] = s if axis == 0 else c
    return qlo, qhi, zlo, zhi


# Names the mode-dependent helpers below read as globals; :func:`_specialise` binds them in each depth mode's
# copies (declared here for the type checker only): the depth factor, whether texels take the slot test,
# and the plain-row kernel with the slot test.
factor: Callable[[Any, Any], Any]
MULTI: bool
_row_block_multi: Callable[..., None]

# With several profile slots a block checks the block-slot map (``block_slot_rows``) over the rows and blocks
# its taps reach: where no other profile is there it skips the per-texel slot test.
# Layout of the frame buffer ``buf`` (planes of (H + 2 pad) x wps texels): input colour R, G, B; depth; slot;
# the horizontal pass's colour R', G', B'. Per-row scratch ``sc``: the accumulators (6 x LANES: A_R, A_G,
# A_B, G_R, G_G, G_B), the lane data (7 x LANES: depth, slot, pixels per mm, jitter axis x, y, jitter offset
# vx, vy) and the jitter window's hat weights (2 x (2 RMAX + 1) x LANES: hat(vx - i), then hat(vy - j), for
# i, j = -RMAX..RMAX). Two arrays in every hot loop: LLVM vectorises.
PLANES = 8
Z_PLANE, S_PLANE, TMP_PLANE = 3, 4, 5
_LN = 6 * _L  # lane data offset in sc
_HX = 13 * _L  # hat weights offset in sc
_WS = 13 * _L + 2 * _W * _L  # the window sums (4 x LANES: g, g E_R, g E_G, g E_B)
SCRATCH = _WS + 4 * _L


def _tex(buf, zo, so, i, z0, s0, p, multi):
    """Depth factor x slot test of texel i (flat index) for a centre at depth z0 in slot s0. With a
    single slot (``multi`` False, a constant at every call site) the test is the depth's finiteness,
    which every factor already applies."""
    f = factor(buf[zo + i] - z0, p)
    return f * np.float32(buf[so + i] == s0) if multi else f


def _accumulate(sc, lu, w, gp, gm, sp0, sp1, sp2, sm0, sm1, sm2, sym):
    """Accumulators += the + and - samples of one row; w = the row's weights (w+_R, w+_G, w+_B, w-_R,
    w-_G, w-_B), scalars; ``sym`` (a constant at every call site): w+ == w- (a symmetric pair)."""
    U = np.uintp
    if sym:
        gs = gp + gm
        sc[lu] += w[0] * (sp0 + sm0)
        sc[U(_L) + lu] += w[1] * (sp1 + sm1)
        sc[U(2 * _L) + lu] += w[2] * (sp2 + sm2)
        sc[U(3 * _L) + lu] += w[0] * gs
        sc[U(4 * _L) + lu] += w[1] * gs
        sc[U(5 * _L) + lu] += w[2] * gs
        return
    sc[lu] += w[0] * sp0 + w[3] * sm0
    sc[U(_L) + lu] += w[1] * sp1 + w[4] * sm1
    sc[U(2 * _L) + lu] += w[2] * sp2 + w[5] * sm2
    sc[U(3 * _L) + lu] += w[0] * gp + w[3] * gm
    sc[U(4 * _L) + lu] += w[1] * gp + w[4] * gm
    sc[U(5 * _L) + lu] += w[2] * gp + w[5] * gm


def _bilinear(buf, co, zo, so, plane, wps, c, vx, vy, z0, s0, p, multi):
    """2D bilinear sample at (vx, vy) pixels from flat index c: (g, S_R, S_G, S_B), each texel with
    its own depth factor and slot test."""
    U = np.uintp
    fx = np.floor(vx)
    fy = np.floor(vy)
    tx = np.float32(vx - fx)
    ty = np.float32(vy - fy)
    i = U(c + int(fy) * wps + int(fx))
    one = np.float32(1.0)
    g = s0_ = s1 = s2 = np.float32(0.0)
    for k in range(4):
        di = U(k & 1)
        dj = U(k >> 1)
        b = (tx if di else one - tx) * (ty if dj else one - ty)
        t = i + di + dj * U(wps)
        gt = b * _tex(buf, zo, so, t, z0, s0, p, multi)
        g += gt
        s0_ += gt * buf[co + t]
        s1 += gt * buf[co + U(plane) + t]
        s2 += gt * buf[co + U(2 * plane) + t]
    return g, s0_, s1, s2


def _lane_row(buf, sc, co, zo, so, plane, wps, c, rho, ux, uy, z0, s0, p, w, l, multi):
    """One row for one lane by 2D bilinear fetches at +-rho (ux, uy) (the slot test with several profiles)."""
    gp, a0, a1, a2 = _bilinear(buf, co, zo, so, plane, wps, c, rho * ux, rho * uy, z0, s0, p, multi)
    gm, b0, b1, b2 = _bilinear(buf, co, zo, so, plane, wps, c, -rho * ux, -rho * uy, z0, s0, p, multi)
    _accumulate(sc, np.uintp(l), w, gp, gm, a0, a1, a2, b0, b1, b2, False)


def _row_block(buf, sc, co, zo, so, plane, c0, st, three, d, mmin, w, p, cap):
    """A plain row for a block of lanes in one slot whose footprints' integer parts lie in
    [mmin, mmin + 1] (module docstring). ``three`` False: they all equal mmin, so the hat weight of texels
    +-(m0 + 2) is exactly 0 in every lane; those two loads then read the texels +-(m0 + 1) again (a zero
    times a finite value: the same sums) instead of two more image rows, which in the vertical pass are
    two more streams from memory per channel (its two plain pairs cost 1.45x less this way)."""
    U = np.uintp
    one = np.float32(1.0)
    zero = np.float32(0.0)
    mi = int(mmin)
    bp = U(c0 + mi * st)  # + side: texels m0, m0 + 1, m0 + 2
    bm = U(c0 - mi * st - 2 * st)  # - side: texels -m0 - 2, -m0 - 1, -m0
    s1 = U(st)
    s2 = U(2 * st)
    s3 = s2 if three else s1  # the + side's third texel
    bz = bm if three else bm + s1  # the - side's third texel
    c1 = co + U(plane)
    c2 = co + U(2 * plane)
    # the lane data and the accumulators on the stack: LLVM knows they alias no texel, so the lane loop
    # vectorises without runtime overlap checks (16 lanes: one AVX-512 step, two AVX2 steps)
    ld = stack_empty(_L3, np.float32)
    acc = stack_empty(_L6, np.float32)
    for i in range(_L3):
        ld[U(i)] = sc[U(_LN + i)]
    for i in range(_L6):
        acc[U(i)] = sc[U(i)]
    for l in range(_L):
        lu = U(l)
        z0 = ld[lu]
        q0 = ld[U(_L) + lu]
        tp = min(d * ld[U(2 * _L) + lu], cap) - mmin
        h0 = max(zero, one - tp)
        h1 = max(zero, one - abs(tp - one))
        h2 = max(zero, tp - one)
        a = bp + lu
        b = bm + lu
        g0 = h0 * _tex(buf, zo, so, a, z0, q0, p, MULTI)
        g1 = h1 * _tex(buf, zo, so, a + s1, z0, q0, p, MULTI)
        g2 = h2 * _tex(buf, zo, so, a + s3, z0, q0, p, MULTI)
        bb = bz + lu
        n2 = h2 * _tex(buf, zo, so, bb, z0, q0, p, MULTI)
        n1 = h1 * _tex(buf, zo, so, b + s1, z0, q0, p, MULTI)
        n0 = h0 * _tex(buf, zo, so, b + s2, z0, q0, p, MULTI)
        _accumulate(acc, lu, w, g0 + g1 + g2, n0 + n1 + n2,
                    g0 * buf[co + a] + g1 * buf[co + a + s1] + g2 * buf[co + a + s3],
                    g0 * buf[c1 + a] + g1 * buf[c1 + a + s1] + g2 * buf[c1 + a + s3],
                    g0 * buf[c2 + a] + g1 * buf[c2 + a + s1] + g2 * buf[c2 + a + s3],
                    n2 * buf[co + bb] + n1 * buf[co + b + s1] + n0 * buf[co + b + s2],
                    n2 * buf[c1 + bb] + n1 * buf[c1 + b + s1] + n0 * buf[c1 + b + s2],
                    n2 * buf[c2 + bb] + n1 * buf[c2 + b + s1] + n0 * buf[c2 + b + s2], True)
    for i in range(_L6):
        sc[U(i)] = acc[U(i)]


#: The jitter window's rings: texels (i, j) grouped by the squared distance d2 = max(0, |i| - 1)^2 +
#: max(0, |j| - 1)^2 from the centre to the nearest point of their open square |x - i| < 1, |y - j| < 1 (where
#: the texel's bilinear weight hat(x - i) hat(y - j) is nonzero). A sample at |v| <= rho weights a texel only
#: if d2 < rho^2, so a block whose largest jittered footprint is rho sweeps the rings with d2 < rho^2. The
#: centre texel (0, 0) is left out of ring 0: its term w g (E_p - E_p) of plan.py's sum is 0.
RING_D2 = (0, 1, 2, 4, 5, 8)
RING_R = (1, 2, 2, 3, 3, 3)  # window radius max(|i|, |j|) of each ring (and every ring before it)


def ring_texels(n: int) -> list[tuple[int, int]]:
    """Texels of ring n, one of each symmetric pair (i, j), (-i, -j): j > 0, or j = 0 and i > 0."""
    d2 = RING_D2[n]
    r = RING_R[n]
    return [(i, j) for j in range(0, r + 1) for i in range(-r, r + 1)
            if (j > 0 or i > 0) and max(0, abs(i) - 1) ** 2 + max(0, abs(j) - 1) ** 2 == d2]


#: The window's texel pairs, ring by ring (one of each pair (i, j), (-i, -j)), and the number of pairs in the
#: first n + 1 rings: a block whose largest footprint needs rings 0..n sweeps pairs [0, RING_PAIRS[n]).
_PAIRS = [t for n in range(len(RING_D2)) for t in ring_texels(n)]
_PI = tuple(i for i, _ in _PAIRS)
_PJ = tuple(j for _, j in _PAIRS)
RING_PAIRS = tuple(sum(len(ring_texels(m)) for m in range(n + 1)) for n in range(len(RING_D2)))


def _window(buf, sc, co, zo, plane, wps, c0, w, p, d, cap, npairs):
    """A jittered row for a block of lanes in one profile (symmetric rows only: w+ = w-): the first ``npairs``
    texel pairs of the window (module docstring), one lane loop per pair (LLVM vectorises it).

    For lane l with sample offsets +-v, texel (i, j) gets hat(vx - i) hat(vy - j) + hat(vx + i) hat(vy + j),
    the two bilinear weights (hat(t) = max(0, 1 - |t|)), which is also texel (-i, -j)'s weight: computed
    once per pair. The first lane loop computes each lane's (vx, vy) and the hats hx[i + RMAX] = hat(vx - i),
    hy[j + RMAX] = hat(vy - j) of the whole window into the scratch; the pair loops sum g and g E per lane
    in the scratch's window sums; the last loop adds them to the accumulators times the row's weights."""
    U = np.uintp
    zero = np.float32(0.0)
    one = np.float32(1.0)
    hx = stack_empty(_WL, np.float32)  # on the stack: LLVM knows it aliases nothing, so the loops vectorise
    hy = stack_empty(_WL, np.float32)
    ws = stack_empty(_L4, np.float32)
    zc = stack_empty(_L, np.float32)
    for l in range(_L):
        lu = U(l)
        rho = min(d * sc[U(_LN + 2 * _L) + lu], cap)
        vx = np.float32(rho * sc[U(_LN + 3 * _L) + lu])
        vy = np.float32(rho * sc[U(_LN + 4 * _L) + lu])
        zc[lu] = sc[U(_LN) + lu]
        for k in range(_W):
            o = np.float32(k - RMAX)
            hx[U(k * _L) + lu] = max(zero, one - abs(vx - o))
            hy[U(k * _L) + lu] = max(zero, one - abs(vy - o))
        ws[lu] = zero
        ws[U(_L) + lu] = zero
        ws[U(2 * _L) + lu] = zero
        ws[U(3 * _L) + lu] = zero
    b = U(c0 - RMAX * wps - RMAX)
    zb = zo + b
    rb = co + b
    gb_ = co + U(plane) + b
    bb = co + U(2 * plane) + b
    for q in range(npairs):
        i = _PI[q]
        j = _PJ[q]
        oa = U((RMAX + j) * wps + RMAX + i)
        ob = U((RMAX - j) * wps + RMAX - i)
        xa = U((RMAX + i) * _L)
        ya = U((RMAX + j) * _L)
        xb = U((RMAX - i) * _L)
        yb = U((RMAX - j) * _L)
        for l in range(_L):
            lu = U(l)
            z0 = zc[lu]
            wt = hx[xa + lu] * hy[ya + lu] + hx[xb + lu] * hy[yb + lu]
            ta = oa + lu
            tb = ob + lu
            ga = wt * factor(buf[zb + ta] - z0, p)
            gb = wt * factor(buf[zb + tb] - z0, p)
            ws[lu] += ga + gb
            ws[U(_L) + lu] += ga * buf[rb + ta] + gb * buf[rb + tb]
            ws[U(2 * _L) + lu] += ga * buf[gb_ + ta] + gb * buf[gb_ + tb]
            ws[U(3 * _L) + lu] += ga * buf[bb + ta] + gb * buf[bb + tb]
    for l in range(_L):
        lu = U(l)
        g_ = ws[lu]
        sc[lu] += w[0] * ws[U(_L) + lu]
        sc[U(_L) + lu] += w[1] * ws[U(2 * _L) + lu]
        sc[U(2 * _L) + lu] += w[2] * ws[U(3 * _L) + lu]
        sc[U(3 * _L) + lu] += w[0] * g_
        sc[U(4 * _L) + lu] += w[1] * g_
        sc[U(5 * _L) + lu] += w[2] * g_


def _sep_body(buf, out, co, ob, ocs, oys, oxs, y0, y1, w, pad, wps, plane, axis, f_axis, offs, wts, n_jit,
              n_rows, centre, param, base, cap, bmap, lanes):
    """One 1D pass of one term over the whole image (module docstring), reading colour planes at ``co``
    of ``buf``. ``out`` is flat; pixel (x, y) channel c goes to out[ob + c ocs + y oys + x oxs] (the
    horizontal pass writes buf's TMP planes, the vertical one the (H, W, 3) result).
    ``wts`` (S, K, 6): each row's w+ (R, G, B) and w- (R, G, B)."""
    U = np.uintp
    st = 1 if axis == 0 else wps
    fa = np.float32(f_axis)
    one = np.float32(1.0)
    zero = np.float32(0.0)
    zo = U(Z_PLANE * plane)
    so = U(S_PLANE * plane)
    cu = U(co)
    kmax = offs.shape[1]
    h_img, nbx = bmap.shape
    n_jits = 0
    for i in range(n_jit.size):
        n_jits += n_jit[i]
    multi = n_jit.size > 2  # more than one profile slot: texels must pass the slot test
    sym = np.empty(offs.shape, np.bool_)  # rows whose + and - weights are equal (symmetric pairs)
    for i in range(offs.shape[0]):
        for k in range(kmax):
            sym[i, k] = (wts[i, k, 0] == wts[i, k, 3] and wts[i, k, 1] == wts[i, k, 4]
                         and wts[i, k, 2] == wts[i, k, 5])
    sc = np.empty(SCRATCH, np.float32)
    mlo = np.empty(kmax, np.float32)
    m3 = np.empty(kmax, np.bool_)
    rwin = np.empty(kmax, np.int64)
    for y in range(y0, y1):
        hrow = mix32_u32(u32_xor(base, y))
        row0 = (y + pad) * wps + pad
        for x0 in range(0, w, _L):
            nl = min(_L, w - x0)
            c0 = row0 + x0
            # lane data (lanes past the image read pad texels: slot 0), the block's slots and pixels-per-mm range
            qlo, qhi, zlo, zhi = _lane_data(buf, sc, zo, so, c0, fa, multi, n_jits > 0, hrow, x0, axis, lanes)
            sb = int(bits_f32(qhi))
            mixed = qlo != qhi
            smin = fa / bits_f32(zhi)  # pixels per mm fa / z of the lanes with SSS (division rounds monotonically)
            smax = fa / bits_f32(zlo)
            if sb > 0:
                for i in range(6 * _L):
                    sc[i] = 0.0
                # the vectorised paths take symmetric pairs whose footprints vary little across the block
                # and jitter windows of radius <= RMAX, on one profile (several: plain rows only); anything
                # else sends the whole block to per-lane fetches (one code path, small compiled code)
                fast = not mixed
                alone = not multi  # no other profile within the block's reach: no slot test needed
                if fast:
                    nj = n_jit[sb]
                    reach = 0
                    rjit = 0
                    for k in range(n_rows[sb]):
                        d = offs[sb, k]
                        lo = np.floor(min(d * smin, cap))  # every lane's footprint o s lies in [lo, hi]
                        hi = min(d * smax, cap)
                        fast = fast and sym[sb, k]
                        if k < nj:
                            h2 = float(hi) * float(hi)
                            nr = 0  # rings to sweep: those with d2 < rho^2
                            for ring in range(len(RING_D2)):
                                nr += 1 if RING_D2[ring] < h2 else 0
                            nr = max(nr, 1)
                            rwin[k] = RING_PAIRS[nr - 1]
                            fast = fast and h2 <= (RMAX * RMAX)
                            rjit = max(rjit, RING_R[nr - 1])
                        else:
                            mlo[k] = lo
                            m3[k] = np.floor(hi) > lo
                            fast = fast and np.floor(hi) - lo <= 1.0
                            reach = max(reach, int(np.floor(hi)) + 2)
                    if fast and multi:  # scan the texels the block can reach for another profile
                        rj = rjit + 1 if nj > 0 else 0
                        rx = max(reach, rj) if axis == 0 else rj  # jitter windows reach rj along both axes
                        ry = rj if axis == 0 else max(reach, rj)
                        # in the block-slot map: one entry per row and 16-pixel block (module docstring)
                        others = 0
                        bx0 = max(0, (x0 - rx) // _L)
                        bx1 = min(nbx - 1, (x0 + _L - 1 + rx) // _L)
                        for j in range(max(0, y - ry), min(h_img, y + ry + 1)):
                            for bx in range(bx0, bx1 + 1):
                                q = bmap[j, bx]
                                others += 1 if (q != 0 and q != sb) else 0
                        alone = others == 0
                        fast = alone or nj == 0  # jitter windows only where no other profile is near
                if fast:
                    p = param[sb]
                    for k in range(n_rows[sb]):
                        wk = (wts[sb, k, 0], wts[sb, k, 1], wts[sb, k, 2], wts[sb, k, 3], wts[sb, k, 4], wts[sb, k, 5])
                        # constant lane counts and window radii (all LANES lanes are computed: the buffer's
                        # right slack makes lanes past the image pad texels) let LLVM vectorise fully
                        if k < n_jit[sb]:
                            _window(buf, sc, cu, zo, plane, wps, c0, wk, p, offs[sb, k], cap, rwin[k])
                        elif not alone:
                            _row_block_multi(buf, sc, cu, zo, so, plane, c0, st, m3[k], offs[sb, k], mlo[k], wk, p, cap)
                        else:  # the common case: one profile, symmetric pairs
                            _row_block(buf, sc, cu, zo, so, plane, c0, st, m3[k], offs[sb, k], mlo[k], wk, p, cap)
                else:  # several slots, asymmetric taps, wide jitter windows or varying footprints
                    for l in range(nl):
                        qi = int(sc[_LN + _L + l])
                        if qi == 0:
                            continue
                        for k in range(n_rows[qi]):
                            jit = k < n_jit[qi]
                            ax = sc[_LN + 3 * _L + l] if jit else (one if axis == 0 else zero)
                            ay = sc[_LN + 4 * _L + l] if jit else (zero if axis == 0 else one)
                            wk = (wts[qi, k, 0], wts[qi, k, 1], wts[qi, k, 2], wts[qi, k, 3], wts[qi, k, 4],
                                  wts[qi, k, 5])
                            _lane_row(buf, sc, cu, zo, so, plane, wps, c0 + l,
                                      min(offs[qi, k] * sc[_LN + 2 * _L + l], cap), ax, ay, sc[_LN + l],
                                      sc[_LN + _L + l], param[qi], wk, l, multi)
            for c in range(3):  # the block's result, into its accumulators A_c
                ci = cu + U(c * plane + c0)
                if sb > 0 and not mixed:
                    wc = centre[sb, c]
                    for l in range(nl):
                        lu = U(l)
                        e = buf[ci + lu]
                        v = (wc - sc[U((3 + c) * _L) + lu]) * e + sc[U(c * _L) + lu]
                        sc[U(c * _L) + lu] = v if sc[U(_LN + _L) + lu] > zero else e
                else:
                    for l in range(nl):
                        e = buf[ci + U(l)]
                        qi = int(sc[_LN + _L + l])
                        sc[c * _L + l] = e if qi == 0 else (centre[qi, c] - sc[(3 + c) * _L + l]) * e + sc[c * _L + l]
            o = ob + y * oys + x0 * oxs
            if oxs == 1:  # planar (the horizontal pass)
                for c in range(3):
                    for l in range(nl):
                        out[U(o + c * ocs + l)] = sc[U(c * _L + l)]
            else:  # interleaved RGB (the vertical pass: oxs = 3, ocs = 1)
                _store_rgb(out, o, sc, nl)


@njit(cache=True, error_model="numpy")
def _store_rgb(out, o, sc, nl):
    """out[o + 3 l + c] = sc[c LANES + l] for the nl lanes of a block: one interleaved (vectorised) store."""
    U = np.uintp
    for l in range(nl):
        lu = U(l)
        out[U(o) + U(3) * lu] = sc[lu]
        out[U(o) + U(3) * lu + U(1)] = sc[U(_L) + lu]
        out[U(o) + U(3) * lu + U(2)] = sc[U(2 * _L) + lu]


def _copy(fn: Callable[..., Any], namespace: dict[str, Any], name: str) -> Callable[..., Any]:
    """``fn``'s code under the globals ``namespace`` and the name ``name`` (numba's cache names its files
    by the qualified name: each copy gets its own)."""
    out = types.FunctionType(fn.__code__, namespace, name, fn.__defaults__, fn.__closure__)
    out.__qualname__ = name
    out.__doc__ = fn.__doc__
    return out


def _specialise(mode: str, factor: Any) -> Any:
    """The pass of depth mode ``mode``: :func:`_sep_body` and its helpers copied with the mode's depth factor
    (and, for the helpers that test slots, ``MULTI``) as globals, i.e. compile-time constants, so that numba
    compiles plain calls (LLVM inlines the small ones) instead of inlining every helper into its caller
    (numba's IR inlining took half of the first compilation) and the pass is cached on disk
    (``cache=True``; a depth factor passed as an argument would make it uncacheable)."""
    ns: dict[str, Any] = dict(globals())
    ns["factor"] = factor
    ns["MULTI"] = False
    multi = dict(ns, MULTI=True)
    jit = njit(fastmath=_FM, error_model="numpy")  # no ZeroDivisionError checks: they block vectorisation
    for fn in (_tex, _accumulate, _bilinear, _lane_row, _window):
        ns[fn.__name__] = jit(_copy(fn, ns, f"{fn.__name__}_{mode}"))
    multi.update({k: ns[k] for k in ("_tex", "_accumulate")})
    ns["_row_block"] = jit(_copy(_row_block, ns, f"_row_block_{mode}"))
    ns["_row_block_multi"] = jit(_copy(_row_block, multi, f"_row_block_multi_{mode}"))
    return njit(cache=True, nogil=True, fastmath=_FM, error_model="numpy")(_copy(_sep_body, ns, f"pass_{mode}"))


pass_gaussian = _specialise("gaussian", f_gaussian)
pass_follow = _specialise("follow", f_follow)
pass_none = _specialise("none", f_none)


PASSES = {"gaussian": pass_gaussian, "follow": pass_follow, "none": pass_none}


@njit(cache=True, nogil=True, error_model="numpy")
def pack_rows(diffuse, depth_mm, slots, buf, pad, wps, plane, y0, y1, write, slot_plane, stats):
    """Rows [y0, y1) of the frame: copied into buf's input planes when ``write`` (pads were set once: colour 0,
    depth +inf, slot 0; the slot plane only if ``slot_plane``: with one profile the passes read a texel's
    validity from its depth), and per row y in stats[y] = (nearest depth with SSS, bad depths (not positive and
    finite where slot > 0), smallest slot, largest slot, non-finite colour values (on any pixel)): one read of
    the frame checks it and sizes the pad.
    One loop per task, each of which LLVM vectorises: the colours (stride-3 loads, permutes), the checks
    (branch-free, the nearest depth as an integer reduction over its bits, as in :func:`_lane_data`), the
    colours' check (a count of v - v != 0 over the row, after the depth checks: placed before them, it and
    they ran scalar, 4x slower), the depth plane, the slot plane: 3 ms of one core at 1080p where one loop
    doing everything took 9 (about 0.5 ms more with the colours' check, 2 threads). No
    parallel loop (its compilation costs seconds): the backend runs ranges of rows on its thread pool."""
    h, w = slots.shape
    imax = np.int32(_IMAX)
    inf = np.float32(np.inf)
    zero = np.float32(0.0)
    U = np.uintp
    d = diffuse.reshape(diffuse.size)  # (C-contiguous) flat: the colour loop is one interleaved vector load
    for y in range(y0, y1):
        r = U((y + pad) * wps + pad)
        if write:  # the colour planes (its own loop: LLVM vectorises the stride-3 loads with permutes)
            s = U(3 * w * y)
            for x in range(w):
                xu = U(x)
                buf[r + xu] = d[s + U(3) * xu]
                buf[U(plane) + r + xu] = d[s + U(3) * xu + U(1)]
                buf[U(2 * plane) + r + xu] = d[s + U(3) * xu + U(2)]
        zlo = imax
        bad = np.int32(0)
        smin = np.int32(0)
        smax = np.int32(0)
        for x in range(w):  # the checks
            q = slots[y, x]
            z = depth_mm[y, x]
            inside = q > 0
            ok = (z > zero) & (z < inf)
            bad += np.int32(inside) - np.int32(inside & ok)
            zlo = min(zlo, f32_bits(z) if inside & ok else imax)
            smin = min(smin, q)
            smax = max(smax, q)
        nonfinite = np.int32(0)
        cs = U(3 * w * y)
        for x in range(3 * w):  # the colours' check (its own loop, vectorised): v - v is 0 unless v is NaN or inf
            v = d[cs + U(x)]
            nonfinite += np.int32((v - v) != zero)
        if write:
            for x in range(w):
                xu = U(x)
                buf[U(Z_PLANE * plane) + r + xu] = depth_mm[y, x] if slots[y, x] > 0 else inf
            if slot_plane:
                for x in range(w):
                    buf[U(S_PLANE * plane) + r + U(x)] = slots[y, x]
        stats[y, 0] = bits_f32(zlo) if zlo != imax else np.inf
        stats[y, 1] = bad
        stats[y, 2] = smin
        stats[y, 3] = smax
        stats[y, 4] = nonfinite


@njit(cache=True, nogil=True)
def block_slot_rows(slots, out, y0, y1):
    """Rows [y0, y1) of the block-slot map out (H, ceil(W / LANES)) int32: for each row and block of LANES
    pixels, the one nonzero slot its pixels have (0 if none, -1 if several): with several profiles, a block
    of the pass reads it to learn whether any other profile lies within its taps' reach."""
    h, w = slots.shape
    nbx = out.shape[1]
    for y in range(y0, y1):
        for bx in range(nbx):
            v = 0
            for x in range(bx * _L, min(w, bx * _L + _L)):
                q = slots[y, x]
                if q > 0:
                    v = q if v == 0 or v == q else -1
            out[y, bx] = v
