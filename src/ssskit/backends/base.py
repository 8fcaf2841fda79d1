"""The backend contract: one small method per screen-space pass, and whether the backend can run here.

A backend turns a pass's *plan* (what to compute, built once per frame by ``ssskit.screenspace``)
and the frame's images into the result. Backends own their scratch buffers; every result they
return is a new array that nothing else writes to (results never alias scratch space).

Frame inputs of the separable pass (all pixel-aligned):

* ``diffuse`` (H, W, 3) linear light, the signal blurred;
* ``depth_mm`` (H, W) linear camera depth in mm, finite wherever ``slots`` > 0;
* ``slots`` (H, W) int32, the plan's profile slot of each pixel (0 = no SSS: copied unchanged).

The Burley pass (:mod:`ssskit.backends.burley_plan`) takes the same images and ``spp``, one sample
count or an (H, W) integer count image. The transmittance pass (:mod:`ssskit.backends.transmission_plan`, pass name
"transmission") takes the light's view of the frame, and the lateral spread of its light
(:mod:`ssskit.backends.spread_plan`, pass name "spread") its result. Every backend has the separable pass; a backend that also
implements the Burley pass names it in ``passes``.

The guiding phase of the adaptive sampler (:mod:`ssskit.backends.adaptive_plan`, pass name
"adaptive") has two entry points, :meth:`Backend.adaptive_counts` and :meth:`Backend.adaptive_update`,
and a frame loop that keeps the history and the counts with the backend between frames,
:meth:`Backend.adaptive_runner` (:class:`AdaptiveRunner`: arrays in memory on the CPU backends, device
images on ``gl``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import PassError
from ..quantities import check_choice
from .plan import DEPTH_MODES, SEPARABLE_FRAME, SeparablePlan, check_arrays

if TYPE_CHECKING:
    from .adaptive_plan import AdaptivePlan, GuideFrame
    from .burley_plan import BurleyPlan, Prefiltered, SampleCounts
    from .spread_plan import SpreadPlan
    from .transmission_plan import TransmissionPlan

_T = TypeVar("_T")


#: the phases an AdaptiveRunner times, in frame order (Xie 2020 Fig. 8 and Table 1)
PHASES = ("estimate", "prefilter", "sampling", "update")

#: what :meth:`Backend.warm_up` gets ready: the separable pass in each depth mode (:data:`DEPTH_MODES`) on a frame
#: of one profile id, what it adds for several ids (``separable:ids``), the Burley pass, the adaptive sampler's
#: guiding phase, the transmittance pass and its lateral spread
WARM_UP = tuple(f"separable:{mode}" for mode in DEPTH_MODES) + ("separable:ids", "burley", "adaptive",
                                                                 "transmission", "spread")


class Backend(ABC):
    """A way to run the screen-space passes (numpy reference, numba CPU, ...)."""

    #: registry name
    name: str = ""
    #: one line for ``ssskit backends``
    description: str = ""
    #: the float type the backend computes in (the parity tolerance table is keyed by it)
    dtype: type = np.float64
    #: the passes this backend implements ("separable" always; "burley" where :meth:`burley` is overridden)
    passes: frozenset[str] = frozenset({"separable"})
    #: whether the first frame of a pass compiles its kernels (numba), which :meth:`warm_up` can do ahead
    compiles_on_first_use: bool = False

    def availability(self) -> tuple[bool, str]:
        """(True, details) if the backend can run on this machine, else (False, why not)."""
        return True, ""

    def warm_up(self, passes: Iterable[str]) -> None:
        """Get ``passes`` (names from :data:`WARM_UP`) ready, so that their first real frame runs at full speed:
        the numba backend compiles their kernels (or loads them from numba's disk cache, which then serves
        every later process too). An unknown name: a BackendError. A template: the backend's own
        :meth:`_warm_up` gets the checked names."""
        self._warm_up(check_warm_up(passes))

    def _warm_up(self, names: list[str]) -> None:
        """:meth:`warm_up` of checked names: this backend has nothing to prepare."""

    #: whether :meth:`_separable` checks the frame's values and slot range itself as it reads the frame (numba:
    #: in its one packing pass), so that :meth:`separable` checks only the shapes and types
    separable_checks_values: bool = False

    # The entry points below are template methods: each states its pass's input rules once, for every backend
    # (the pass is one this backend implements; the frame's shapes, types and values: its table of arrays, checked
    # by :func:`~ssskit.backends.plan.check_arrays`), returns an empty frame's result without running the pass,
    # and hands checked inputs to the backend's own ``_<pass>``:
    # ``_separable`` always, and each of these where :attr:`passes` names the pass (:meth:`require` refuses the
    # others before they are reached): ``_burley`` (checked counts: an int or an (H, W) int64 image),
    # ``_transmission``, ``_transmission_spread``, ``_adaptive_counts`` (a GuideFrame without ``rgb`` and
    # ``counts``) and ``_adaptive_update`` (with them).
    _burley: Callable[[BurleyPlan, np.ndarray, np.ndarray, np.ndarray, NDArray[np.int64] | int, Prefiltered | None],
                      np.ndarray]
    _transmission: Callable[[TransmissionPlan, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    _transmission_spread: Callable[[SpreadPlan, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    _adaptive_counts: Callable[[AdaptivePlan, GuideFrame], NDArray[np.int64]]
    _adaptive_update: Callable[[AdaptivePlan, GuideFrame], tuple[NDArray[np.float32], NDArray[np.int64]]]

    def separable(self, plan: SeparablePlan, diffuse: np.ndarray, depth_mm: np.ndarray,
                  slots: np.ndarray) -> np.ndarray:
        """The separable pass (see :mod:`ssskit.backends.plan`): a new (H, W, 3) array, inputs checked by
        :data:`~ssskit.backends.plan.SEPARABLE_FRAME` (real ``diffuse`` (H, W, 3) and ``depth_mm`` (H, W) of any
        array-like, an integer ``slots`` image: a float one is refused, never rounded; the values and the slot
        range here unless :attr:`separable_checks_values`)."""
        check_arrays(SEPARABLE_FRAME, dict(diffuse=diffuse, depth_mm=depth_mm, slots=slots), plan.slots,
                     values=not self.separable_checks_values)
        if np.size(slots) == 0:
            return np.array(diffuse, self.dtype)
        return self._separable(plan, diffuse, depth_mm, slots)

    @abstractmethod
    def _separable(self, plan: SeparablePlan, diffuse: np.ndarray, depth_mm: np.ndarray,
                   slots: np.ndarray) -> np.ndarray:
        """:meth:`separable` on a checked frame of at least one pixel."""

    def burley(self, plan: BurleyPlan, diffuse: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
               spp: SampleCounts, pyramid: Prefiltered | None = None) -> np.ndarray:
        """The Burley Monte Carlo pass (see :mod:`ssskit.backends.burley_plan`): a new (H, W, 3) array.

        ``spp``: samples per pixel, an int or an (H, W) integer image (the frame checked by
        :data:`~ssskit.backends.burley_plan.BURLEY_FRAME`). ``pyramid``: the frame's pyramid if the caller built
        it already, by :meth:`burley_prefilter` (CPU backends; None: built here when the plan has mips). A
        backend without the pass raises :class:`~ssskit.errors.BackendError`.
        """
        from .burley_plan import BURLEY_FRAME

        self.require("burley")
        counts = check_arrays(BURLEY_FRAME, dict(diffuse=diffuse, depth_mm=depth_mm, slots=slots, spp=spp),
                              plan.slots)["spp"]
        if np.size(slots) == 0:
            return np.array(diffuse, self.dtype)
        return self._burley(plan, diffuse, depth_mm, slots, counts, pyramid)

    def burley_prefilter(self, plan: BurleyPlan, diffuse: np.ndarray, slots: np.ndarray) -> Prefiltered:
        """Step 5b's pyramid of a frame (Xie 2020 Eqs. 22-23) in the form this backend's :meth:`burley` takes
        as ``pyramid``: here the oracle's :func:`~ssskit.backends.burley_plan.mip_pyramid` (float64)."""
        from .burley_plan import mip_pyramid

        return mip_pyramid(diffuse, slots, plan.slots)

    def transmission(self, plan: TransmissionPlan, slots: np.ndarray, light_uvz: np.ndarray, shadow_mm: np.ndarray,
                     n_dot_l: np.ndarray, light_rgb: np.ndarray) -> np.ndarray:
        """The transmittance pass (see :mod:`ssskit.backends.transmission_plan`): a new (H, W, 3) array of the
        light leaving each pixel through the medium, inputs checked by
        :data:`~ssskit.backends.transmission_plan.TRANSMISSION_FRAME`. A backend without the pass raises
        :class:`~ssskit.errors.BackendError`."""
        from .transmission_plan import TRANSMISSION_FRAME

        self.require("transmission")
        check_arrays(TRANSMISSION_FRAME, dict(slots=slots, light_uvz=light_uvz, shadow_mm=shadow_mm, n_dot_l=n_dot_l,
                                              light_rgb=light_rgb), plan.slots)
        if np.size(slots) == 0:
            return np.zeros(np.shape(slots) + (3,), self.dtype)
        return self._transmission(plan, slots, light_uvz, shadow_mm, n_dot_l, light_rgb)

    def transmission_spread(self, plan: SpreadPlan, exitance: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
                            light_uvz: np.ndarray, shadow_mm: np.ndarray) -> np.ndarray:
        """The transmitted light's lateral spread (see :mod:`ssskit.backends.spread_plan`, pass name "spread"): a
        new (H, W, 3) array, ``exitance`` (the transmittance pass's result) spread by each pixel's thickness,
        inputs checked by :data:`~ssskit.backends.spread_plan.SPREAD_FRAME`. A backend without the step
        raises :class:`~ssskit.errors.BackendError`."""
        from .spread_plan import SPREAD_FRAME

        self.require("spread")
        check_arrays(SPREAD_FRAME, dict(slots=slots, light_uvz=light_uvz, shadow_mm=shadow_mm, exitance=exitance,
                                        depth_mm=depth_mm), plan.slots)
        if np.size(slots) == 0:
            return np.array(exitance, self.dtype)
        return self._transmission_spread(plan, exitance, depth_mm, slots, light_uvz, shadow_mm)

    def adaptive_counts(self, plan: AdaptivePlan, history: ArrayLike, mask: ArrayLike, motion: ArrayLike | None = None,
                        valid: ArrayLike | None = None) -> NDArray[np.int64]:
        """The guiding phase's *estimate* (:mod:`ssskit.backends.adaptive_plan` steps 1, 3, 4): this frame's
        sample counts (H, W) int64 from the previous (H, W, 4) history, reprojected through ``motion``
        (H, W, 2) (None: static) with ``valid`` (H, W) (None: everywhere), and the frame's SSS ``mask``;
        inputs checked by :data:`~ssskit.backends.adaptive_plan.GUIDE_FRAME`."""
        from .adaptive_plan import GUIDE_FRAME, GuideFrame

        self.require("adaptive")
        return self._adaptive_counts(plan, GuideFrame(**check_arrays(GUIDE_FRAME, dict(
            history=history, mask=mask, motion=motion, valid=valid))))

    def adaptive_update(self, plan: AdaptivePlan, history: ArrayLike, rgb: ArrayLike | None, counts: ArrayLike | None,
                        mask: ArrayLike, motion: ArrayLike | None = None,
                        valid: ArrayLike | None = None) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        """The guiding phase's *update* (:mod:`ssskit.backends.adaptive_plan` steps 1-4): (the new (H, W, 4)
        float32 history, the next frame's counts (H, W) int64 for the same pixels) from the previous
        history, this frame's Burley result ``rgb`` (H, W, 3) and the ``counts`` it used (both required)."""
        from .adaptive_plan import GUIDE_FRAME, GuideFrame

        self.require("adaptive")
        return self._adaptive_update(plan, GuideFrame(**check_arrays(GUIDE_FRAME, dict(
            history=history, mask=mask, motion=motion, valid=valid, rgb=rgb, counts=counts))))

    def adaptive_runner(self, plan: AdaptivePlan, history: ArrayLike) -> AdaptiveRunner:
        """A frame loop of the Burley pass with adaptive counts that keeps the history (and counts) with this
        backend between frames (:class:`AdaptiveRunner`; the gl backend keeps them on the device)."""
        self.require("adaptive", "burley")
        return AdaptiveRunner(self, plan, history)

    def require(self, *passes: str) -> Backend:
        """This backend if it implements every one of ``passes`` (names of :attr:`passes`), else a BackendError
        naming, in words, the first it does not implement."""
        from ..errors import BackendError

        for name in passes:
            if name not in self.passes:
                raise BackendError(f"backend {self.name!r} has no " + {
                    "burley": "Burley pass", "adaptive": "adaptive guiding pass", "transmission": "transmittance pass",
                    "spread": "spread of the transmitted light"}.get(name, f"{name} pass"))
        return self


class AdaptiveRunner:
    """Frames of the Burley pass with the counts of the guiding phase (Xie 2020 Fig. 8), on one backend.

    Per frame: :meth:`load` a G-buffer (with the motion from it to the previous frame, if it moved; this
    runs the *estimate*), or keep the last one (then the counts the last *update* produced are used),
    :meth:`sample` (the Burley pass with those counts, mips first) and :meth:`update` (the history update
    and the next counts). :meth:`result`, :meth:`counts` and :meth:`history` read back; ``times`` holds the
    ms of every phase run (:data:`PHASES`). This base class keeps everything in numpy arrays and calls the
    backend's entry points; the gl backend's subclass keeps it on the device. The phases' order is stated here
    for every runner (a subclass implements :meth:`_sample`, :meth:`_update` and :meth:`_result`).
    """

    def __init__(self, backend: Backend, plan: AdaptivePlan, history: ArrayLike, sampler: Backend | None = None) -> None:
        from .adaptive_plan import GUIDE_FRAME

        self.backend = backend
        self.sampler = backend if sampler is None else sampler  # the backend of the Burley pass
        self.plan = plan
        self._history = np.array(check_arrays(GUIDE_FRAME, {"history": history})["history"], np.float32)
        self._counts: np.ndarray | None = None
        self._out: np.ndarray | None = None
        self._frame: tuple[NDArray[np.float32], NDArray[np.float32], np.ndarray] | None = None
        self._sampled: tuple[NDArray[np.float32], NDArray[np.float32], np.ndarray] | None = None  # since the load
        self._has_counts = self._updated = False
        self._motion: ArrayLike | None = None
        self._valid: ArrayLike | None = None
        self.times: dict[str, list[float]] = {p: [] for p in PHASES}

    @property
    def shape(self) -> tuple[int, int]:
        h, w = self._history.shape[:2]
        return h, w

    def _timed(self, phase: str, fn: Callable[[], _T]) -> _T:
        import time

        t = time.perf_counter()
        out = fn()
        self.times[phase].append(1e3 * (time.perf_counter() - t))
        return out

    def load(self, diffuse: ArrayLike, depth_mm: ArrayLike, slots: ArrayLike, motion: ArrayLike | None = None,
             valid: ArrayLike | None = None, estimate: bool = True) -> None:
        """A frame's G-buffer images (the Burley pass's inputs: :mod:`ssskit.backends.base`), and ``motion``
        (H, W, 2) from it to the previous frame (None: the camera and the scene did not move) and ``valid``
        (H, W) (the caller's disocclusion test; None: everywhere); runs the *estimate* for the frame.
        ``estimate=False`` skips it (a fixed count, or the caller's own): :meth:`set_counts` must follow
        before :meth:`sample`."""
        s: NDArray[np.integer] = check_arrays(SEPARABLE_FRAME, {"slots": slots}, dims=self.shape)["slots"]
        self._frame = (np.asarray(diffuse, np.float32), np.asarray(depth_mm, np.float32), s)
        self._motion, self._valid = motion, valid
        self._counts = None
        self._has_counts, self._sampled = estimate, None
        if estimate:
            self._counts = self._timed("estimate", lambda: self.backend.adaptive_counts(
                self.plan, self._history, s > 0, motion, valid))

    def set_counts(self, counts: ArrayLike) -> None:
        """Replace the counts the next :meth:`sample` (and :meth:`update`'s Eq. 8) uses: an (H, W) integer
        image (a fixed count on the mask, or the estimate changed by the caller); not timed."""
        from .burley_plan import COUNT_IMAGE

        self._counts = np.array(check_arrays({"counts": COUNT_IMAGE}, {"counts": counts}, dims=self.shape)["counts"],
                                np.int64)  # (a copy: the caller's array stays theirs)
        self._has_counts = True

    def sample(self, plan: BurleyPlan) -> None:
        """The Burley pass of the loaded frame with the current counts (``plan.frame`` keys its samples)."""
        if self._frame is None or not self._has_counts:
            raise PassError("load a frame (and set its counts, without the estimate) before sampling it")
        self._sample(plan, *self._frame)
        self._sampled, self._updated = self._frame, False

    def update(self) -> None:
        """The history update from the last :meth:`sample` (Eqs. 6, 8, 9; 16-17) and the next counts."""
        if self._sampled is None or self._updated:  # (once per sampled frame: its result and counts feed it)
            raise PassError("sample a frame before updating the history")
        self._update(self._sampled[2])
        self._updated = True

    def result(self) -> np.ndarray:
        """The last sampled frame's Burley result (H, W, 3) float32 (a new array)."""
        if self._sampled is None:
            raise PassError("no frame sampled yet")
        return self._result()

    def _sample(self, plan: BurleyPlan, diffuse: np.ndarray, depth: np.ndarray, slots: np.ndarray) -> None:
        counts = self._counts
        assert counts is not None  # (set with _has_counts: the order sample states)
        pyr = None
        if plan.mips:
            pyr = self._timed("prefilter", lambda: self.sampler.burley_prefilter(plan, diffuse, slots))
        self._out = self._timed("sampling", lambda: self.sampler.burley(plan, diffuse, depth, slots, counts,
                                                                         pyramid=pyr))

    def _update(self, slots: np.ndarray) -> None:
        self._history, self._counts = self._timed("update", lambda: self.backend.adaptive_update(
            self.plan, self._history, self._out, self._counts, slots > 0, self._motion, self._valid))
        self._motion = self._valid = None  # the next frame, unless loaded anew, is this one again

    def _result(self) -> np.ndarray:
        return np.array(self._out, np.float32)

    def counts(self) -> np.ndarray:
        """The counts the next :meth:`sample` uses (H, W) int64 (a new array)."""
        return np.array(self._counts, np.int64)

    def history(self) -> np.ndarray:
        """The history (H, W, 4) float32 (a new array)."""
        return np.array(self._history, np.float32)

    def release(self) -> None:
        """Free what the runner holds (device images on gl)."""


def check_warm_up(passes: Iterable[str]) -> list[str]:
    """The names of :meth:`Backend.warm_up` as a list, or a BackendError naming the unknown one."""
    from ..errors import BackendError

    return [check_choice("the pass to warm up", name, WARM_UP, BackendError)
            for name in ([passes] if isinstance(passes, str) else list(passes))]


def run_tiny_frames(backend: Backend, names: list[str]) -> None:
    """Run each of ``names`` (:data:`WARM_UP`, checked by :meth:`Backend.warm_up`) once on ``backend`` on a tiny
    synthetic 8 x 8 frame (two profile ids; one for ``separable:<mode>``, whose first real frame rarely has more),
    through the backend's own entry points: what a backend that compiles on first use calls to compile, since
    the argument types (hence the compiled specialisations) are those of a real frame of any size.
    ``separable:ids`` runs the pass in the depth mode named before it (else ``follow``) on two ids. The results
    are thrown away."""
    from .adaptive_plan import AdaptivePlan
    from .burley_plan import BurleyParams, build_burley_plan
    from .plan import TermTable
    from .spread_plan import SlotSpread, build_spread_plan
    from .transmission_plan import SlotModel, build_transmission_plan

    n = 8
    diffuse = np.ones((n, n, 3), np.float32)
    depth = np.full((n, n), 100.0, np.float32)
    slots = np.ones((n, n), np.int32)
    slots[:, n // 2:] = 2
    slots[0] = 0
    ids = (1, 2)
    uvz = np.zeros((n, n, 3), np.float32)  # the light's view: each pixel 1 mm behind a shadow map of 1 mm
    uvz[..., 2] = 2.0
    modes = [name.partition(":")[2] for name in names if name.startswith("separable:") and name != "separable:ids"]
    for name in names:
        kind, _, mode = name.partition(":")
        if kind == "separable":
            k = 2 if mode == "ids" else 1  # profile ids
            rows = np.array([[0.0, 0.0]] + [[0.5, 1.0]] * k)
            weights = np.full((k + 1, 2, 3), 0.1)
            term = TermTable(rows, weights, weights, np.array([0] + [1] * k), np.array([0] + [2] * k),
                             np.full((k + 1, 3), 0.6), np.ones((k + 1, 3)))
            plan = SeparablePlan(ids[:k], (term,), (modes or ["follow"])[0] if mode == "ids" else mode,
                                 np.array([0.0] + [1.0] * k), 100.0, 100.0, 0, 0)
            backend.separable(plan, diffuse, depth, slots if k == 2 else np.minimum(slots, 1))
        elif kind == "burley":
            params = BurleyParams.from_dmfp((0.5, 0.5, 0.5), (1.0, 0.5, 0.25))
            for mips in (True, False):
                bplan = build_burley_plan({i: params for i in ids}, 100.0, 100.0, sampler="xie", mips=mips)
                backend.burley(bplan, diffuse, depth, slots, 2)
                backend.burley(bplan, diffuse, depth, slots, np.full((n, n), 2, np.int64))
        elif kind == "adaptive":
            aplan = AdaptivePlan(sigma0_sq=1e-3, kappa=0.2, b_min=1, b_max=64, alpha=0.2, correction="variance",
                                 gamma=1.0)
            history = np.zeros((n, n, 4), np.float32)
            counts = backend.adaptive_counts(aplan, history, slots > 0)
            backend.adaptive_update(aplan, history, diffuse, counts, slots > 0)
            backend.adaptive_counts(aplan, history, slots > 0, np.zeros((n, n, 2)), np.ones((n, n), bool))
        elif kind == "transmission":
            model = SlotModel(np.full((3, 2), 0.5), np.ones((3, 2)), np.zeros((3, 2)))
            tplan = build_transmission_plan({i: model for i in ids})
            backend.transmission(tplan, slots, uvz, np.ones((n, n), np.float32), np.ones((n, n), np.float32),
                                 diffuse)
        elif kind == "spread":
            spread = SlotSpread(np.array([0.0, 2.0]), np.ones((3, 2)))
            splan = build_spread_plan({i: spread for i in ids}, 100.0, 100.0)
            backend.transmission_spread(splan, diffuse, depth, slots, uvz, np.ones((n, n), np.float32))
