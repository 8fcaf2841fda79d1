"""The separable pass's plan: what every backend executes, built once per frame from the taps.

A plan holds, for every separable term r of the kernels (rank R = the largest rank among the
profile ids) and every profile *slot* s (slot 0 = no SSS; slot s >= 1 = the s-th profile id of the
G-buffer), a table of tap **rows**. A row is a distance o >= 0 (mm) with the weight of its tap at
+o and of its tap at -o along the pass axis:

* a symmetric pair: w_plus == w_minus (the taps o and -o of an even kernel, paired exactly when the
  taps are made, never guessed later);
* a single tap at +o (w_minus = 0) or at -o (w_plus = 0), for asymmetric user taps.

Rows [0, n_jit) of a slot are the jittered ones (closer to the centre than the jitter radius;
separable-SSS paper section 6), rows [n_jit, n_rows) the plain ones. The centre tap needs no row:
the pass computes, per pixel p in slot s and channel c,

    out_c(p) = W_sc E_c(p) + sum_rows sum_(side +-) w_side,c sum_j b_j f(z_j - z_p) [slot_j = s] (E_c(j) - E_c(p))

with W_sc the term's total weight (``centre``), j the bilinear texels of the tap's position
p +- o s(p) u (u the pass axis, rotated by the pixel's jitter angle for jittered rows; s(p) = f_axis
/ z_p pixels per mm), b_j the bilinear weights and f the depth factor of the plan's mode with the
slot's parameter. Texels off the image, off the slot or off the SSS mask count 0 (their share stays
at the centre), which makes the pass conserve energy on a fronto-parallel surface. The output of
the two 1D passes of term r is multiplied by ``sign[s]`` and the terms are summed (paper Eq. 2).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import PassError
from ..quantities import LENGTH_MM, TYPE, Quantity, check_choice, check_instance, check_shape, fail

#: depth factor f(d_z) of the pass: exp(-d_z^2 p) with p = 1 / (2 tau_max) (supplement E),
#: max(0, 1 - |d_z| p) with p = 1 / width (follow-surface test), or 1 (no depth test)
DEPTH_MODES = ("gaussian", "follow", "none")


#: a pixel's linear depth in front of the camera where it has SSS (mm): positive, finite
DEPTH_MM = LENGTH_MM.within(reason="a linear depth in front of the camera, on every pixel with SSS")


#: any finite number (a colour, a motion vector)
FINITE_VALUE = Quantity("value", -math.inf, math.inf, "", "", lo_open=True, hi_open=True)
#: the profile slot of a pixel (0: no SSS); :func:`check_arrays` bounds it by the plan's slots
SLOT = Quantity("slots", 0, 2**31 - 1, "", "the plan's profile slots; 0 is no SSS", integer=True)


@dataclass(frozen=True)
class Array:
    """One array a pass (or a plan) takes, declared once, in a table name -> Array that :func:`check_arrays` reads:
    its ``name`` in messages, its ``shape`` (ints, and letters: a length bound by the first array of the table
    that has the letter, so every image shaped ``("H", "W", ...)`` has the frame's size), dtype ``kinds`` (numpy's
    letters, :func:`~ssskit.quantities.check_shape`), the ``dtype`` it is converted to (None: as given), the
    quantity of its ``values`` (None: any) with ``elements`` their name in messages and ``sss``: checked on the
    pixels with SSS only (``slots`` > 0, the only ones the pass reads), ``optional``: None passes, ``nonempty``:
    no axis of length 0, and ``scalar``: one number for every pixel is taken too, checked by that quantity."""

    shape: tuple[int | str, ...]
    name: str
    kinds: str = "iuf"
    dtype: Any = None
    values: Quantity | None = None
    elements: str = "values"
    sss: bool = False
    optional: bool = False
    nonempty: bool = False
    scalar: Quantity | None = None


def check_arrays(table: Mapping[str, Array], given: Mapping[str, Any], n_slots: int | None = None,
                 dims: tuple[int, ...] = (), values: bool = True, where: str = "") -> dict[str, Any]:
    """The arrays of ``given`` (each key of ``table`` it holds) checked by their :class:`Array` under the name
    ``{where}: {name}`` (``where`` empty: the name alone), or a PassError: first every shape and kind, in the
    table's order (``dims``: the frame's (H, W), known already), then with ``values`` the slot image ``slots``
    in [0, ``n_slots`` - 1] (:data:`SLOT`) and each array's values, first by the whole array's min and max (one
    reduction each, no temporaries: a few ms at 1080p, what valid frames pass) and only where that fails on the
    pixels with SSS alone (a boolean mask copies: ~90 ms at 1080p), naming the count and the first bad element.
    Returns the checked arrays, converted to their ``dtype`` (a scalar: its quantity's number)."""
    bound: dict[int | str, int] = dict(zip(("H", "W"), dims))
    out: dict[str, Any] = {}
    for key, spec in ((k, a) for k, a in table.items() if k in given):
        v, label = given[key], f"{where}: {spec.name}" if where else spec.name
        if (v is None and spec.optional) or (spec.scalar is not None and np.ndim(v) == 0):
            out[key] = v if v is None else spec.scalar.check(v, error=PassError)  # type: ignore[union-attr]
            continue
        if v is None:  # a required array not given (numpy would make it "shape () object")
            raise fail(PassError, TYPE, name=label, kind="an array (it is required)", actual=None)
        out[key] = a = check_shape(v, label, tuple(bound.get(n, n) for n in spec.shape), PassError, spec.kinds,
                                   spec.dtype)
        bound.update((n, m) for n, m in zip(spec.shape, a.shape) if isinstance(n, str))
        if spec.nonempty and a.size == 0:
            raise fail(PassError, TYPE, name=label, kind="a non-empty image", actual=f"shape {a.shape}")
    inside: np.ndarray | None = None
    for key, a in out.items() if values else ():
        spec, label = table[key], f"{where}: {table[key].name}" if where else table[key].name
        q = SLOT.within(hi=n_slots - 1) if key == "slots" and n_slots is not None else spec.values
        if q is None or np.ndim(a) == 0 or a.size == 0 or (q.contains(np.min(a)) and q.contains(np.max(a))):
            continue  # (min and max propagate NaN, which no range contains)
        if spec.sss:
            inside = out["slots"] > 0 if inside is None else inside
            a = a[inside]
        if q.contains(-math.inf) and q.contains(math.inf):  # only NaN lies outside [-inf, inf]
            q.refuse(math.nan, label, PassError)
        q.check_array(a, label, PassError, spec.elements)
    return out


#: the separable (and Burley) pass's frame (:mod:`ssskit.backends.base`): depth first, whose shape is the frame's;
#: every colour finite (a NaN or inf colour spreads over its neighbours), every pixel with SSS at a positive
#: finite depth
SEPARABLE_FRAME = {"depth_mm": Array(("H", "W"), "depth", values=DEPTH_MM, elements="pixels with SSS", sss=True),
                   "diffuse": Array(("H", "W", 3), "diffuse", values=FINITE_VALUE, elements="colour values"),
                   "slots": Array(("H", "W"), "slots", "iu", elements="pixels")}
#: the light's view of a frame that the transmittance pass and its spread take: the slots, ``light_uvz`` (H, W, 3)
#: and a non-empty light-space depth ``shadow_mm`` (H', W')
LIGHT_VIEW = {"slots": SEPARABLE_FRAME["slots"], "light_uvz": Array(("H", "W", 3), "light_uvz"),
              "shadow_mm": Array(("Hs", "Ws"), "shadow_mm (the light-space depth)", elements="texels", nonempty=True)}


#: a focal length of the camera in pixels (pixels per unit of the image plane at unit depth)
FOCAL_PX = Quantity("focal length", 0.0, math.inf, "px", "pixels per mm of the image plane at 1 mm depth",
                    lo_open=True, hi_open=True)
#: the profile ids a plan has parameters for: 0 is the G-buffer's no-SSS id
PROFILE_ID = Quantity("profile ids", 1, 2**31 - 1, "", "0 means no SSS", integer=True)


def check_plan_ids(by_id: Any, kind: type, fx: float | None = None, fy: float | None = None,
                   allow_empty: bool = True) -> tuple[int, ...]:
    """The sorted profile ids of a plan's mapping profile id -> ``kind`` (the rule every plan states once: a
    mapping, integer ids >= 1, values of ``kind``), with ``fx``, ``fy`` (focal lengths, :data:`FOCAL_PX`)
    checked; or a PassError."""
    for name, f in (("fx", fx), ("fy", fy)):
        if f is not None:
            FOCAL_PX.check(f, f"focal length {name}", PassError)
    if not isinstance(by_id, Mapping) or not (by_id or allow_empty):
        raise fail(PassError, TYPE, name="a plan", kind=f"a non-empty mapping profile id -> {kind.__name__}",
                   actual=repr(by_id) if not by_id else type(by_id).__name__)
    for pid, value in by_id.items():
        PROFILE_ID.check(pid, "profile ids", PassError)
        check_instance(value, kind, f"profile id {pid}", PassError)
    return tuple(sorted(int(i) for i in by_id))


def per_id(given: Any, kind: type, ids: Iterable[int], what: str) -> dict[int, Any]:
    """A pass's parameters per profile id: ``given`` (one ``kind`` for every id, or a mapping profile id ->
    ``kind``) for each of ``ids``; a PassError naming the id whose ``what`` is missing or of another kind."""
    if isinstance(given, kind):
        return {int(i): given for i in ids}
    check_instance(given, (kind, Mapping), f"the pass's {what}", PassError)
    out = {int(i): given.get(int(i)) for i in ids}
    for i, value in out.items():
        if value is None:
            raise PassError(f"no {what} given for profile id {i}")
        check_instance(value, kind, f"{what} for profile id {i}", PassError)
    return out


@dataclass(frozen=True, eq=False)
class TermTable:
    """One separable term for every slot; arrays indexed [slot, row] (slot 0 has no rows)."""

    offsets_mm: np.ndarray  # (S, K) float64, >= 0
    w_plus: np.ndarray  # (S, K, 3)
    w_minus: np.ndarray  # (S, K, 3)
    n_jit: np.ndarray  # (S,) int64: rows [0, n_jit) are jittered
    n_rows: np.ndarray  # (S,) int64
    centre: np.ndarray  # (S, 3): the term's total weight W_sc
    sign: np.ndarray  # (S, 3): +-1

    @property
    def max_rows(self) -> int:
        return int(self.offsets_mm.shape[1])


@dataclass(frozen=True, eq=False)
class SeparablePlan:
    """Everything a backend needs besides the frame's images (module docstring)."""

    ids: tuple[int, ...]  # profile id of slot 1, 2, ...
    terms: tuple[TermTable, ...]
    depth_mode: str
    depth_param: np.ndarray  # (S,) float64; slot 0 unused
    fx: float
    fy: float
    frame: int
    seed: int

    @property
    def slots(self) -> int:
        return len(self.ids) + 1

    @property
    def jittered(self) -> bool:
        return any(int(t.n_jit.max(initial=0)) > 0 for t in self.terms)

    def max_reach_mm(self) -> float:
        return max((float(t.offsets_mm.max(initial=0.0)) for t in self.terms), default=0.0)

    def slot_map(self, profile_id: np.ndarray) -> np.ndarray:
        """(H, W) int32 slots of a profile-id layer: 0 where the id has no SSS or no entry here."""
        pid = np.asarray(profile_id)
        top = max(self.ids, default=0)
        if self.ids == tuple(range(1, top + 1)) and np.issubdtype(pid.dtype, np.integer) and (
                pid.size == 0 or (int(pid.max()) <= top and (pid.dtype.kind == "u" or int(pid.min()) >= 0))):
            # ids 1..n (the usual case): the slots are the ids; an int32 or writeable C-contiguous uint32 layer
            # (ids < 2^31) is its own slot map, viewed as int32 (no 8 MB copy per 1080p frame; never written)
            if pid.flags.c_contiguous and pid.flags.writeable and pid.dtype in (np.int32, np.uint32):
                return pid.view(np.int32)
            return pid.astype(np.int32)
        if top < 1 << 16:  # small ids: one table lookup per pixel
            lut = np.zeros(top + 1, np.int32)
            lut[list(self.ids)] = np.arange(1, len(self.ids) + 1, dtype=np.int32)
            return lut[np.minimum(pid, top)] * (pid <= top)
        out = np.zeros(pid.shape, np.int32)
        for s, i in enumerate(self.ids, start=1):
            out[pid == i] = s
        return out


def profile_ids(profile_id: np.ndarray) -> list[int]:
    """The distinct ids > 0 of a profile-id layer, ascending (a histogram for small ids, else a sort)."""
    pid = np.asarray(profile_id)
    top = int(pid.max(initial=0))
    if top <= 1:  # a mask (the usual single material): no histogram
        return [1] if top == 1 else []
    if top < 1 << 16:
        return [int(i) for i in np.flatnonzero(np.bincount(pid.ravel(), minlength=top + 1)[1:]) + 1]
    return [int(i) for i in np.unique(pid[pid > 0])]


def term_rows(offsets: np.ndarray, weights: np.ndarray,
              n_jit: int) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], int]:
    """Rows of one term of one slot: (offsets (K,), w_plus (K, 3), w_minus (K, 3), n_jit_rows).

    ``offsets`` (N,) signed mm and ``weights`` (N, 3) as :class:`~ssskit.sampling.SeparableTaps`
    stores them (sorted by |o|, the first ``n_jit`` jittered). Taps at exactly -o and +o with
    exactly equal weights become one symmetric row (the taps are made exact mirror pairs); other
    taps are single rows. Taps at o = 0 need no row.
    """
    used = np.zeros(offsets.size, bool)
    rows = []  # (jittered, |o|, w_plus, w_minus)
    zero = np.zeros(3)
    for i in range(offsets.size):
        if used[i]:
            continue
        used[i] = True
        o = float(offsets[i])
        if o == 0.0:
            continue
        jit = i < n_jit
        partner = -1
        for j in range(i + 1, offsets.size):
            if not used[j] and offsets[j] == -o and (j < n_jit) == jit and np.array_equal(weights[j], weights[i]):
                partner = j
                break
        if partner >= 0:
            used[partner] = True
            rows.append((jit, abs(o), weights[i], weights[i]))
        else:
            rows.append((jit, abs(o), weights[i] if o > 0 else zero, zero if o > 0 else weights[i]))
    rows.sort(key=lambda r: not r[0])  # jittered rows first (stable: nearest first)
    k = len(rows)
    offs = np.array([r[1] for r in rows], float).reshape(k)
    wp = np.array([r[2] for r in rows], float).reshape(k, 3)
    wm = np.array([r[3] for r in rows], float).reshape(k, 3)
    return offs, wp, wm, sum(1 for r in rows if r[0])


def build_separable_plan(taps_by_id: dict, fx: float, fy: float, *, jitter: float, depth_mode: str,
                         frame: int = 0, seed: int = 0) -> SeparablePlan:
    """The plan for profile ids -> :class:`~ssskit.sampling.SeparableTaps` (module docstring).

    ``depth_mode`` is one of :data:`DEPTH_MODES`; its parameter comes from each id's taps:
    1 / (2 tau_max) for ``gaussian`` (tau_max = the kernel's depth-correction width squared, or the
    axis width squared for kernels without one), 1 / width for ``follow``.
    """
    depth_mode = check_choice("depth_mode", depth_mode, DEPTH_MODES, PassError)
    ids = check_plan_ids(taps_by_id, object, fx, fy)
    n_slots = len(ids) + 1
    rank = max((taps_by_id[i].rank for i in ids), default=1)
    per_slot = []  # per slot: list over terms of rows
    params = np.zeros(n_slots)
    for s, pid in enumerate(ids, start=1):
        t = taps_by_id[pid]
        nj = t.jitter_count(jitter)
        per_slot.append([term_rows(t.offsets_mm[r], t.weights[r], nj) for r in range(t.rank)])
        if depth_mode == "gaussian":
            tau = t.tau_max_mm2 if t.tau_max_mm2 is not None else t.width_mm**2
            params[s] = 1.0 / (2.0 * tau)
        elif depth_mode == "follow":
            params[s] = 1.0 / t.width_mm
    terms = []
    for r in range(rank):
        k = max((len(rows[r][0]) for rows in per_slot if r < len(rows)), default=0)
        offs = np.zeros((n_slots, k))
        wp = np.zeros((n_slots, k, 3))
        wm = np.zeros((n_slots, k, 3))
        n_jit = np.zeros(n_slots, np.int64)
        n_rows = np.zeros(n_slots, np.int64)
        centre = np.zeros((n_slots, 3))
        sign = np.ones((n_slots, 3))
        for s, pid in enumerate(ids, start=1):
            t = taps_by_id[pid]
            if r >= t.rank:
                continue  # a lower-rank kernel: this term contributes 0 on its pixels
            o, p, m, nj = per_slot[s - 1][r]
            offs[s, : o.size], wp[s, : o.size], wm[s, : o.size] = o, p, m
            n_jit[s], n_rows[s] = nj, o.size
            centre[s] = t.weights[r].sum(axis=0)
            sign[s] = t.signs[r]
        terms.append(TermTable(offs, wp, wm, n_jit, n_rows, centre, sign))
    return SeparablePlan(ids, tuple(terms), depth_mode, params, float(fx), float(fy), int(frame), int(seed))
