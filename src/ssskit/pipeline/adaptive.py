"""An adaptive run: the Burley pass over frames with the variance-guided sample counts of Xie et al. 2020
Sec. 4.1, beside the same loop at a fixed b_max spp, through the library's one frame loop
(:func:`ssskit.screenspace.frames.run_frames`), as ``ssskit render --pass burley-adaptive`` runs it.

    >>> from ssskit.pipeline import AdaptivePass, RenderSettings, render
    >>> r = render("slab", RenderSettings(width=96, height=72, pass_=AdaptivePass(frames=8)))  # doctest: +SKIP
    >>> r.to_dict()["final_psnr_taa"]                                                            # doctest: +SKIP

``settings.pass_`` is an :class:`~ssskit.pipeline.settings.AdaptivePass`. Two kinds of run:

* **moving** (the default on a built-in scene): the frames follow the scene's camera and light paths from
  ``settings.frame`` (:func:`ssskit.pipeline.sequence.sequence_gbuffers`, cached); each frame is compared
  with its converged reference (exact sampler, no mips, ``limit_spp`` samples in two cached halves that
  give its standard error: :func:`ssskit.pipeline.sequence.sequence_references`), and the adaptive loop
  and the fixed b_max loop run through the same TAA; ``disocclusion_spp`` sets the count where the
  history is missing. A moving run has no single-frame ground truths: ``reference`` must be off and the
  reference options and ``exact`` at their defaults;
* **static** (``static = true``, and always for a G-buffer): one frame at a fixed b_max spp gives the
  G-buffer, the pass's exact limit (:func:`ssskit.pipeline.burley_frame.burley_exact`) and the fixed-count
  comparison (:func:`ssskit.pipeline.burley_frame.render_burley`, with the path-traced reference when
  asked); then every frame of the adaptive loop, and their average, against the limit.

With the transmittance pass (``settings.transmission``, as for one frame: ``auto`` where the G-buffer has
the light layers, ``on`` renders the scene's G-buffers with them), every frame's blurred diffuse layer
gets its G-buffer's transmitted light before the albedo multiply (:func:`ssskit.screenspace.frames.run_frames`
step 4; computed once per G-buffer), and the comparisons carry the same light: the static run's exact
limit (as :func:`~ssskit.pipeline.burley_frame.render_burley` adds it), the moving run's converged
references. The sample counts are those without it (the guiding phase sees the reflectance pass).

``on_frame`` receives every adaptive frame (:class:`AdaptiveFrame`: the frame number, the composite
before and after TAA, the counts, and the sequence's tone-map peak) so a caller can write it
(``ssskit render --frames-dir``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..backends import warm_up_in_background
from ..errors import SettingsError
from ..quantities import FRAME, check_instance, refuse_unused
from ..io import check_distinct, save_image
from ..metrics import region_metrics
from ..screenspace import AdaptiveSettings, BurleyParams, BurleySettings, GBuffer
from ..screenspace.frames import Frame, FrameRun, run_frames
from ..screenspace.taa import TAASettings
from .burley_frame import plan_burley, render_burley
from .frame import BurleyInput, Progress, SceneInput, ScenePlan, finite, metric_lines
from .sequence import sequence_gbuffers, sequence_references
from .settings import AdaptivePass, BurleyPass, RenderSettings
from .transmission import TransmissionInfo, material_of_ids, transmission_light, transmission_passes

#: the history's format, as the JSON states it
HISTORY_FORMAT = "(H, W, 4) float32: n_bar, mu, sigma^2, available"
#: the moving run's final PSNRs are the mean over its last frames (at most this many)
FINAL_FRAMES = 20


@dataclass(frozen=True)
class AdaptiveFrame:
    """One frame of an adaptive run, for a writer: ``number`` (the frame number), ``image`` and
    ``image_taa`` (the composite before and after TAA; None without TAA), ``counts`` ((H, W) samples per
    pixel), ``peak`` (one tone-map peak for the whole sequence: the 99.5th percentile of its reference)
    and ``b_max`` (the budget's top, the heatmap's scale)."""

    number: int
    image: np.ndarray
    image_taa: np.ndarray | None
    counts: np.ndarray
    peak: float
    b_max: int


FrameCallback = Callable[[AdaptiveFrame], None]


@dataclass
class AdaptiveResult:
    """An adaptive run: ``run`` (the adaptive loop's :class:`~ssskit.screenspace.frames.FrameRun`) and
    ``fixed`` (the fixed b_max loop's, moving; or the fixed frame's
    :class:`~ssskit.pipeline.burley_frame.BurleyResult`, static), the per-frame ``rows``, ``metrics``
    (static: the last frame and the average against the limit, and the path trace), the written ``image``
    and its extra EXR ``layers``; ``gbuffer`` (static) and ``gbuffers`` (moving)."""

    scene: str
    settings: RenderSettings
    material: Any
    static: bool
    run: FrameRun
    fixed: Any
    rows: list[dict[str, Any]]
    image: np.ndarray
    layers: dict[str, np.ndarray]
    gbuffer: GBuffer
    gbuffers: list[GBuffer] = field(default_factory=list)
    metrics: dict[str, Any] = field(default_factory=dict)
    reference: dict[str, Any] = field(default_factory=dict)
    source: Path | None = None
    transmission: TransmissionInfo = field(default_factory=lambda: TransmissionInfo("off", False))

    @property
    def pass_(self) -> AdaptivePass:
        assert isinstance(self.settings.pass_, AdaptivePass)
        return self.settings.pass_

    def save(self, path: str | Path) -> None:
        """Write the image: ``.exr`` (linear, with :attr:`layers`) or ``.png`` (tone-mapped); never over the
        G-buffer file it was rendered from."""
        check_distinct(path, self.source, what="output image")
        save_image(path, self.image, self.layers, what="output image")

    def _adaptive_dict(self) -> dict[str, Any]:
        a = self.pass_.adaptive_settings()
        out = {**a.to_dict(), "sigma0": math.sqrt(a.sigma0_sq), "frames": self.pass_.frames, "history": HISTORY_FORMAT}
        if not self.static:
            out["disocclusion_spp"] = self.pass_.disocclusion_spp if self.pass_.disocclusion_spp is not None else a.b_min
        return out

    def _finals(self, r: FrameRun) -> dict[str, Any]:
        last, taa_on = min(FINAL_FRAMES, self.pass_.frames), self.pass_.taa
        return {"final_psnr_taa": r.final_psnr(last) if taa_on else None, "final_psnr": r.final_psnr(last, taa=False),
                "final_psnr_gray_taa": r.final_psnr(last, gray=True) if taa_on else None,
                "final_psnr_gray": r.final_psnr(last, taa=False, gray=True), "total_samples": r.samples,
                "mean_spp": float(np.mean(r.mean_spp)), "median_ms": float(np.median(r.ms)),
                "median_ms_update": float(np.median(r.ms_update)), "median_ms_frame": float(np.median(r.ms_frame)),
                "total_ms_frame": float(np.sum(r.ms_frame))}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the run's settings, its per-frame ``frames`` records and its summary (non-finite
        numbers become None)."""
        b = self.settings.burley_settings()
        burley = {k: v for k, v in b.to_dict().items() if k != "spp"}
        taa = TAASettings().to_dict() if self.pass_.taa else None
        h, w = self.gbuffer.shape
        if self.static:
            data = self.fixed.to_dict()
            data.update({"pass": "burley-adaptive", "settings": self.settings.to_dict(), "burley": burley,
                         "metrics": finite(self.metrics),
                         "adaptive": self._adaptive_dict(), "static": True, "taa": taa, "frames": self.rows,
                         "mean_spp": float(np.mean([r["mean_spp"] for r in self.rows])),
                         "total_samples": int(self.run.samples),
                         "fixed": {"spp": self.pass_.b_max, "metrics": finite(self.fixed.metrics)}})
            return finite(data)
        b_max = self.pass_.b_max
        fixed_rows = [{**r, "frame": r["frame"] + self.settings.frame} for r in self.fixed.rows()]
        return finite({"scene": self.scene, "pass": "burley-adaptive", "static": False,
                       "material": getattr(self.material, "name", str(self.material)), "size": [int(w), int(h)],
                       "settings": self.settings.to_dict(), "burley": burley, "adaptive": self._adaptive_dict(),
                       "taa": taa, "reference": self.reference, "final_frames": min(FINAL_FRAMES, self.pass_.frames),
                       "transmission": self.transmission.to_dict(),
                       "frames": self.rows, **self._finals(self.run),
                       "fixed": {"spp": b_max, **self._finals(self.fixed), "frames": fixed_rows},
                       "sample_ratio": self.fixed.samples / self.run.samples if self.run.samples else None})

    def lines(self) -> list[str]:
        """The human-readable summary ``ssskit render`` prints."""
        p, b = self.pass_, self.settings.burley_settings()
        a = p.adaptive_settings()
        h, w = self.gbuffer.shape
        mode = (f"{b.sampler} sampler, {'mips' if b.mips else 'no mips'}, {w}x{h}, {b.backend} backend, "
                f"TAA {'on' if p.taa else 'off'}")
        if self.static:
            out = [f"# {self.scene}: Burley adaptive, sigma0 {math.sqrt(a.sigma0_sq):.4g} (sigma0^2 {a.sigma0_sq:.3g}), "
                   f"kappa {a.kappa:g}, budget {a.b_min}:{a.b_max}, {p.frames} frames, {mode}"]
            spp = [r["mean_spp"] for r in self.rows]
            out.append(f"mean spp per frame: first {spp[0]:.1f}, last {spp[-1]:.1f}, average {np.mean(spp):.1f} "
                       f"(fixed: {a.b_max}); median ms: pass {np.median(self.run.ms):.3g}, "
                       f"update {np.median(self.run.ms_update):.3g}")
            out += metric_lines(self.metrics, width=16)
            out += metric_lines(self.fixed.metrics, prefix=f"fixed {a.b_max} spp vs ")
            out.append(self.transmission.line())
            return out
        last = min(FINAL_FRAMES, p.frames)
        out = [f"# {self.scene}: Burley adaptive along the camera/light path, frames "
               f"{self.settings.frame}..{self.settings.frame + p.frames - 1}, sigma0^2 {a.sigma0_sq:.3g}, "
               f"kappa {a.kappa:g}, budget {a.b_min}:{a.b_max}, {mode}",
               f"# reference per frame: exact sampler, {self.reference['spp']} spp, no mips (noise RMS <= "
               f"{self.reference['noise_rms_max']:.3g})"]
        for name, r in (("adaptive", self.run), (f"fixed {a.b_max} spp", self.fixed)):
            taa_txt = f", with TAA {r.final_psnr(last):.2f} ({r.final_psnr(last, gray=True):.2f})" if p.taa else ""
            out.append(f"{name:14s} mean spp {np.mean(r.mean_spp):6.2f}  samples {r.samples}  final PSNR, gray in () "
                       f"(last {last} frames): {r.final_psnr(last, taa=False):.2f} "
                       f"({r.final_psnr(last, False, True):.2f}){taa_txt} dB  median ms: pass {np.median(r.ms):.3g}, "
                       f"guiding {np.median(r.ms_update):.3g}, whole loop {np.median(r.ms_frame):.3g}")
        ratio = self.fixed.samples / self.run.samples if self.run.samples else float("nan")
        out.append(f"samples: fixed / adaptive = {ratio:.2f}x")
        out.append(self.transmission.line())
        return out


def _peak(like: np.ndarray) -> float:
    finite_values = np.asarray(like)[np.isfinite(like)]
    return float(np.percentile(finite_values, 99.5)) if finite_values.size else 1.0


def _some(say: Progress | None, frames: int, label: str) -> Progress | None:
    """``say`` for every frames // 8-th "frame k/N" message of the loop, prefixed with ``label``."""
    if say is None:
        return None
    every = max(1, frames // 8)
    return lambda msg: say(f"{label} {msg}") if (int(msg.split()[1].split("/")[0]) - 1) % every == 0 else None


def _writer(on_frame: FrameCallback | None, peak: float, b_max: int) -> Callable[[Frame], None] | None:
    if on_frame is None:
        return None
    return lambda fr: on_frame(AdaptiveFrame(fr.number, fr.image, fr.image_taa, fr.counts, peak, b_max))


class _Through:
    """The transmitted light of each G-buffer of a run (:func:`~ssskit.pipeline.transmission.transmission_light`),
    computed once per G-buffer object and kept: the last one's radiance and info."""

    def __init__(self, plan: ScenePlan, settings: RenderSettings, say: Progress | None) -> None:
        self.plan, self.settings = plan, settings
        self.say: Progress = say or (lambda msg: None)
        self.done: dict[int, tuple[GBuffer, np.ndarray]] = {}
        self.radiance: np.ndarray | None = None
        self.info = TransmissionInfo(settings.transmission, False)

    def __call__(self, gb: GBuffer) -> np.ndarray:
        hit = self.done.get(id(gb))
        if hit is not None and hit[0] is gb:
            return hit[1]
        added, self.radiance, self.info = transmission_light(
            gb, self.settings, material_of_ids(gb, self.plan.materials, self.plan.material), self.say)
        self.done[id(gb)] = (gb, added)
        return added


def plan_adaptive(scene: SceneInput, settings: RenderSettings,
                  params: BurleyInput | None = None) -> tuple[ScenePlan, BurleyInput, bool]:
    """Check what :func:`render_adaptive` needs, doing no work (the scene, the material, the backend, the
    moving run's limits); returns (scene plan, params, static)."""
    check_instance(settings, RenderSettings, 'settings', SettingsError)  # (a dict was an AttributeError)
    p = settings.pass_as(AdaptivePass, "burley-adaptive")  # (what render_adaptive runs)
    plan, params = plan_burley(scene, settings, params)
    static = p.static or plan.builtin is None
    # a static run (a G-buffer or a mesh scene is always static) has no new pixels and compares with the exact limit
    refuse_unused([k for k in ("limit_spp", "disocclusion_spp") if static and getattr(p, k) is not None], "camera",
                  ("moving",), "static", SettingsError)
    FRAME.check(settings.frame + p.frames - 1, f"the last frame ({p.frames} frames from frame {settings.frame})",
                SettingsError)
    # a moving run compares each frame with its converged Burley reference of limit_spp spp: the one-frame
    # comparisons (a path-traced reference, the exact convolution) apply to a static run only
    d = RenderSettings()
    refuse_unused([k for k in ("reference", "reference_spp", "reference_max_spp", "reference_rel_se", "exact")
                   if not static and getattr(settings, k) != getattr(d, k)], "camera", ("static",), "moving",
                  SettingsError)
    return plan, params, static


def render_adaptive(scene: SceneInput = "slab", settings: RenderSettings | None = None, *,
                    progress: Progress | None = None, params: BurleyInput | None = None,
                    on_frame: FrameCallback | None = None) -> AdaptiveResult:
    """Run the adaptive pass of ``settings`` on ``scene`` (module docstring): static or moving, the fixed
    b_max comparison, every frame to ``on_frame``; ``params`` (every profile id) instead of the settings'
    or the material's Burley parameters."""
    settings = RenderSettings(pass_=AdaptivePass()) if settings is None else settings
    plan, params, static = plan_adaptive(scene, settings, params)
    p = settings.pass_
    assert isinstance(p, AdaptivePass)
    a = p.adaptive_settings()
    b = settings.burley_settings()
    taa = TAASettings() if p.taa else None
    # the passes' kernels compile (a fresh machine: seconds, one thread) while Mitsuba renders the G-buffers
    warm_up_in_background(b.backend, ["burley", "adaptive"] + transmission_passes(settings, plan.transmission))
    if static:
        return _static(scene, plan, settings, p, a, b, params, taa, progress, on_frame)
    assert plan.builtin is not None  # a moving run has a built-in scene (plan_adaptive)
    gbs = sequence_gbuffers(plan.builtin, plan.material, p.frames, settings.frame, width=settings.width,
                            height=settings.height, spp=settings.spp, seed=settings.seed, progress=progress,
                            light_layers=plan.transmission)
    refs = sequence_references(gbs, params, spp=p.reference_spp, backend=b.backend, progress=progress)
    through = _Through(plan, settings, progress) if plan.transmission else None
    ref_sss = [r.sss if through is None else np.add(r.sss, through(g), dtype=r.sss.dtype) for g, r in zip(gbs, refs)]
    peak = _peak(gbs[0].composite(ref_sss[0]))
    run = run_frames(gbs, params, b, adaptive=a, taa=taa, references=ref_sss, disocclusion_spp=p.disocclusion_spp,
                     progress=_some(progress, p.frames, "adaptive"), on_frame=_writer(on_frame, peak, a.b_max),
                     transmission=through)
    fixed = run_frames(gbs, params, b, spp=a.b_max, taa=taa, references=ref_sss,
                       progress=_some(progress, p.frames, f"fixed {a.b_max} spp"), transmission=through)
    rows = run.rows()
    for row in rows:
        row["frame"] += settings.frame
    ref_noise = [float(np.sqrt(np.mean((g.albedo * r.stderr)[g.mask] ** 2))) if g.mask.any() else 0.0
                 for g, r in zip(gbs, refs)]
    image = run.last_taa if run.last_taa is not None else run.last
    assert image is not None and run.last is not None
    layers = {"frame": run.last, "reference": gbs[-1].composite(ref_sss[-1])}
    if through is not None:
        through(gbs[-1])  # (kept: the last frame's radiance and info)
        assert through.radiance is not None
        layers["transmission"] = through.radiance
    return AdaptiveResult(plan.label, settings, plan.material, False, run, fixed, rows, image, layers, gbs[-1],
                          gbuffers=gbs, reference={"spp": refs[0].spp, "sampler": "exact", "mips": False,
                                                   "noise_rms_max": max(ref_noise)},
                          transmission=through.info if through is not None else TransmissionInfo(settings.transmission,
                                                                                                   False))


def _static(scene: SceneInput, plan: ScenePlan, settings: RenderSettings, p: AdaptivePass, a: AdaptiveSettings,
            b: BurleySettings, params: BurleyInput, taa: TAASettings | None, progress: Progress | None,
            on_frame: FrameCallback | None) -> AdaptiveResult:
    """The static run (module docstring): one fixed b_max frame with the ground truths, then the adaptive
    frames against the pass's exact limit."""
    sampling = {f.name: getattr(p, f.name) for f in dataclasses.fields(BurleyPass) if f.name != "spp"}
    one = settings.replace(pass_=BurleyPass(**sampling, spp=a.b_max))
    fixed = render_burley(scene, one, progress=progress, params=params)
    gb, mask = fixed.gbuffer, fixed.gbuffer.mask
    exact = None if fixed.exact is None else gb.composite(fixed.exact)
    peak = _peak(exact if exact is not None else gb.composite(fixed.sss))
    rows: list[dict[str, Any]] = []
    write = _writer(on_frame, peak, a.b_max)

    def record(fr: Frame) -> None:
        psnr = psnr_taa = None
        if exact is not None and mask.any():
            psnr = region_metrics(exact, fr.image, mask, False)["psnr"]
            if fr.image_taa is not None:
                psnr_taa = region_metrics(exact, fr.image_taa, mask, False)["psnr"]
        rows.append({"frame": fr.number, "mean_spp": float(fr.counts[mask].mean()) if mask.any() else 0.0,
                     "psnr": psnr, "psnr_taa": psnr_taa})
        if write is not None:
            write(fr)

    through = _Through(plan, settings, progress) if fixed.transmission.ran else None
    run = run_frames([gb] * p.frames, fixed.params, b, adaptive=a, taa=taa, accumulate=True, on_frame=record,
                     progress=_some(progress, p.frames, "adaptive"), transmission=through)
    for row, ms, ms_update in zip(rows, run.ms, run.ms_update):
        row["ms"], row["ms_update"] = ms, ms_update
    assert run.last_sss is not None and run.mean is not None
    image = gb.composite(run.last_sss)
    metrics: dict[str, Any] = {}
    if exact is not None:
        metrics["exact_2d"] = region_metrics(exact, image, mask, settings.perceptual)
        metrics["average_exact_2d"] = region_metrics(exact, gb.composite(run.mean.astype(np.float32)), mask, False)
    if fixed.reference is not None:
        metrics["path_traced"] = region_metrics(fixed.reference, image, mask, settings.perceptual)
    final = dataclasses.replace(fixed, sss=run.last_sss, image=image)
    return AdaptiveResult(fixed.scene, settings, fixed.material, True, run, fixed, rows, image, final.layers(), gb,
                          metrics=metrics, source=fixed.source, transmission=fixed.transmission)


__all__ = ["AdaptiveFrame", "AdaptiveResult", "FrameCallback", "plan_adaptive", "render_adaptive"]
