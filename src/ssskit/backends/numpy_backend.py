"""The numpy backend: float64, vectorised over pixels, one array operation per tap row and texel.

It is the oracle of the parity tests, written to be read next to :mod:`ssskit.backends.plan`:
every tap sample is a 2D bilinear fetch of its four texels (for an unjittered tap along the x axis
the two texels of the next row have weight 0), each texel with its own depth factor and slot test.
"""

from __future__ import annotations

import numpy as np

from ..sampling.hashes import jitter_angles
from .base import Backend, check_frame
from .plan import SeparablePlan, TermTable


def depth_factor(dz: np.ndarray, mode: str, param: np.ndarray) -> np.ndarray:
    """f(d_z): ``gaussian`` exp(-d_z^2 p) (separable-SSS supplement E, p = 1 / (2 tau_max)),
    ``follow`` max(0, 1 - |d_z| p) (p = 1 / width), ``none`` 1."""
    with np.errstate(invalid="ignore", over="ignore"):
        if mode == "gaussian":
            return np.exp(-dz * dz * param)
        if mode == "follow":
            return np.maximum(0.0, 1.0 - np.abs(dz) * param)
        return np.ones_like(dz)


def one_pass(src: np.ndarray, z_mm: np.ndarray, slots: np.ndarray, f_axis: float, horizontal: bool,
             term: TermTable, plan: SeparablePlan, angles: np.ndarray | None) -> np.ndarray:
    """One 1D pass of one term (plan module docstring); float64 (H, W, 3)."""
    h, w = slots.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    inside = slots > 0
    with np.errstate(divide="ignore"):
        s = np.where(inside, f_axis / np.where(inside, z_mm, 1.0), 0.0)  # pixels per mm
    param = plan.depth_param[slots]
    out = src * term.centre[slots]
    ax, ay = (1.0, 0.0) if horizontal else (0.0, 1.0)  # the pass axis
    ux, uy = ax, ay
    if angles is not None:
        cth, sth = np.cos(angles), np.sin(angles)
        # rotated axes (paper section 6): (cos, sin) horizontally, (-sin, cos) vertically
        ux, uy = (cth, sth) if horizontal else (-sth, cth)
    for k in range(term.max_rows):
        active = inside & (k < term.n_rows[slots])
        if not active.any():
            continue
        reach = term.offsets_mm[slots, k] * s
        jit = k < term.n_jit[slots]
        for side, weights in ((1.0, term.w_plus[slots, k]), (-1.0, term.w_minus[slots, k])):
            d = side * reach
            dx, dy = d * np.where(jit, ux, ax), d * np.where(jit, uy, ay)
            px, py = xx + dx, yy + dy
            i0, j0 = np.floor(px), np.floor(py)
            tx, ty = px - i0, py - j0
            i0, j0 = i0.astype(np.int64), j0.astype(np.int64)
            for di, dj in ((0, 0), (1, 0), (0, 1), (1, 1)):
                b = (tx if di else 1.0 - tx) * (ty if dj else 1.0 - ty)
                ii, jj = i0 + di, j0 + dj
                ic, jc = np.clip(ii, 0, w - 1), np.clip(jj, 0, h - 1)
                valid = active & (b > 0) & (ii == ic) & (jj == jc) & (slots[jc, ic] == slots)
                with np.errstate(invalid="ignore"):
                    f = np.where(valid, depth_factor(z_mm[jc, ic] - z_mm, plan.depth_mode, param), 0.0)
                out += (b * f)[..., None] * weights * (src[jc, ic] - src)
    out[~inside] = src[~inside]
    return out


class NumpyBackend(Backend):
    name = "numpy"
    description = "numpy, float64: the reference every other backend is tested against (slow)"
    dtype = np.float64

    def availability(self) -> tuple[bool, str]:
        return True, "float64 reference (the oracle)"

    def separable(self, plan, diffuse, depth_mm, slots):
        check_frame(diffuse, depth_mm, slots, plan)
        src = np.asarray(diffuse, dtype=np.float64)
        z = np.asarray(depth_mm, dtype=np.float64)
        slots = np.asarray(slots, dtype=np.int64)
        h, w = slots.shape
        angles = jitter_angles(h, w, plan.frame, plan.seed) if plan.jittered else None
        out = np.zeros_like(src)
        for term in plan.terms:
            tmp = one_pass(src, z, slots, plan.fx, True, term, plan, angles)
            out += term.sign[slots] * one_pass(tmp, z, slots, plan.fy, False, term, plan, angles)
        inside = (slots > 0)[..., None]
        return np.where(inside, out, src)
