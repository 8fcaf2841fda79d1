"""The screen-space separable SSS pass (separable-SSS paper section 6, supplement E).

For every pixel p inside the SSS mask, and every separable term r of the kernel, a horizontal then a
vertical 1D pass over the diffuse layer E:

    out(p) = W_c E(p) + sum_k w_kc sum_j b_j f(z_j - z_p) (E(j) - E(p))          (per channel c)

where the taps k sit at o_k * s(p) pixels from p along the pass axis, s(p) = f_axis / z_p the
pixels per mm at the pixel's linear depth z_p (mm; f_axis = fx or fy, so non-square pixels get
their own horizontal and vertical scale), j runs over the bilinear corners of the sample position
with weights b_j, and W_c = sum_k w_kc. Samples outside the image or outside the pixel's profile
region take the centre value (f = 0), so nothing bleeds across the mask, a constant signal is
unchanged and, for a fronto-parallel surface, energy inside the mask is conserved exactly (the
gather is symmetric).

Depth factor f (``depth_mode``):

* ``gaussian`` f = exp(-d_z^2 / (2 tau_max)), tau_max = max(sigma_near, sigma_far)^2: the
  two-Gaussian model's depth correction, supplement E (equation after S.9);
* ``follow``   f = max(0, 1 - |d_z| / width): a follow-surface depth test for tabulated kernels,
  rejecting samples more than one kernel width (the axis standard deviation, mm) off the surface;
* ``none``     f = 1 inside the region (depth-unaware).

Jitter (paper section 6): taps closer to the centre than ``jitter`` x the kernel size (the taps'
full span, see :meth:`SeparableTaps.jitter_count`) are taken
along axes rotated by a per-pixel random angle theta(x, y, frame, seed) (a counter-based hash, so
the same seed gives the same image on any thread count), with 2D bilinear fetches.

Two backends compute the same thing: ``numpy`` (float64, the reference) and ``numba`` (float32
images, parallel over rows).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import SsskitError
from ..sampling.taps import SeparableTaps
from .gbuffer import GBuffer, GBufferError

DEPTH_MODES = ("gaussian", "follow", "none")
BACKENDS = ("numba", "numpy")
_MODE_CODE = {"gaussian": 0, "follow": 1, "none": 2}
_MASK32 = 0xFFFFFFFF


class PassError(SsskitError):
    """Bad settings for the screen-space pass."""


# ---- per-pixel rotation angle ------------------------------------------------------------------

def _mix32_np(h: np.ndarray) -> np.ndarray:
    """lowbias32 integer hash (C. Wellons), on uint64 arrays holding 32-bit values."""
    h = h ^ (h >> np.uint64(16))
    h = (h * np.uint64(0x7FEB352D)) & np.uint64(_MASK32)
    h = h ^ (h >> np.uint64(15))
    h = (h * np.uint64(0x846CA68B)) & np.uint64(_MASK32)
    return h ^ (h >> np.uint64(16))


def jitter_angles(height: int, width: int, frame: int = 0, seed: int = 0) -> np.ndarray:
    """theta(x, y, frame, seed) in [0, 2 pi), shape (H, W): hash(x ^ hash(y ^ hash(frame ^ hash(seed))))."""
    hy = _mix32_np(_frame_base(frame, seed) ^ np.arange(height, dtype=np.uint64))
    h = _mix32_np(hy[:, None] ^ np.arange(width, dtype=np.uint64)[None, :])
    return h.astype(np.float64) * (2.0 * math.pi / 4294967296.0)


# ---- settings ----------------------------------------------------------------------------------

def default_depth_mode(taps: SeparableTaps) -> str:
    """``gaussian`` for the two-Gaussian model (supplement E), ``follow`` for tabulated kernels."""
    return "gaussian" if taps.tau_max_mm2 is not None else "follow"


def depth_parameter(taps: SeparableTaps, mode: str) -> float:
    """1 / (2 tau_max) for ``gaussian``, 1 / width for ``follow``, 0 for ``none``."""
    if mode not in DEPTH_MODES:
        raise PassError(f"unknown depth mode {mode!r}; choose from {', '.join(DEPTH_MODES)}")
    if mode == "gaussian":
        tau = taps.tau_max_mm2 if taps.tau_max_mm2 is not None else taps.width_mm**2
        return 1.0 / (2.0 * tau)
    if mode == "follow":
        return 1.0 / taps.width_mm
    return 0.0


def _check_jitter(jitter: float) -> float:
    if not (isinstance(jitter, (int, float, np.floating)) and 0.0 <= jitter <= 1.0):
        raise PassError(f"jitter must be a fraction of the kernel size in [0, 1], got {jitter!r}")
    return float(jitter)


# ---- numpy reference -----------------------------------------------------------------------------

def _factor_np(dz: np.ndarray, mode: int, param: float) -> np.ndarray:
    with np.errstate(invalid="ignore", over="ignore"):
        if mode == 0:
            f = np.exp(-dz * dz * param)
        elif mode == 1:
            f = np.maximum(0.0, 1.0 - np.abs(dz) * param)
        else:
            f = np.ones_like(dz)
    return np.where(np.isfinite(dz), f, 0.0)


def pass_numpy(src, zk, f_axis, horizontal, offsets, weights, n_jit, mode, param, angles=None) -> np.ndarray:
    """One 1D pass, vectorised over pixels (module docstring); float64 (H, W, 3).

    A sample at a fractional position is the bilinear blend of its texels (2 along the pass axis,
    4 for a jittered tap); each texel carries its own depth factor, and texels off the image or off
    the region get factor 0 (their share stays with the centre pixel). Per-texel rejection keeps the
    gather symmetric, so energy in the region is conserved exactly on a fronto-parallel surface.
    """
    src = np.asarray(src, dtype=np.float64)
    zk = np.asarray(zk, dtype=np.float64)
    h, w = zk.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    inside = np.isfinite(zk)
    with np.errstate(divide="ignore"):
        s = np.where(inside, f_axis / zk, 0.0)
    out = src * np.asarray(weights).sum(axis=0)
    if n_jit:
        cth, sth = np.cos(angles), np.sin(angles)
    for k in range(len(offsets)):
        if offsets[k] == 0.0:
            continue
        o = offsets[k] * s
        jittered = k < n_jit
        if jittered:
            dx, dy = (o * cth, o * sth) if horizontal else (-o * sth, o * cth)
        else:
            dx, dy = (o, np.zeros_like(o)) if horizontal else (np.zeros_like(o), o)
        px, py = xx + dx, yy + dy
        i0, j0 = np.floor(px), np.floor(py)
        tx, ty = px - i0, py - j0
        i0, j0 = i0.astype(np.int64), j0.astype(np.int64)
        if jittered:
            texels = [(0, 0), (1, 0), (0, 1), (1, 1)]
        else:
            texels = [(0, 0), (1, 0)] if horizontal else [(0, 0), (0, 1)]
        for di, dj in texels:
            bx = tx if di else (1.0 - tx if (jittered or horizontal) else 1.0)
            by = ty if dj else (1.0 - ty if (jittered or not horizontal) else 1.0)
            ii, jj = i0 + di, j0 + dj
            valid = inside & (ii >= 0) & (ii < w) & (jj >= 0) & (jj < h)
            ic, jc = np.clip(ii, 0, w - 1), np.clip(jj, 0, h - 1)
            with np.errstate(invalid="ignore"):
                f = np.where(valid, _factor_np(zk[jc, ic] - zk, mode, param), 0.0)
            out += (bx * by * f)[..., None] * weights[k] * (src[jc, ic] - src)
    out[~inside] = src[~inside]
    return out


def _frame_base(frame: int, seed: int) -> np.uint64:
    base = _mix32_np(np.uint64((int(seed) ^ 0x9E3779B9) & _MASK32))
    return np.uint64(_mix32_np(base ^ np.uint64(int(frame) & _MASK32)))


# ---- public entry points ---------------------------------------------------------------------------

def filter_arrays(diffuse: np.ndarray, depth_mm: np.ndarray, fx: float, fy: float, taps: SeparableTaps, *,
                  jitter: float = 0.1, frame: int = 0, seed: int = 0, depth_mode: str | None = None,
                  backend: str = "numba", scratch: dict | None = None) -> np.ndarray:
    """The separable SSS of ``diffuse`` (H, W, 3) for one profile region.

    ``depth_mm`` (H, W): linear depth in mm where the region has SSS and +inf elsewhere (stencil);
    ``fx``/``fy``: focal lengths in pixels. Returns (H, W, 3): float32 (numba) or float64 (numpy);
    pixels outside the region are copied. 2R passes for a rank-R kernel, horizontal then vertical.
    ``scratch``: a dict in which buffers are kept and reused across frames (pass the same one).
    """
    if not isinstance(taps, SeparableTaps):
        raise PassError(f"the pass needs SeparableTaps (ssskit.sampling.make_taps), got {type(taps).__name__}")
    if backend not in BACKENDS:
        raise PassError(f"unknown backend {backend!r}; choose from {', '.join(BACKENDS)}")
    jitter = _check_jitter(jitter)
    if np.ndim(depth_mm) != 2 or np.shape(diffuse) != tuple(np.shape(depth_mm)) + (3,):
        raise PassError(f"diffuse must be (H, W, 3) and depth (H, W) of the same size, got {np.shape(diffuse)} "
                        f"and {np.shape(depth_mm)}")
    mode = default_depth_mode(taps) if depth_mode is None else depth_mode
    param = depth_parameter(taps, mode)
    n_jit = taps.jitter_count(jitter)
    h, w = depth_mm.shape
    if backend == "numpy":
        angles = jitter_angles(h, w, frame, seed) if n_jit else None
        src = np.asarray(diffuse, dtype=np.float64)
        out = np.zeros_like(src)
        for r in range(taps.rank):
            tmp = pass_numpy(src, depth_mm, fx, True, taps.offsets_mm[r], taps.weights[r], n_jit,
                             _MODE_CODE[mode], param, angles)
            out += taps.signs[r] * pass_numpy(tmp, depth_mm, fy, False, taps.offsets_mm[r], taps.weights[r],
                                              n_jit, _MODE_CODE[mode], param, angles)
        return np.where(np.isfinite(depth_mm)[..., None], out, src) if taps.rank > 1 else out
    from ._fastpass import kernels, planar_buffer, tap_table, vector_kernels

    src = np.ascontiguousarray(diffuse, dtype=np.float32)
    zk = np.ascontiguousarray(depth_mm, dtype=np.float32)
    scratch = {} if scratch is None else scratch
    out = scratch.get("out")
    if out is None or out.shape != src.shape:
        out = scratch["out"] = np.empty_like(src)
    base = _frame_base(frame, seed)
    p = np.float32(param)
    acc = None
    for r in range(taps.rank):
        offs, kinds, wts, n_j, n_p = tap_table(taps.offsets_mm[r], taps.weights[r], n_jit)
        wsum = taps.weights[r].sum(axis=0).astype(np.float32)
        if n_j == 0 and n_p == offs.size:  # symmetric pairs, no jitter: the vectorised kernels
            vh, vv = vector_kernels(_MODE_CODE[mode])
            pad = _pad(offs, fx, fy, zk)
            if scratch.get("planar_key") != (h, w, pad):
                scratch["planar"], scratch["planar_key"] = planar_buffer(h, w, pad), (h, w, pad)
            vh(src, zk, scratch["planar"], pad, float(fx), offs, wts, wsum, p)
            vv(scratch["planar"], out, pad, float(fy), offs, wts, wsum, p)
        else:  # the scalar kernel on RGBZ arrays
            spass = kernels(_MODE_CODE[mode])
            src4 = np.concatenate([src, zk[..., None]], axis=-1)
            tmp4 = np.empty_like(src4)
            spass(src4, tmp4, float(fx), True, offs, kinds, wts, wsum, n_j, n_p, p, base)
            spass(tmp4, src4, float(fy), False, offs, kinds, wts, wsum, n_j, n_p, p, base)
            out[...] = src4[..., :3]
        if taps.rank == 1 and np.all(taps.signs == 1):
            return out
        acc = np.zeros_like(src) if acc is None else acc
        acc += taps.signs[r].astype(np.float32) * out
    return np.where(np.isfinite(zk)[..., None], acc, src)


def _pad(offs: np.ndarray, fx: float, fy: float, zk: np.ndarray) -> int:
    """Pad (pixels) of the vectorised kernels' buffers: the largest footprint, capped by the image."""
    finite = zk[np.isfinite(zk)]
    h, w = zk.shape
    if finite.size == 0 or offs.size == 0:
        return 3
    reach = float(np.max(np.abs(offs))) * max(fx, fy) / float(finite.min())
    return int(min(np.ceil(reach) + 3, max(h, w) + 3))


def region_depth_mm(gbuffer: GBuffer, profile_id: int) -> np.ndarray:
    """Linear depth in mm on the pixels of ``profile_id``, +inf elsewhere (the pass's stencil)."""
    z = gbuffer.depth.astype(np.float64) / gbuffer.camera.world_units_per_mm
    return np.where(gbuffer.profile_id == profile_id, z, np.inf)


def separable_sss(gbuffer: GBuffer, taps, *, jitter: float = 0.1, frame: int = 0, seed: int = 0,
                  depth_mode: str | None = None, backend: str = "numba") -> np.ndarray:
    """Blurred diffuse layer (H, W, 3) float32: every profile region filtered with its taps.

    ``taps``: one :class:`SeparableTaps` for every region, or a mapping profile id -> taps.
    Pixels without SSS keep their diffuse value.
    """
    if not isinstance(gbuffer, GBuffer):
        raise GBufferError(f"expected a GBuffer, got {type(gbuffer).__name__}")
    out = gbuffer.diffuse.copy()
    cam = gbuffer.camera
    for pid in np.unique(gbuffer.profile_id[gbuffer.profile_id > 0]):
        t = taps if isinstance(taps, SeparableTaps) else taps.get(int(pid)) if hasattr(taps, "get") else None
        if t is None:
            raise PassError(f"no taps given for profile id {int(pid)}")
        res = filter_arrays(gbuffer.diffuse, region_depth_mm(gbuffer, int(pid)), cam.fx, cam.fy, t, jitter=jitter,
                            frame=frame, seed=seed, depth_mode=depth_mode, backend=backend)
        sel = gbuffer.profile_id == pid
        out[sel] = res[sel]
    return out
