"""The numba backend: float32 on the CPU, vectorised, ranges of rows on a thread pool (kernels in
:mod:`ssskit.backends._numba_separable`, compiled on first use and cached on disk).

The backend owns its scratch: planar padded copies of the frame (colour, depth, slot) and of the
horizontal pass's output, reused while the image size and pad stay the same. Results are always
new arrays.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..compute.workers import submit_all
from ..errors import PassError
from ..sampling.hashes import frame_base
from .base import Backend, run_tiny_frames
from .plan import SEPARABLE_FRAME, SeparablePlan, TermTable, check_arrays

if TYPE_CHECKING:
    from concurrent.futures import ThreadPoolExecutor

    from .adaptive_plan import AdaptivePlan, GuideFrame
    from .burley_plan import BurleyPlan, MipPyramid, Prefiltered
    from .spread_plan import SpreadPlan
    from .transmission_plan import TransmissionPlan


#: the largest planar frame buffer the backend allocates (extreme close-ups need a wide pad)
MAX_BUFFER_BYTES = 2 << 30


@dataclass(frozen=True, eq=False)
class NumbaMips:
    """The Burley pass's prefiltered pyramid (plan step 5b) in the numba kernel's layout: levels 1..MAX_MIP
    of every slot s >= 1 as float32 planes (S - 1, hh[L], ww[L], 4) flattened into ``pyr`` at ``off[L]``
    (level 0 is read from the frame itself, so its entry is empty)."""

    pyr: NDArray[np.float32]
    off: NDArray[np.int64]
    hh: NDArray[np.int64]
    ww: NDArray[np.int64]

    @classmethod
    def from_levels(cls, levels: MipPyramid) -> "NumbaMips":
        """From the oracle's float64 list (:func:`~ssskit.backends.burley_plan.mip_pyramid`, slot 0 first)."""
        hh = np.array([lv.shape[1] for lv in levels], np.int64)
        ww = np.array([lv.shape[2] for lv in levels], np.int64)
        parts = [np.zeros(0, np.float32)] + [np.ascontiguousarray(lv[1:], np.float32).ravel() for lv in levels[1:]]
        off = np.concatenate([[0], np.cumsum([p.size for p in parts])[:-1]]).astype(np.int64)
        return cls(np.concatenate(parts), off, hh, ww)


class NumbaBackend(Backend):
    name = "numba"
    description = "numba on the CPU, float32, parallel over rows and vectorised (the default)"
    dtype = np.float32
    passes = frozenset({"separable", "burley", "adaptive", "transmission", "spread"})
    compiles_on_first_use = True
    separable_checks_values = True  # in the one packing pass over the frame (_pack)

    def __init__(self) -> None:
        self._key: tuple[int, int, int] | None = None
        self._buf: NDArray[np.float32] | None = None
        self._pool: ThreadPoolExecutor | None = None
        self._lock = threading.Lock()
        self._pads: dict[tuple[int, int], int] = {}  # the pad of the last frame of each size

    def availability(self) -> tuple[bool, str]:
        try:
            import numba
        except ImportError as exc:  # pragma: no cover - numba is a dependency
            return False, f"numba cannot be imported ({exc})"
        return True, f"numba {numba.__version__}, {numba.get_num_threads()} threads"

    def _warm_up(self, names: list[str]) -> None:
        """Compile the kernels of ``names`` (:data:`~ssskit.backends.base.WARM_UP`), or load them from numba's disk
        cache: each pass runs once on a tiny synthetic frame through this backend's own entry points
        (:func:`~ssskit.backends.base.run_tiny_frames`), so numba compiles the very specialisations a real
        frame of any size calls, and the first real frame compiles nothing. On a fresh machine this is
        most of a first frame's time (seconds per kernel, one thread), so a caller can overlap it with other
        work: a thread while Mitsuba renders the G-buffer, or a process beside another demo section."""
        run_tiny_frames(self, names)

    def _rows(self, h: int, fn: Callable[[int, int], object]) -> None:
        """fn(y0, y1) over row ranges covering [0, h), on numba.get_num_threads() threads (the kernels
        release the GIL; rows are independent, so any thread count gives the same result)."""
        import numba

        threads = numba.get_num_threads()
        if threads == 1 or h < 64:
            fn(0, h)
            return
        if self._pool is None or self._pool._max_workers < threads:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="ssskit-numba")
        bounds = np.linspace(0, h, 4 * threads + 1).astype(int)
        for f in submit_all(self._pool, fn, [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]):
            f.result()

    def _buffer(self, h: int, w: int, pad: int) -> tuple[NDArray[np.float32], int, int]:
        from ._numba_separable import LANES, PLANES, Z_PLANE

        wps = w + 2 * pad + LANES
        plane = (h + 2 * pad) * wps
        key = (h, w, pad)
        if self._key != key or self._buf is None:  # (a key is only set with its buffer)
            self._buf = np.zeros(PLANES * plane, np.float32)
            self._buf[Z_PLANE * plane:(Z_PLANE + 1) * plane] = np.inf
            self._key = key
        return self._buf, wps, plane

    def _transmission(self, plan: TransmissionPlan, slots: np.ndarray, light_uvz: np.ndarray, shadow_mm: np.ndarray,
                      n_dot_l: np.ndarray, light_rgb: np.ndarray) -> NDArray[np.float32]:
        """The transmittance pass (:mod:`ssskit.backends._numba_transmission`), float32, rows on the pool."""
        from ._numba_transmission import LANES, transmission_pixels

        f32 = np.float32
        h, w = np.shape(slots)
        n = h * w
        flat = [np.ascontiguousarray(slots, dtype=np.int32).reshape(-1),
                np.ascontiguousarray(light_uvz, dtype=f32).reshape(-1),
                np.ascontiguousarray(n_dot_l, dtype=f32).reshape(-1),
                np.ascontiguousarray(light_rgb, dtype=f32).reshape(-1)]
        m = max(n, LANES)  # the kernel works on whole blocks of LANES pixels: a smaller frame is padded (slot 0)
        if m > n:
            flat = [np.concatenate([v, np.zeros((m - n) * k, v.dtype)]) for v, k in zip(flat, (1, 3, 1, 3))]
        sl, uvz, ndl, light = flat
        shadow = np.ascontiguousarray(shadow_mm, dtype=f32)
        if shadow.shape[1] < 2:  # the kernel reads texels in pairs: a column of +inf (no surface) beside it
            shadow = np.concatenate([shadow, np.full_like(shadow, np.inf)], axis=1)
        a, b, c = (np.ascontiguousarray(v, dtype=f32) for v in (plan.a, plan.b, plan.c))
        scale, wrap, normal = plan.scale.astype(f32), plan.wrap.astype(f32), plan.normal.astype(f32)
        out = np.empty(3 * m, f32)
        bias = f32(plan.bias_mm)
        kind = plan.lut_slot.astype(np.int32)
        lut = np.ascontiguousarray(plan.lut, dtype=f32).reshape(-1)
        odp, odo = plan.od_per_mm.astype(f32), plan.od_offset.astype(f32)
        blocks = m // LANES  # ranges of whole blocks; the last range also takes the m % LANES pixels left
        self._rows(blocks, lambda i0, i1: transmission_pixels(sl, uvz, shadow, ndl, light, a, b, c, scale, wrap, normal,
                                                              bias, kind, lut, odp, odo, out, i0 * LANES,
                                                              m if i1 == blocks else i1 * LANES))
        return out[: 3 * n].reshape(h, w, 3)

    def _transmission_spread(self, plan: SpreadPlan, exitance: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
                             light_uvz: np.ndarray, shadow_mm: np.ndarray) -> NDArray[np.float32]:
        """The transmitted light's lateral spread (:mod:`ssskit.backends._numba_spread`), float32, rows on the pool:
        per row the widths and planes and the horizontal pass (``spread_h``), then the vertical pass."""
        from ._numba_spread import LANES, PLANES, plane_stride, spread_h, spread_v

        f32 = np.float32
        h, w = np.shape(slots)
        pad = max(0, LANES - w)  # the kernels work on whole blocks of LANES pixels: a narrower frame is padded
        sl = np.ascontiguousarray(slots, dtype=np.int32)
        uvz = np.ascontiguousarray(light_uvz, dtype=f32)
        depth = np.ascontiguousarray(depth_mm, dtype=f32)
        src = np.ascontiguousarray(exitance, dtype=f32)
        if pad:  # slot 0 beside the frame: off the image for every tap
            sl = np.pad(sl, [(0, 0), (0, pad)])
            depth = np.pad(depth, [(0, 0), (0, pad)])
            uvz = np.pad(uvz, [(0, 0), (0, pad), (0, 0)])
            src = np.pad(src, [(0, 0), (0, pad), (0, 0)])
        wp = w + pad
        shadow = np.ascontiguousarray(shadow_mm, dtype=f32)
        if shadow.shape[1] < 2:  # the map is read in pairs of texels: a column of +inf (no surface) beside it
            shadow = np.concatenate([shadow, np.full_like(shadow, np.inf)], axis=1)
        nk = plan.knots_mm.shape[1]
        knots = np.append(plan.knots_mm.astype(f32).reshape(-1), f32(0))  # one element past the last slot's
        table = np.append(plan.sigma_mm.astype(f32).reshape(-1), f32(0))
        n_knots = plan.n_knots.astype(np.int32)
        pl = np.empty(PLANES * plane_stride(h, wp), f32)
        stats = np.empty(4 * h, f32)
        hs, ws = shadow.shape
        flat = [a.reshape(-1) for a in (sl, uvz, shadow, src, depth)]
        min_px, taps = f32(plan.min_px), int(plan.max_taps)
        self._rows(h, lambda y0, y1: spread_h(flat[0], flat[1], flat[2], hs, ws, flat[3], flat[4], knots, table,
                                              n_knots, nk, f32(plan.bias_mm), pl, stats, wp, float(plan.fx), min_px,
                                              taps, LANES, y0, y1))
        gmf = stats.reshape(h, 4)[:, :3].min(axis=0).astype(f32)
        out = np.empty(3 * h * wp, f32)
        self._rows(h, lambda y0, y1: spread_v(pl, stats, gmf, wp, float(plan.fy), min_px, taps, out, LANES,
                                              y0, y1))
        res = out.reshape(h, wp, 3)
        return res[:, :w].copy() if pad else res

    def _separable(self, plan: SeparablePlan, diffuse: np.ndarray, depth_mm: np.ndarray,
                   slots: np.ndarray) -> NDArray[np.float32]:
        with self._lock:  # one frame buffer per backend: one frame at a time
            return self._separable_locked(plan, diffuse, depth_mm, slots)

    def _pack(self, src: np.ndarray, depth: np.ndarray, slots: np.ndarray, pad: int, write: bool,
              slot_plane: bool) -> tuple[NDArray[np.float32], int, int, NDArray[np.float64]]:
        """Pack the frame into the buffer of pad ``pad`` (if ``write``; its slot plane if ``slot_plane``), checking
        it on the way: per-row stats."""
        from ._numba_separable import pack_rows

        h, w = slots.shape
        buf, wps, plane = self._buffer(h, w, pad) if write else (np.zeros(1, np.float32), 1, 1)
        stats = np.empty((h, 5))
        self._rows(h, lambda y0, y1: pack_rows(src, depth, slots, buf, pad, wps, plane, y0, y1, write, slot_plane,
                                                   stats))
        return buf, wps, plane, stats

    def _separable_locked(self, plan: SeparablePlan, diffuse: np.ndarray, depth_mm: np.ndarray,
                          slots: np.ndarray) -> NDArray[np.float32]:
        from ._numba_separable import LANES, PASSES, PLANES, TMP_PLANE, block_slot_rows

        slots = np.ascontiguousarray(slots, dtype=np.int32)  # (Backend.separable checked its shape and type)
        h, w = slots.shape
        depth = np.ascontiguousarray(depth_mm, dtype=np.float32)
        src = np.ascontiguousarray(diffuse, dtype=np.float32)
        # one read of the frame packs and checks it with the last frame's pad (a frame of another size: a
        # read-only check first); a nearer surface than the pad allows is packed again with a larger one
        pad = self._pads.get((h, w))
        multi = plan.slots > 2  # several profiles: the passes test slots (one: a texel's depth tells)
        buf, wps, plane, stats = self._pack(src, depth, slots, pad if pad is not None else 0, pad is not None, multi)
        if stats[:, 4].any() or stats[:, 1].any() or (slots.size and (stats[:, 2].min() < 0 or
                                                                      stats[:, 3].max() >= plan.slots)):
            # the one pass over the frame found a bad value or slot: name it
            check_arrays(SEPARABLE_FRAME, dict(diffuse=src, depth_mm=depth, slots=slots), plan.slots)
        z_min = float(stats[:, 0].min(initial=np.inf))
        if not np.isfinite(z_min):  # no pixel with SSS
            return np.array(src, dtype=np.float32)
        need = _pad(plan, z_min, h, w)
        size = PLANES * (h + 2 * need) * (w + 2 * need + LANES) * 4
        if size > MAX_BUFFER_BYTES:
            raise PassError(f"the kernel reaches {need - 3} px at the nearest depth ({z_min:.4g} mm): the numba "
                            f"backend would need a {size / 2**30:.1f} GiB frame buffer (limit "
                            f"{MAX_BUFFER_BYTES / 2**30:.0f} GiB); use --backend numpy or a smaller footprint")
        if pad is None or need > pad or need < pad // 2:  # (a pad larger than needed changes nothing)
            pad = need
            buf, wps, plane, _ = self._pack(src, depth, slots, pad, True, multi)
        self._pads[(h, w)] = pad
        run = PASSES[plan.depth_mode]
        base = np.uint64(frame_base(plan.frame, plan.seed))
        cap = np.float32(pad - 3)
        param = plan.depth_param.astype(np.float32)
        out = np.empty((h, w, 3), np.float32)
        flat = out.reshape(-1)
        tmp = TMP_PLANE * plane
        acc: NDArray[np.float32] | None = None
        bmap = np.zeros((h, -(-w // LANES)) if plan.slots > 2 else (h, 1), np.int32)
        if plan.slots > 2:
            self._rows(h, lambda y0, y1: block_slot_rows(slots, bmap, y0, y1))
        for term in plan.terms:
            t = _tables(term)
            self._rows(h, lambda y0, y1: run(buf, buf, 0, tmp + pad * wps + pad, plane, wps, 1, y0, y1, w, pad, wps,
                                             plane, 0, plan.fx, *t, param, base, cap, bmap, LANES))
            self._rows(h, lambda y0, y1: run(buf, flat, tmp, 0, 1, 3 * w, 3, y0, y1, w, pad, wps, plane, 1, plan.fy,
                                             *t, param, base, cap, bmap, LANES))
            if len(plan.terms) == 1 and np.all(term.sign == 1):
                return out
            contribution = term.sign[slots].astype(np.float32) * out
            acc = contribution if acc is None else acc + contribution
        assert acc is not None  # a plan has at least one term
        return np.where((slots > 0)[..., None], acc, src).astype(np.float32)


    def _burley(self, plan: BurleyPlan, diffuse: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
                spp: NDArray[np.int64] | int, pyramid: Prefiltered | None) -> NDArray[np.float32]:
        """The Burley pass (kernel in :mod:`ssskit.backends._numba_burley`), rows on the thread pool; ``pyramid``:
        :meth:`burley_prefilter`'s result or the oracle's list (None: built here when the plan has mips)."""
        from ._numba_burley import burley_rows
        from .burley_plan import GOLDEN32, KEY2, MAX_MIP, R2_A1, R2_A2, SAMPLERS, SEQUENCES

        h, w = np.shape(slots)
        src = np.ascontiguousarray(diffuse, dtype=np.float32)
        z = np.ascontiguousarray(depth_mm, dtype=np.float32)
        # BURLEY_FRAME's check gives an int or an int64 image
        counts = np.zeros((1, 1), np.int64) if isinstance(spp, int) else np.ascontiguousarray(spp, np.int64)
        out = np.empty((h, w, 3), np.float32)
        u64 = np.uint64
        args = (src, z, z.view(np.uint32), np.ascontiguousarray(slots, np.int32), counts,
                spp if isinstance(spp, int) else 0, not isinstance(spp, int), out)
        rest = (np.ascontiguousarray(plan.d_mm, np.float64), np.ascontiguousarray(plan.channel, np.int64),
                np.ascontiguousarray(plan.r997_mm, np.float64), SAMPLERS.index(plan.sampler),
                SEQUENCES.index(plan.sequence), plan.c, plan.bleed, plan.fx, plan.fy,
                u64(frame_base(0 if plan.stable else plan.frame, plan.seed)), plan.stable, u64(KEY2), u64(GOLDEN32),
                u64(R2_A1), u64(R2_A2), plan.mips, plan.mip_scale, MAX_MIP)
        if not plan.mips:
            mips = NumbaMips(np.zeros(1, np.float32), *(np.zeros(MAX_MIP + 1, np.int64) for _ in range(3)))
        elif isinstance(pyramid, NumbaMips):
            mips = pyramid
        elif pyramid is not None:  # the oracle's float64 list (burley_plan.mip_pyramid)
            mips = NumbaMips.from_levels(pyramid)
        else:
            mips = self.burley_prefilter(plan, src, slots)
        pyr = (mips.pyr, mips.off, mips.hh, mips.ww, np.ascontiguousarray(plan.dmfp_max_mm, np.float64))
        self._rows(h, lambda y0, y1: burley_rows(*args, y0, y1, *rest, *pyr))
        return out

    def burley_prefilter(self, plan: BurleyPlan, diffuse: np.ndarray, slots: np.ndarray) -> NumbaMips:
        """Step 5b's pyramid (Xie 2020 Eqs. 22-23; :func:`~ssskit.backends.burley_plan.mip_pyramid`) in the
        kernel's layout: levels 1..MAX_MIP in float32 (level 0 is the frame itself), level 1's rows on the pool."""
        from ._numba_burley import mip_coarse, mip_level1
        from .burley_plan import MAX_MIP

        slots = np.ascontiguousarray(slots, np.int32)
        src = np.ascontiguousarray(diffuse, np.float32)
        h, w = slots.shape
        hh = np.array([-(-h // (1 << k)) for k in range(MAX_MIP + 1)], np.int64)
        ww = np.array([-(-w // (1 << k)) for k in range(MAX_MIP + 1)], np.int64)
        planes = max(plan.slots - 1, 1)
        sizes = np.where(np.arange(MAX_MIP + 1) > 0, planes * hh * ww * 4, 0)
        off = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        pyr = np.zeros(int(sizes.sum()), np.float32)
        self._rows(int(hh[1]), lambda y0, y1: mip_level1(src, slots, pyr, int(off[1]), int(hh[1]), int(ww[1]), y0, y1))
        mip_coarse(pyr, off, hh, ww, planes, MAX_MIP)
        return NumbaMips(pyr, off, hh, ww)

    def _adaptive_counts(self, plan: AdaptivePlan, frame: GuideFrame) -> NDArray[np.int64]:
        """The *estimate* of :mod:`ssskit.backends.adaptive_plan` (kernel in ``_numba_adaptive``)."""
        return self._guide(plan, frame)[1]

    def _adaptive_update(self, plan: AdaptivePlan, frame: GuideFrame) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        """The *update* of :mod:`ssskit.backends.adaptive_plan` (kernel in ``_numba_adaptive``)."""
        new, n = self._guide(plan, frame)
        assert new is not None  # an update returns the new history
        return new, n

    def _guide(self, plan: AdaptivePlan, frame: GuideFrame) -> tuple[NDArray[np.float32] | None, NDArray[np.int64]]:
        from ._numba_adaptive import guide_rows

        h, m, mv, ok, img, n = frame
        hh, ww = m.shape
        update = img is not None
        hist = np.ascontiguousarray(h, np.float32)
        out_hist = np.zeros((hh, ww, 4) if update else (1, 1, 4), np.float32)
        out_counts = np.empty((hh, ww), np.int64)
        args = (hist, np.zeros((1, 1, 2)) if mv is None else np.ascontiguousarray(mv), mv is not None,
                np.zeros((1, 1), bool) if ok is None else np.ascontiguousarray(ok), ok is not None,
                np.ascontiguousarray(m), np.zeros((1, 1, 3), np.float32) if img is None else np.ascontiguousarray(img),
                np.zeros((1, 1), np.int64) if n is None else np.ascontiguousarray(n), update,
                np.float32(plan.alpha), float(plan.sigma0_sq), float(plan.kappa * (plan.k - 1.0)),
                plan.correction == "variance", math.sqrt(plan.sigma0_sq), int(plan.b_min), int(plan.b_max),
                plan.gamma == 1.0, np.float32(1.0 / plan.gamma), out_hist, out_counts)
        self._rows(hh, lambda y0, y1: guide_rows(*args, y0, y1))
        return (out_hist if update else None), out_counts


def _tables(term: TermTable) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.int64], NDArray[np.int64],
                                      NDArray[np.float32]]:
    f32 = np.float32
    return (np.ascontiguousarray(term.offsets_mm, f32),
            np.ascontiguousarray(np.concatenate([term.w_plus, term.w_minus], axis=-1), f32),
            np.ascontiguousarray(term.n_jit, np.int64),
            np.ascontiguousarray(term.n_rows, np.int64), np.ascontiguousarray(term.centre, f32))


def _pad(plan: SeparablePlan, z_min_mm: float, h: int, w: int) -> int:
    """Pad (pixels) of the planar buffers: the largest tap reach at the nearest depth, + 3, capped by the
    image diagonal + 3 (a tap clamped there still lands off the image)."""
    reach = plan.max_reach_mm() * max(plan.fx, plan.fy) / z_min_mm
    return int(min(math.ceil(reach) + 3, math.ceil(math.hypot(h, w)) + 3))
