"""Frame sequences of the Burley pass along a scene's camera and light paths: the variance-guided adaptive
sample counts (Xie 2020 Sec. 4.1) or a fixed count, each optionally followed by the global TAA resolve
(:mod:`ssskit.screenspace.taa`, Karis 2014), compared frame by frame with that frame's converged reference.

    >>> from ssskit.pipeline.sequence import sequence_gbuffers, run_sequence    # doctest: +SKIP
    >>> gbs = sequence_gbuffers("sphere", "skin1", frames=60, width=160, height=120)
    >>> run = run_sequence(gbs, params, burley, AdaptiveSettings(), taa=TAASettings(), references=refs)

Per frame f (G-buffer g_f with its camera; motion m_f = :func:`~ssskit.screenspace.motion_vectors`
from g_f's pixels to where their surface was in g_{f-1}), through the Burley backend's frame loop
(:meth:`ssskit.backends.Backend.adaptive_runner`, :mod:`ssskit.backends.adaptive_plan`; the history and
the counts stay with the backend, on the device for gl):

1. ``runner.load(g_f, m_f)``: adaptive: the *estimate*, the history reprojected (nearest, no rejection:
   Xie 2020 Sec. 4.1.5's lower bound, Eq. 18; pixels whose previous position is off-screen or was not
   SSS, channel 3 = 0, take the disocclusion initialisation, Eqs. 16-17), then Eqs. 13-15 and the clamp
   give the counts; fixed: ``counts = spp`` on the SSS mask (``runner.set_counts``);
2. ``runner.sample(plan_f)``: the Burley pass with those counts (the frame number keys the random numbers);
3. adaptive: ``runner.update()``, the history update (Eqs. 8, 6, 9) on the pre-TAA output, so the
   sampler is the same with TAA on or off (it never reads the TAA's state);
4. ``sss_f = runner.result()``; ``image_f = g_f.composite(sss_f)``; with TAA, ``taa_f =
   TemporalAA.resolve(image_f, m_f, valid_f)`` with ``valid_f`` the depth test
   :func:`~ssskit.screenspace.taa.reprojection_valid`.

The G-buffers are cached per frame (``cache_dir("gbuffers")``), the references by
:func:`ssskit.pipeline.burley.burley_reference` (``cache_dir("reference")``).
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..cache import cache_dir
from ..errors import PassError, SettingsError
from ..io import atomic_output
from ..metrics import region_metrics
from ..screenspace import BurleySettings, Camera, GBuffer, motion_vectors
from ..screenspace.adaptive import AVAILABLE, LUMA_709, AdaptiveSettings, new_history, reproject_history
from ..screenspace.taa import TAASettings, TemporalAA, reprojection_valid
from ..settings import check_int

#: bumped when the cached G-buffers' contents change
GBUFFER_VERSION = 1


def _gbuffer_path(key: dict):
    digest = hashlib.sha1(json.dumps({**key, "v": GBUFFER_VERSION}, sort_keys=True).encode()).hexdigest()[:16]
    return cache_dir("gbuffers") / f"{key['scene']}-{key['frame']}-{digest}.npz"


def _save_gbuffer(path, gb: GBuffer) -> None:
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, diffuse=gb.diffuse, albedo=gb.albedo, depth=gb.depth, profile_id=gb.profile_id,
                     specular=gb.specular, normal=gb.normal,
                     camera=np.array(json.dumps(gb.camera.to_dict())), meta=np.array(json.dumps(gb.meta)),
                     materials=np.array(json.dumps(list(gb.materials))))


def _load_gbuffer(path) -> GBuffer | None:
    try:
        with np.load(path) as z:
            return GBuffer(diffuse=z["diffuse"], albedo=z["albedo"], depth=z["depth"], profile_id=z["profile_id"],
                           camera=Camera.from_dict(json.loads(str(z["camera"]))), specular=z["specular"],
                           normal=z["normal"], materials=tuple(json.loads(str(z["materials"]))),
                           meta=json.loads(str(z["meta"])))
    except (OSError, ValueError, KeyError):  # a damaged cache entry is rendered again
        return None


def sequence_gbuffers(scene: str, material, frames: int, first: int = 0, *, width: int = 160, height: int = 120,
                      spp: int = 64, seed: int = 0, static: bool = False, use_cache: bool = True,
                      progress: Callable[[str], None] | None = None) -> list[GBuffer]:
    """G-buffers of frames ``first .. first + frames - 1`` of the built-in ``scene`` along its camera and
    light paths (:func:`ssskit.scenes.render_sequence`), each rendered once and cached as ``.npz``
    keyed by everything that shapes it. ``material``: a material name or object (its Burley albedo
    and eta); ``static``: every frame is frame ``first`` (a still camera and light)."""
    from ..materials import MATERIALS
    from ..scenes import render_gbuffer
    from ..scenes.scenes import SCENES, check_size, check_spp
    from ..screenspace.burley import burley_params_for_material

    SCENES.get(scene)
    check_size(width, height)
    check_spp(spp)
    frames = check_int("frames", frames, 1, 100_000)
    first = check_int("first", first, 0, 2**31 - 1 - frames)
    mat = MATERIALS.get(material) if isinstance(material, str) else material
    if not hasattr(mat, "eta"):
        raise SettingsError(f"the Burley pass needs a homogeneous material; {getattr(mat, 'name', mat)!r} is not one")
    albedo = np.clip(burley_params_for_material(mat).albedo, 0.0, 1.0)
    out: list[GBuffer] = []
    cache: dict[int, GBuffer] = {}
    for f in range(frames):
        frame = first if static else first + f
        if frame in cache:
            out.append(cache[frame])
            continue
        key = {"scene": scene, "frame": int(frame), "albedo": [float(a) for a in albedo], "eta": float(mat.eta),
               "size": [int(width), int(height)], "spp": int(spp), "seed": int(seed), "material": mat.name}
        path = _gbuffer_path(key)
        gb = _load_gbuffer(path) if use_cache and path.is_file() else None
        if gb is None:
            if progress is not None:
                progress(f"G-buffer {scene} frame {frame} ({width}x{height}, {spp} spp, Mitsuba)")
            gb = render_gbuffer(scene, albedo, eta=mat.eta, width=width, height=height, spp=spp, seed=seed,
                                frame=frame, material=mat.name)
            if use_cache:
                _save_gbuffer(path, gb)
        cache[frame] = gb
        out.append(gb)
    return out


@dataclass(frozen=True)
class SequenceReference:
    """A frame's converged reference: ``sss`` (H, W, 3), the mean of two independent runs of the exact
    sampler without mips at ``spp`` / 2 samples each (:func:`ssskit.pipeline.burley.burley_reference`,
    cached), and ``stderr`` (H, W, 3), its standard error estimated from the two halves,
    |a - b| / 2 (the variance of the mean of two independent estimates is (a - b)^2 / 4 in expectation)."""

    sss: np.ndarray
    stderr: np.ndarray
    spp: int


def sequence_references(gbuffers: Sequence[GBuffer], params, spp: int = 8192, seed: int = 1000,
                        backend: str = "numba", use_cache: bool = True,
                        progress: Callable[[str], None] | None = None) -> list[SequenceReference]:
    """One :class:`SequenceReference` per G-buffer (identical G-buffers share theirs)."""
    from .burley import burley_reference

    spp = check_int("spp", spp, 2, 2 * 65536)
    half = spp // 2
    out: list[SequenceReference] = []
    seen: dict[int, SequenceReference] = {}
    for i, gb in enumerate(gbuffers):
        if id(gb) in seen:
            out.append(seen[id(gb)])
            continue
        if progress is not None:
            progress(f"reference {i + 1}/{len(gbuffers)} ({spp} spp, exact sampler, no mips; cached)")
        a = burley_reference(gb, params, spp=half, seed=seed, backend=backend, use_cache=use_cache).astype(np.float64)
        b = burley_reference(gb, params, spp=half, seed=seed + 1, backend=backend,
                             use_cache=use_cache).astype(np.float64)
        ref = SequenceReference(sss=(0.5 * (a + b)).astype(np.float32), stderr=np.abs(a - b) / 2.0, spp=2 * half)
        seen[id(gb)] = ref
        out.append(ref)
    return out


@dataclass
class SequenceRun:
    """Per-frame results of :func:`run_sequence`: ``mean_spp``, ``psnr`` (the pass's frame against its
    reference, composite inside the SSS mask), ``psnr_taa`` (after TAA; None without TAA), ``ms`` (the
    Burley pass: prefilter + sampling), ``ms_update`` (the guiding phase: estimate with its reprojection,
    and history update; 0 for a fixed count) and ``ms_frame`` (the wall time of the whole loop: guiding
    phase, pass, upload and readback; :func:`run_sequence`), each a list over frames; ``psnr_gray`` and
    ``psnr_gray_taa`` the same as :func:`display_psnr`; ``samples`` the total samples taken; ``last`` /
    ``last_taa`` the last frame's composite images; ``counts`` (frames, H, W) int32 when kept."""

    adaptive: AdaptiveSettings | None
    spp: int | None
    taa: TAASettings | None
    mean_spp: list = field(default_factory=list)
    psnr: list = field(default_factory=list)
    psnr_taa: list = field(default_factory=list)
    psnr_gray: list = field(default_factory=list)
    psnr_gray_taa: list = field(default_factory=list)
    ms: list = field(default_factory=list)
    ms_update: list = field(default_factory=list)
    ms_frame: list = field(default_factory=list)
    samples: int = 0
    last: np.ndarray | None = None
    last_taa: np.ndarray | None = None
    counts: np.ndarray | None = None

    def rows(self) -> list[dict]:
        """The per-frame records (frame index from 0)."""
        return [{"frame": f, "mean_spp": self.mean_spp[f], "psnr": self.psnr[f],
                 "psnr_taa": self.psnr_taa[f] if self.taa is not None else None, "psnr_gray": self.psnr_gray[f],
                 "psnr_gray_taa": self.psnr_gray_taa[f] if self.taa is not None else None, "ms": self.ms[f],
                 "ms_update": self.ms_update[f], "ms_frame": self.ms_frame[f]} for f in range(len(self.mean_spp))]

    def final_psnr(self, last: int = 20, taa: bool = True, gray: bool = False) -> float:
        """The sequence's final PSNR: the mean over its last ``last`` frames of the per-frame PSNR (after
        TAA when it ran and ``taa``; the display gray-scale PSNR with ``gray``; frames without a
        reference are left out)."""
        if gray:
            series = self.psnr_gray_taa if (taa and self.taa is not None) else self.psnr_gray
        else:
            series = self.psnr_taa if (taa and self.taa is not None) else self.psnr
        vals = [v for v in series[-last:] if v is not None]
        return float(np.mean(vals)) if vals else float("nan")


def _psnr(reference, image, mask) -> float | None:
    if reference is None or not mask.any():
        return None
    return region_metrics(reference, image, mask, False)["psnr"]


def display_psnr(reference, image, mask, gamma: float = 2.2) -> float | None:
    """Gray-scale PSNR on the display (Xie 2020 Sec. 6 reports "gray-scale PSNR"), inside ``mask``: both
    images mapped by g(x) = clip(Y(x) / P, 0, 1)^(1/gamma), Y the BT.709 luminance and P the reference's
    largest luminance inside the mask (so the reference spans [0, 1] like a display frame), then
    PSNR = 20 log10(1 / RMSE). This is the scale the sampler's history measures (gamma-corrected
    luminance, Sec. 4.1.2), where dark pixels weigh as much as on a screen; the linear ``psnr`` is
    dominated by the brightest pixels. None without a reference or mask."""
    if reference is None or not np.any(mask):
        return None
    w = np.asarray(LUMA_709)
    y_ref = np.asarray(reference, np.float64)[mask] @ w
    y_img = np.asarray(image, np.float64)[mask] @ w
    peak = float(y_ref.max())
    if peak <= 0:
        return None
    g = 1.0 / gamma
    err = np.sqrt(np.mean((np.clip(y_ref / peak, 0, 1) ** g - np.clip(y_img / peak, 0, 1) ** g) ** 2))
    return float("inf") if err == 0 else float(-20.0 * np.log10(err))


def run_sequence(gbuffers: Sequence[GBuffer], params, burley: BurleySettings | None = None,
                 adaptive: AdaptiveSettings | None = None, spp: int | None = None, taa: TAASettings | None = None,
                 references: Sequence[SequenceReference] | None = None, disocclusion_spp: int | None = None,
                 keep_counts: bool = False,
                 on_frame: Callable[..., None] | None = None,
                 progress: Callable[[str], None] | None = None) -> SequenceRun:
    """The Burley pass over ``gbuffers`` (module docstring) with ``adaptive`` counts or a fixed ``spp``
    (exactly one of them), ``burley`` its sampler settings (frame f uses frame number burley.frame + f),
    ``taa`` the TAA settings or None (no TAA), ``references`` one per G-buffer or None (no PSNR).

    Both run through the Burley backend's frame loop, :meth:`~ssskit.backends.Backend.adaptive_runner`
    (:mod:`ssskit.backends.adaptive_plan`): per frame ``load`` (the G-buffer and the motion; the
    *estimate*), ``sample`` (the Burley pass), ``update`` (the history update and the next counts),
    ``result``. The history and the counts stay with the backend (on gl on the device); only the result
    (for the TAA and the PSNR) and the counts (for the statistics) are read back. The fixed count loads
    without the estimate, sets ``spp`` on the mask and skips the update.

    ``disocclusion_spp`` (adaptive only): the count of pixels inside the mask whose reprojected history
    is missing (channel 3 = 0: new, newly SSS, or off-screen before; the first frame everywhere). None is
    Xie 2020 Sec. 4.1.4 as printed: n = max(n_hat, beta) = b_min there. A larger value is this
    package's variant (not the paper's): a newly visible pixel has no TAA history either, so its
    b_min-sample noise reaches the screen unfiltered; the history is still initialised by Eqs. 16-17
    (Eq. 8 records the count actually taken).
    ``on_frame(f, image, image_taa, counts)`` is called after every frame (``image_taa`` None without TAA).

    Times per frame: ``ms`` the Burley pass (prefilter + sampling) and ``ms_update`` the guiding phase
    (estimate + update), from the runner's ``times`` (GPU time or wall time around glFinish on gl);
    ``ms_frame`` the wall time of the whole loop (load with its upload and estimate, pass, update,
    the result's readback). Outside ``ms_frame``: the counts' readback for the statistics, the fixed
    count's (or the variant's) upload, motion vectors, TAA and metrics."""
    from ..backends import get_backend
    from ..backends.adaptive_plan import as_plan
    from ..backends.plan import profile_ids
    from ..screenspace.burley import burley_backend, burley_plan_for

    b = BurleySettings() if burley is None else burley
    if not isinstance(b, BurleySettings):
        raise SettingsError(f"burley must be BurleySettings, got {type(b).__name__}")
    if (adaptive is None) == (spp is None):
        raise SettingsError("give adaptive settings or a fixed spp, exactly one of them")
    if adaptive is not None and not isinstance(adaptive, AdaptiveSettings):
        raise SettingsError(f"adaptive must be AdaptiveSettings, got {type(adaptive).__name__}")
    if spp is not None:
        spp = check_int("spp", spp, 1, 65536)
    if disocclusion_spp is not None:
        if adaptive is None:
            raise SettingsError("disocclusion_spp applies to the adaptive counts")
        disocclusion_spp = check_int("disocclusion_spp", disocclusion_spp, adaptive.b_min, adaptive.b_max)
    if taa is not None and not isinstance(taa, TAASettings):
        raise SettingsError(f"taa must be TAASettings, got {type(taa).__name__}")
    gbs = list(gbuffers)
    if not gbs or not all(isinstance(g, GBuffer) for g in gbs):
        raise PassError("run_sequence needs a non-empty sequence of GBuffers")
    shape = gbs[0].shape
    if any(g.shape != shape for g in gbs):
        raise PassError("the G-buffers of a sequence must share one size")
    if references is not None and len(references) != len(gbs):
        raise PassError(f"{len(references)} references for {len(gbs)} frames")
    if b.frame + len(gbs) - 1 > 2**31 - 1:
        raise SettingsError(f"{len(gbs)} frames from frame {b.frame} pass the last frame number 2^31 - 1")
    backend = burley_backend(b.backend)  # the Burley pass's backend runs the guiding phase too
    run = SequenceRun(adaptive=adaptive, spp=spp, taa=taa)
    resolver = TemporalAA(taa) if taa is not None else None
    counts_all = np.zeros((len(gbs), *shape), np.int32) if keep_counts else None
    runner = backend.adaptive_runner(as_plan(adaptive if adaptive is not None else AdaptiveSettings()),
                                     new_history(*shape))
    prev: GBuffer | None = None
    prev_inside: np.ndarray | None = None
    try:
        for f, gb in enumerate(gbs):
            if progress is not None:
                progress(f"frame {f + 1}/{len(gbs)}")
            mask = gb.mask
            motion = None  # the camera's motion (also the TAA's input), outside the loop's time
            if prev is not None and not np.array_equal(prev.camera.world_to_camera, gb.camera.world_to_camera):
                motion = motion_vectors(gb.depth, gb.camera, prev.camera)
            cam = gb.camera
            plan = burley_plan_for(params, profile_ids(gb.profile_id), cam.fx, cam.fy, b.replace(frame=b.frame + f))
            slots = plan.slot_map(gb.profile_id)
            inside = slots > 0
            before = {p: len(v) for p, v in runner.times.items()}
            t0 = time.perf_counter()
            runner.load(gb.diffuse, gb.depth_mm, slots, motion, estimate=adaptive is not None)
            t1 = time.perf_counter()
            if adaptive is None:
                counts = np.where(inside, spp, 0)
                runner.set_counts(counts)
            else:
                counts = runner.counts()
                if disocclusion_spp is not None:
                    counts[inside & ~_had_history(prev_inside, motion, shape)] = disocclusion_spp
                    runner.set_counts(counts)
            t2 = time.perf_counter()
            runner.sample(plan)
            if adaptive is not None:
                runner.update()
            sss = runner.result()
            t3 = time.perf_counter()
            phase = {p: sum(v[before[p]:]) for p, v in runner.times.items()}
            image = gb.composite(sss)
            ref = None if references is None else gb.composite(references[f].sss)
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
                if prev is not None:
                    valid = reprojection_valid(gb.depth, gb.camera, prev.depth, prev.camera)
                out_taa = resolver.resolve(image, motion, valid)
                run.psnr_taa.append(_psnr(ref, out_taa, mask))
                run.psnr_gray_taa.append(display_psnr(ref, out_taa, mask))
            else:
                run.psnr_taa.append(None)
                run.psnr_gray_taa.append(None)
            if counts_all is not None:
                counts_all[f] = counts
            if on_frame is not None:
                on_frame(f, image, out_taa, counts)
            run.last, run.last_taa = image, out_taa
            prev, prev_inside = gb, inside
    finally:
        runner.release()
    run.counts = counts_all
    return run


def _had_history(prev_inside: np.ndarray | None, motion, shape) -> np.ndarray:
    """(H, W) bool: where the reprojected history holds history (channel 3 > 0). After an update the
    history's channel 3 is the frame's SSS mask (:mod:`ssskit.backends.adaptive_plan` step 2), so this
    is that mask fetched like the history (step 1: nearest, no rejection, off-screen: none); nothing
    before the first frame."""
    if prev_inside is None:
        return np.zeros(shape, bool)
    h = np.zeros((*shape, 4), np.float32)
    h[..., AVAILABLE] = prev_inside
    return reproject_history(h, motion)[..., AVAILABLE] > 0


__all__ = ["GBUFFER_VERSION", "SequenceReference", "SequenceRun", "display_psnr", "run_sequence", "sequence_gbuffers",
           "sequence_references"]
