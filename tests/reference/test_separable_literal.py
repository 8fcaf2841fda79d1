"""Slow, literal per-pixel oracle of the separable pass: the formula of ssskit.backends.plan written out
pixel by pixel in plain Python (the jitter hash too, on Python integers), checked against the numpy
backend (the oracle every fast backend is tested against) on tiny frames."""

import math

import numpy as np
import pytest

from ssskit.backends import build_separable_plan, get_backend
from ssskit.sampling.taps import SeparableTaps


def lowbias32(h: int) -> int:
    """C. Wellons' lowbias32, on Python integers."""
    h &= 0xFFFFFFFF
    h ^= h >> 16
    h = (h * 0x7FEB352D) & 0xFFFFFFFF
    h ^= h >> 15
    h = (h * 0x846CA68B) & 0xFFFFFFFF
    return h ^ (h >> 16)


def angle(x: int, y: int, frame: int, seed: int) -> float:
    base = lowbias32(lowbias32(seed ^ 0x9E3779B9) ^ frame)
    return lowbias32(lowbias32(base ^ y) ^ x) * 2.0 * math.pi / 2**32


def factor(mode: str, dz: float, param: float) -> float:
    if mode == "gaussian":
        return math.exp(-dz * dz * param)  # supplement E
    if mode == "follow":
        return max(0.0, 1.0 - abs(dz) * param)
    return 1.0


def literal_pass(E, z, slots, f_axis, horizontal, term, plan):
    h, w = len(slots), len(slots[0])
    out = [[list(E[y][x]) for x in range(w)] for y in range(h)]
    for y in range(h):
        for x in range(w):
            s = slots[y][x]
            if s == 0:
                continue
            ppm = f_axis / z[y][x]
            val = [term.centre[s][c] * E[y][x][c] for c in range(3)]
            for k in range(term.n_rows[s]):
                o = term.offsets_mm[s][k] * ppm
                if k < term.n_jit[s]:
                    th = angle(x, y, plan.frame, plan.seed)
                    ux, uy = (math.cos(th), math.sin(th)) if horizontal else (-math.sin(th), math.cos(th))
                else:
                    ux, uy = (1.0, 0.0) if horizontal else (0.0, 1.0)
                for side, wts in ((1.0, term.w_plus[s][k]), (-1.0, term.w_minus[s][k])):
                    sx, sy = x + side * o * ux, y + side * o * uy
                    i0, j0 = math.floor(sx), math.floor(sy)
                    tx, ty = sx - i0, sy - j0
                    for i, j, b in ((i0, j0, (1 - tx) * (1 - ty)), (i0 + 1, j0, tx * (1 - ty)),
                                    (i0, j0 + 1, (1 - tx) * ty), (i0 + 1, j0 + 1, tx * ty)):
                        if b == 0 or not (0 <= i < w and 0 <= j < h) or slots[j][i] != s:
                            continue
                        f = factor(plan.depth_mode, z[j][i] - z[y][x], plan.depth_param[s])
                        for c in range(3):
                            val[c] += wts[c] * b * f * (E[j][i][c] - E[y][x][c])
            out[y][x] = val
    return out


def literal_frame(E, z, slots, plan):
    h, w = len(slots), len(slots[0])
    total = [[[0.0] * 3 for _ in range(w)] for _ in range(h)]
    for term in plan.terms:
        v = literal_pass(literal_pass(E, z, slots, plan.fx, True, term, plan), z, slots, plan.fy, False, term, plan)
        for y in range(h):
            for x in range(w):
                for c in range(3):
                    total[y][x][c] += term.sign[slots[y][x]][c] * v[y][x][c]
    return np.array([[total[y][x] if slots[y][x] else list(E[y][x]) for x in range(w)] for y in range(h)])


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["gaussian", "follow", "none"])
@pytest.mark.parametrize("jitter", [0.0, 0.6])
def test_numpy_backend_is_the_literal_formula(mode, jitter):
    rng = np.random.default_rng(3)
    h, w = 9, 11
    sym = SeparableTaps([[0.0, 1.1, -1.1, 2.9, -2.9]],
                        [[[0.3, 0.4, 0.5], [0.2, 0.15, 0.1], [0.2, 0.15, 0.1], [0.15, 0.15, 0.15], [0.15, 0.15, 0.15]]],
                        [[1.0, 1.0, 1.0]], "test", 2.9)
    rank2 = SeparableTaps([[0.0, 0.7, -1.3], [0.0, 1.9, -1.9]],
                          [[[0.5] * 3, [0.3, 0.2, 0.1], [0.2, 0.3, 0.4]], [[0.2] * 3, [0.1] * 3, [0.1] * 3]],
                          [[1.0, 1.0, 1.0], [-1.0, -1.0, -1.0]], "test", 1.9)
    slots = np.ones((h, w), np.int64)
    slots[:, 6:] = 2
    slots[0, :3] = 0
    z = (250.0 + 4.0 * rng.random((h, w))) * np.where(slots > 0, 1.0, np.inf)
    E = rng.random((h, w, 3))
    plan = build_separable_plan({1: sym, 2: rank2}, 120.0, 150.0, jitter=jitter, depth_mode=mode, frame=3, seed=11)
    plan = type(plan)(plan.ids, plan.terms, plan.depth_mode, np.array([0.0, 0.02, 0.05]), plan.fx, plan.fy,
                      plan.frame, plan.seed)
    expected = literal_frame(E.tolist(), z.tolist(), slots.tolist(), plan)
    got = get_backend("numpy").separable(plan, E, z, slots)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
