"""The frame loop of the Burley pass: adaptive (Xie et al. 2020 Sec. 4.1, Fig. 8) or fixed sample counts,
on one still G-buffer or along a camera/light path, optionally through the global TAA (Karis 2014).

Every frame sequence in ssskit runs through :func:`run_frames`: the adaptive run of ``ssskit render
--pass burley-adaptive`` (:mod:`ssskit.pipeline.adaptive`), the static runs of
:func:`ssskit.screenspace.adaptive.adaptive_frames`, the figures (:mod:`ssskit.figures.adaptive`) and the
benchmarks. Per frame f (G-buffer g_f; motion m_f = :func:`~ssskit.screenspace.camera.motion_vectors` from
g_f's pixels to where their surface was in g_{f-1}, when the camera moved), through the backend's runner
(:meth:`ssskit.backends.Backend.adaptive_runner`, :mod:`ssskit.backends.adaptive_plan`; the history and
the counts stay with the backend, on the device for gl):

1. a new G-buffer is loaded (``runner.load(g_f, m_f)``: for adaptive counts this runs the *estimate*, the
   history reprojected, nearest and without rejection, Xie 2020 Sec. 4.1.5's lower bound of Eq. 18;
   pixels whose previous position is off-screen or was not SSS take the disocclusion initialisation,
   Eqs. 16-17, then Eqs. 13-15 and the clamp give the counts); the same G-buffer again (a still frame) is
   not reloaded: the counts are those the last *update* produced (steps 3-4 of the plan on the new
   history, what a static camera uses); a fixed count loads without the estimate and sets ``spp`` on
   the SSS mask;
2. ``runner.sample(plan_f)``: the Burley pass with those counts (the frame number keys the random numbers);
3. adaptive: ``runner.update()``, the history update (Eqs. 8, 6, 9) on the pre-TAA output, so the sampler
   is the same with TAA on or off (it never reads the TAA's state);
4. ``sss_f = runner.result()``, plus the light ``transmission(g_f)`` adds (the transmittance pass's, computed
   once per G-buffer; it is deterministic, so the guiding phase of step 3 never sees it, as it never sees
   the TAA); ``image_f = g_f.composite(sss_f)``; with TAA, ``taa_f =
   TemporalAA.resolve(image_f, m_f, valid_f)``, ``valid_f`` the depth test
   :func:`~ssskit.screenspace.taa.reprojection_valid` when a new G-buffer was loaded (None on a still one);
5. with ``references`` (one converged blurred diffuse layer per frame), the frame's PSNR inside the SSS
   mask, linear and as the display's gray scale (:func:`ssskit.metrics.display_psnr`).

The counts are chosen before a frame's samples are drawn, from earlier frames only, so each frame's
estimate has the expectation of the pass at its count: adapting the counts adds no bias of its own.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..backends.adaptive_plan import AVAILABLE, as_plan
from ..backends.base import PHASES, AdaptiveRunner, Backend
from ..backends.burley_plan import BurleyParams, BurleyPlan
from ..backends.plan import profile_ids
from ..errors import PassError, SettingsError
from ..metrics import display_psnr, region_metrics
from ..quantities import FRAME, FRAMES, check_instance, check_shape, refuse_unused
from .adaptive import AdaptiveSettings, _settings as adaptive_settings, check_history, new_history, reproject_history
from .burley import BACKEND, BURLEY_SPP, BurleySettings, burley_backend, burley_plan_for
from .camera import motion_vectors
from .gbuffer import RADIANCE, GBuffer
from .taa import TAASettings, TemporalAA, reprojection_valid

#: the per-frame times :attr:`FrameRun.phases` holds: the runner's phases, the result's readback and the
#: transmitted light of a new G-buffer
TIMED = (*PHASES, "readback", "transmission")


@dataclass
class Frame:
    """What :func:`run_frames` hands ``on_frame`` after each frame: ``index`` (from 0), ``number`` (the frame
    number that keyed its samples), its ``gbuffer``, ``sss`` (the pass's blurred diffuse layer, (H, W, 3)
    float32), ``image`` (composited), ``image_taa`` (after TAA, or None), ``counts`` ((H, W) int64, the
    samples each pixel took); :meth:`history` reads the guiding phase's history back."""

    index: int
    number: int
    gbuffer: GBuffer
    sss: np.ndarray
    image: np.ndarray
    image_taa: np.ndarray | None
    counts: np.ndarray
    runner: AdaptiveRunner

    def history(self) -> np.ndarray:
        """The (H, W, 4) float32 history after this frame (a new array; a readback on gl)."""
        return self.runner.history()


@dataclass
class FrameRun:
    """Per-frame results of :func:`run_frames`, each a list over frames: ``mean_spp`` (mean samples per SSS
    pixel), ``psnr`` / ``psnr_taa`` (the composite against the frame's reference inside the SSS mask, before
    and after TAA; None without a reference or TAA), ``psnr_gray`` / ``psnr_gray_taa`` (the same as
    :func:`~ssskit.metrics.display_psnr`), ``ms`` (the Burley pass: prefilter + sampling), ``ms_update`` (the
    guiding phase: estimate + update; 0 for a fixed count), ``ms_frame`` (the wall time of the whole loop:
    load with its upload and estimate, pass, update, the result's readback, the transmitted light of a new
    G-buffer; not the counts' readback for the
    statistics, the fixed count's upload, motion vectors, TAA or metrics), ``phases`` (ms per frame of each
    of :data:`TIMED`; on gl GPU time, or wall time around glFinish on llvmpipe). ``samples``: the total
    samples taken; ``last`` / ``last_taa``: the last frame's composite images, ``last_sss`` its blurred
    diffuse layer; ``counts`` (frames, H, W) int32 when kept; ``history``: the final (H, W, 4) history;
    ``mean`` / ``stderr`` (H, W, 3) float64 when accumulated: the average of the frames' blurred diffuse
    layers and its standard error from their spread; ``backend``: where the guiding phase ran."""

    adaptive: AdaptiveSettings | None
    spp: int | None
    taa: TAASettings | None
    backend: str = ""
    mean_spp: list[float] = field(default_factory=list)
    psnr: list[float | None] = field(default_factory=list)
    psnr_taa: list[float | None] = field(default_factory=list)
    psnr_gray: list[float | None] = field(default_factory=list)
    psnr_gray_taa: list[float | None] = field(default_factory=list)
    ms: list[float] = field(default_factory=list)
    ms_update: list[float] = field(default_factory=list)
    ms_frame: list[float] = field(default_factory=list)
    phases: dict[str, list[float]] = field(default_factory=lambda: {p: [] for p in TIMED})
    samples: int = 0
    last: np.ndarray | None = None
    last_taa: np.ndarray | None = None
    last_sss: np.ndarray | None = None
    counts: np.ndarray | None = None
    history: np.ndarray | None = None
    mean: np.ndarray | None = None
    stderr: np.ndarray | None = None

    def rows(self) -> list[dict[str, Any]]:
        """The per-frame records (frame index from 0)."""
        return [{"frame": f, "mean_spp": self.mean_spp[f], "psnr": self.psnr[f],
                 "psnr_taa": self.psnr_taa[f] if self.taa is not None else None, "psnr_gray": self.psnr_gray[f],
                 "psnr_gray_taa": self.psnr_gray_taa[f] if self.taa is not None else None, "ms": self.ms[f],
                 "ms_update": self.ms_update[f], "ms_frame": self.ms_frame[f]} for f in range(len(self.mean_spp))]

    def final_psnr(self, last: int = 20, taa: bool = True, gray: bool = False) -> float:
        """The sequence's final PSNR: the mean over its last ``last`` frames of the per-frame PSNR (after
        TAA when it ran and ``taa``; the display gray-scale PSNR with ``gray``; frames without a
        reference are left out; NaN when none is left)."""
        if gray:
            series = self.psnr_gray_taa if (taa and self.taa is not None) else self.psnr_gray
        else:
            series = self.psnr_taa if (taa and self.taa is not None) else self.psnr
        vals = [v for v in series[-last:] if v is not None]
        return float(np.mean(vals)) if vals else float("nan")


def _psnr(reference: np.ndarray | None, image: np.ndarray, mask: np.ndarray) -> float | None:
    if reference is None or not mask.any():
        return None
    return region_metrics(reference, image, mask, False)["psnr"]


def _check(gbuffers: Sequence[GBuffer], burley: BurleySettings | None, adaptive: AdaptiveSettings | None,
           spp: int | None, taa: TAASettings | None, references: Sequence[np.ndarray] | None,
           disocclusion_spp: int | None) -> tuple[BurleySettings, int | None, int | None, list[GBuffer], tuple[int, int]]:
    b = check_instance(BurleySettings() if burley is None else burley, BurleySettings, "burley", SettingsError)
    if (adaptive is None) == (spp is None):
        raise SettingsError("give adaptive settings or a fixed spp, exactly one of them")
    check_instance(adaptive, AdaptiveSettings, "adaptive", SettingsError, optional=True)
    check_instance(taa, TAASettings, "taa", SettingsError, optional=True)
    spp = None if spp is None else int(BURLEY_SPP.check(spp, "spp", SettingsError))
    if disocclusion_spp is not None and adaptive is None:
        refuse_unused(["disocclusion_spp"], "counts", ["adaptive"], "fixed", SettingsError)
    if disocclusion_spp is not None and adaptive is not None:
        disocclusion_spp = int(adaptive.budget().check(disocclusion_spp, "disocclusion_spp", SettingsError))
    gbs = [check_instance(g, GBuffer, "the frame loop's G-buffers", PassError) for g in gbuffers]
    if not gbs or any(g.shape != gbs[0].shape for g in gbs):
        raise PassError("the frame loop needs a non-empty sequence of G-buffers of one size")
    if references is not None and len(references) != len(gbs):
        raise PassError(f"{len(references)} references for {len(gbs)} frames")
    FRAME.check(b.frame + len(gbs) - 1, f"the last frame ({len(gbs)} frames from frame {b.frame})", SettingsError)
    return b, spp, disocclusion_spp, gbs, gbs[0].shape


def _runner(b: BurleySettings, adaptive: AdaptiveSettings | None, history: ArrayLike | None, guide: str | None,
            shape: tuple[int, int]) -> tuple[AdaptiveRunner, Backend]:
    """The backend runner: the Burley pass on ``b.backend``, the guiding phase on ``guide`` (default: the
    same backend, which then keeps the history and counts between frames)."""
    from ..backends import get_backend

    sampler = burley_backend(b.backend)
    g = (sampler if guide is None else get_backend(BACKEND.check(guide, "backend", SettingsError))).require("adaptive")
    h = new_history(*shape) if history is None else check_history(history, shape)  # (the G-buffers' size)
    plan = as_plan(adaptive if adaptive is not None else AdaptiveSettings())
    runner = g.adaptive_runner(plan, h) if g is sampler else AdaptiveRunner(g, plan, h, sampler=sampler)
    return runner, g


def run_frames(gbuffers: Sequence[GBuffer], params: BurleyParams | Mapping[int, BurleyParams], burley: BurleySettings | None = None, *,
               adaptive: AdaptiveSettings | None = None, spp: int | None = None, taa: TAASettings | None = None,
               references: Sequence[np.ndarray] | None = None, disocclusion_spp: int | None = None,
               history: ArrayLike | None = None, guide: str | None = None, keep_counts: bool = False, accumulate: bool = False,
               on_frame: Callable[[Frame], None] | None = None,
               progress: Callable[[str], None] | None = None,
               transmission: Callable[[GBuffer], np.ndarray] | None = None) -> FrameRun:
    """The Burley pass over ``gbuffers`` (module docstring; the same G-buffer object twice in a row is a
    still frame) with ``adaptive`` counts or a fixed ``spp`` (exactly one), ``params`` the Burley parameters
    (one :class:`~ssskit.screenspace.BurleyParams` or a mapping profile id -> params), ``burley`` the
    sampler settings (frame f uses frame number ``burley.frame + f``), ``taa`` the TAA settings or None,
    ``references`` one converged blurred diffuse layer (H, W, 3) per G-buffer or None (no PSNR).

    ``disocclusion_spp`` (adaptive only): the count of pixels inside the mask whose reprojected history is
    missing (channel 3 = 0: new, newly SSS, or off-screen before; the first frame everywhere). None is Xie
    2020 Sec. 4.1.4 as printed: n = max(n_hat, beta) = b_min there. A larger value is this package's
    variant (not the paper's): a newly visible pixel has no TAA history either, so its b_min-sample noise
    reaches the screen unfiltered; the history is still initialised by Eqs. 16-17 (Eq. 8 records the
    count actually taken). ``history``: the initial (H, W, 4) history (default: none, so frame 0 takes the
    disocclusion initialisation). ``guide``: the backend of the guiding phase (default: the Burley pass's).
    ``keep_counts``: keep every frame's counts; ``accumulate``: the average of the frames and its standard
    error. ``on_frame(frame)`` is called after every frame with a :class:`Frame`; ``progress`` gets
    ``"frame k/N"`` before each. ``transmission(gbuffer)``: the light added to the pass's blurred diffuse
    layer of each G-buffer, (H, W, 3) (the transmittance pass demodulated by the albedo,
    :func:`ssskit.pipeline.transmission.transmission_light`), called once per new G-buffer (module
    docstring, step 4); ``references`` are compared as given (add the same light to them).
    """
    b, spp, disocclusion_spp, gbs, shape = _check(gbuffers, burley, adaptive, spp, taa, references,
                                                  disocclusion_spp)
    runner, guide_backend = _runner(b, adaptive, history, guide, shape)
    run = FrameRun(adaptive=adaptive, spp=spp, taa=taa, backend=guide_backend.name)
    resolver = TemporalAA(taa) if taa is not None else None
    counts_all = np.zeros((len(gbs), *shape), np.int32) if keep_counts else None
    total = np.zeros((*shape, 3)) if accumulate else None
    total_sq = np.zeros((*shape, 3)) if accumulate else None
    prev: GBuffer | None = None
    prev_inside: np.ndarray | None = None
    plan: BurleyPlan | None = None
    slots: np.ndarray | None = None
    added: np.ndarray | None = None
    try:
        for f, gb in enumerate(gbs):
            if progress is not None:
                progress(f"frame {f + 1}/{len(gbs)}")
            new = gb is not prev
            mask = gb.mask
            motion = None  # the camera's motion (also the TAA's input), outside the loop's time
            if new and prev is not None and not np.array_equal(prev.camera.world_to_camera, gb.camera.world_to_camera):
                motion = motion_vectors(gb.depth, gb.camera, prev.camera)
            cam = gb.camera
            if new or plan is None or slots is None:  # (the plan and its slots are set together)
                plan = burley_plan_for(params, profile_ids(gb.profile_id), cam.fx, cam.fy, b)
                slots = plan.slot_map(gb.profile_id)
            plan_f = dataclasses.replace(plan, frame=b.frame + f)
            inside = slots > 0
            before = {p: len(v) for p, v in runner.times.items()}
            t0 = time.perf_counter()
            if new:
                runner.load(gb.diffuse, gb.depth_mm, slots, motion, estimate=adaptive is not None)
            t1 = time.perf_counter()
            if adaptive is None:
                assert spp is not None  # _check: adaptive settings or a fixed spp
                counts = np.where(inside, spp, 0)
                if new:
                    runner.set_counts(counts)
            else:
                counts = runner.counts()
                if disocclusion_spp is not None:
                    counts[inside & ~_had_history(prev_inside, motion, shape, new)] = disocclusion_spp
                    runner.set_counts(counts)
            t2 = time.perf_counter()
            runner.sample(plan_f)
            if adaptive is not None:
                runner.update()
            t_read = time.perf_counter()
            sss = runner.result()
            t4 = time.perf_counter()
            if transmission is not None:
                if new:
                    added = RADIANCE.check_array(check_shape(transmission(gb), "the transmitted light", (*shape, 3),
                                                             PassError), "the transmitted light", PassError, "values")
                assert added is not None  # (computed on the first frame, which is new)
                sss = np.add(sss, added, dtype=sss.dtype)
            t3 = time.perf_counter()
            phase = {p: sum(v[before[p]:]) for p, v in runner.times.items()}
            for p in PHASES:
                run.phases[p].append(phase[p])
            run.phases["readback"].append(1e3 * (t4 - t_read))
            run.phases["transmission"].append(1e3 * (t3 - t4))
            image = gb.composite(sss)
            ref = None if references is None else gb.composite(references[f])
            run.mean_spp.append(float(counts[mask].mean()) if mask.any() else 0.0)
            run.samples += int(counts[mask].sum())
            run.ms.append(phase["prefilter"] + phase["sampling"])
            run.ms_update.append(phase["estimate"] + phase["update"])
            run.ms_frame.append(1e3 * ((t1 - t0) + (t3 - t2)))
            run.psnr.append(_psnr(ref, image, mask))
            run.psnr_gray.append(display_psnr(ref, image, mask))
            out_taa = None
            if resolver is not None:
                valid = None
                if new and prev is not None:
                    valid = reprojection_valid(gb.depth, gb.camera, prev.depth, prev.camera)
                out_taa = resolver.resolve(image, motion, valid)
                run.psnr_taa.append(_psnr(ref, out_taa, mask))
                run.psnr_gray_taa.append(display_psnr(ref, out_taa, mask))
            else:
                run.psnr_taa.append(None)
                run.psnr_gray_taa.append(None)
            if counts_all is not None:
                counts_all[f] = counts
            if total is not None and total_sq is not None:
                o = sss.astype(np.float64)
                total += o
                total_sq += o * o
            if on_frame is not None:
                on_frame(Frame(f, b.frame + f, gb, sss, image, out_taa, np.asarray(counts, np.int64), runner))
            run.last, run.last_taa, run.last_sss = image, out_taa, sss
            prev, prev_inside = gb, inside
        run.history = runner.history()
    finally:
        runner.release()
    run.counts = counts_all
    if total is not None and total_sq is not None:
        n = len(gbs)
        run.mean = total / n
        var = np.maximum(total_sq / n - run.mean * run.mean, 0.0) * (n / max(n - 1, 1))
        run.stderr = np.sqrt(var / n)
    return run


def _had_history(prev_inside: np.ndarray | None, motion: np.ndarray | None, shape: tuple[int, int],
                 new: bool) -> np.ndarray:
    """(H, W) bool: where the reprojected history holds history (channel 3 > 0). After an update the
    history's channel 3 is the frame's SSS mask (:mod:`ssskit.backends.adaptive_plan` step 2), so this
    is that mask fetched like the history (step 1: nearest, no rejection, off-screen: none; a still frame:
    the mask itself); nothing before the first frame."""
    if prev_inside is None:
        return np.zeros(shape, bool)
    if not new:
        return prev_inside
    h = np.zeros((*shape, 4), np.float32)
    h[..., AVAILABLE] = prev_inside
    return reproject_history(h, motion)[..., AVAILABLE] > 0


# ---- a still G-buffer: the Burley pass with adaptive counts ------------------------------------------------

@dataclass
class AdaptiveFrames:
    """A sequence of the Burley pass with adaptive counts on one G-buffer (:func:`adaptive_frames`).

    ``mean`` and ``stderr`` (H, W, 3) float64: the average of the frames' blurred diffuse layers and its
    standard error from the spread across frames; ``last`` (H, W, 3) float32: the last frame;
    ``counts`` (frames, H, W) int32: the samples each pixel took; ``history``: the final (H, W, 4)
    history; ``ms_pass`` / ``ms_update``: per-frame times of the Burley pass (prefilter + sampling) and
    of the guiding phase (counts estimate + history update), in ms; ``phases``: per-frame ms of each
    phase (:data:`ssskit.backends.base.PHASES`: estimate, prefilter, sampling, update; on gl GPU time,
    or wall time around glFinish on llvmpipe); ``backend``: the guiding phase's backend."""

    settings: AdaptiveSettings
    burley: BurleySettings
    mean: np.ndarray
    stderr: np.ndarray
    last: np.ndarray
    counts: np.ndarray
    history: np.ndarray
    ms_pass: list[float]
    ms_update: list[float]
    phases: dict[str, list[float]] = field(default_factory=dict)
    backend: str = ""

    @property
    def mean_spp(self) -> np.ndarray:
        """Mean samples per SSS pixel, per frame (frames,)."""
        mask = self.counts[0] > 0
        return self.counts[:, mask].mean(axis=1) if mask.any() else np.zeros(len(self.counts))


def adaptive_frames(gbuffer: GBuffer, params_by_id: BurleyParams | Mapping[int, BurleyParams], settings: AdaptiveSettings | None = None, frames: int = 16, *,
                    burley: BurleySettings | None = None, history: ArrayLike | None = None,
                    progress: Callable[[str], None] | None = None,
                    on_frame: Callable[[int, np.ndarray, np.ndarray], None] | None = None,
                    backend: str | None = None) -> AdaptiveFrames:
    """``frames`` frames of the Burley pass on a still G-buffer, each with the counts of the
    variance-guided sampler (Xie 2020 Sec. 4.1, Fig. 8's guiding phase), through :func:`run_frames`: per
    frame f,

        counts = sample_counts(history)                       (Eqs. 13-15, clamped to [b_min, b_max])
        sss_f  = burley_sss(gbuffer, params, burley with frame = burley.frame + f, counts=counts)
        history = update_history(history, shading_value(sss_f), counts)   (Eqs. 6, 8, 9; 16-17)

    The camera does not move, so the history needs no reprojection. ``history``: the initial (H, W, 4)
    history (default: none, so frame 0 takes the disocclusion initialisation of Eqs. 16-17);
    ``burley``: :class:`~ssskit.screenspace.BurleySettings` (its ``spp`` is unused); ``on_frame(f, sss,
    counts)`` is called after every frame with its blurred diffuse layer and counts; ``progress`` gets
    ``"adaptive frame k/N"``. ``backend``: where the guiding phase runs (default: the Burley settings'
    backend, which then keeps the history and counts between frames: on gl, on the device).
    """
    check_instance(gbuffer, GBuffer, "gbuffer", PassError)
    s = adaptive_settings(settings)
    b = check_instance(BurleySettings() if burley is None else burley, BurleySettings, "burley", PassError)
    frames = int(FRAMES.check(frames, "frames", SettingsError))
    hook = None if on_frame is None else (lambda fr: on_frame(fr.index, fr.sss, fr.counts))
    say = None if progress is None else (lambda msg: progress(f"adaptive {msg}"))
    run = run_frames([gbuffer] * frames, params_by_id, b, adaptive=s, history=history, guide=backend,
                     keep_counts=True, accumulate=True, on_frame=hook, progress=say)
    assert run.counts is not None and run.history is not None and run.mean is not None and run.stderr is not None
    assert run.last_sss is not None
    return AdaptiveFrames(settings=s, burley=b, mean=run.mean, stderr=run.stderr, last=run.last_sss,
                          counts=run.counts, history=run.history, ms_pass=run.ms, ms_update=run.ms_update,
                          phases={p: run.phases[p] for p in PHASES}, backend=run.backend)


__all__ = ["TIMED", "AdaptiveFrames", "Frame", "FrameRun", "adaptive_frames", "run_frames"]
