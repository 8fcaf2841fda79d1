"""Xie et al. 2020 Figs. 2 and 3: the circle scenario of the variance-guided adaptive sampler (Sec. 4.1.3-4.1.4).

One pixel integrates uniform irradiance 4/pi inside a circle of radius 0.5 centred at (0.5, 0.5) with
uniform random samples (:func:`ssskit.screenspace.adaptive.circle_scenario`): b = [8, 64], alpha = 0.2,
sigma0^2 = 0.08^2, H_0 = 0, 150 frames, kappa = 0 and kappa = 1. Fig. 2 is the *cold start* (H_0 = 0
taken as history), Fig. 3 the disocclusion initialisation (Eqs. 16-17). Per kappa, two panels as the
paper has them: the estimate n_hat (Eq. 14) and the samples used n; sigma (the square root of Eq. 9)
and mu (Eq. 6).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from ..screenspace.adaptive import AdaptiveSettings, CircleRun, circle_scenario
from .plots import pyplot, save_figure

if TYPE_CHECKING:
    from ..profiles.base import RGBProfile
    from ..screenspace import BurleyParams, GBuffer
    from ..screenspace.frames import Frame
    from ..screenspace.taa import TAASettings

#: a figure's progress messages
Progress = Callable[[str], None]
_T = TypeVar("_T")

#: the paper's circle-scenario setting (Sec. 4.1.3)
CIRCLE_SIGMA0_SQ = 0.08**2
CIRCLE_FRAMES = 150
CIRCLE_KAPPAS = (0.0, 1.0)
#: the pixel shown (any seed shows the same behaviour; the tests check it over hundreds of pixels)
CIRCLE_SEED = 1


def circle_runs(disocclusion: bool, correction: str = "variance", seed: int = CIRCLE_SEED,
                pixels: int = 1) -> list[CircleRun]:
    """The circle scenario for kappa = 0 and kappa = 1 (Xie 2020 Sec. 4.1.3)."""
    return [circle_scenario(AdaptiveSettings(sigma0_sq=CIRCLE_SIGMA0_SQ, kappa=k, b_min=8, b_max=64, alpha=0.2,
                                             correction=correction),
                            CIRCLE_FRAMES, disocclusion=disocclusion, pixels=pixels, seed=seed)
            for k in CIRCLE_KAPPAS]


def plot_circle(runs: list[CircleRun], title: str, path: Path) -> list[Path]:
    """One row per run: n_hat and n per frame (left), sigma and mu per frame (right)."""
    plt = pyplot()
    fig, axes = plt.subplots(len(runs), 2, figsize=(12, 3.2 * len(runs)), squeeze=False)
    for row, run in zip(axes, runs):
        s = run.settings
        frames = np.arange(1, run.n.shape[0] + 1)
        top = 2.0 * s.b_max
        n_hat = run.n_hat[:, 0]
        ax = row[0]
        ax.plot(frames, np.clip(n_hat, -0.5 * s.b_max, top), color="#9467bd", lw=1.0, label=r"$\hat n$ (Eq. 14)")
        ax.plot(frames, run.n[:, 0], color="#1f77b4", lw=1.4, drawstyle="steps-mid", label="samples n")
        ax.axhline(s.b_min, color="0.6", ls=":", lw=0.8)
        ax.axhline(s.b_max, color="0.6", ls=":", lw=0.8)
        ax.set_ylim(-0.5 * s.b_max, top)
        ax.set_xlabel("frame")
        ax.set_ylabel("samples per pixel")
        ax.set_title(rf"$\kappa$ = {s.kappa:g}: samples (total {int(run.n.sum())}; "
                     rf"$\hat n$ peaks at {n_hat.max():.0f}, clipped to [{-0.5 * s.b_max:g}, {top:g}])", fontsize=9)
        ax.legend(fontsize=8, loc="upper right")
        ax = row[1]
        ax.plot(frames, run.sigma[:, 0], color="#d62728", lw=1.2, label=r"$\sigma$ (Eq. 9)")
        ax.axhline(np.sqrt(s.sigma0_sq), color="#d62728", ls="--", lw=0.8, label=r"$\sigma_0$")
        ax.set_ylabel(r"$\sigma$")
        ax.set_xlabel("frame")
        ax.set_ylim(0, max(0.3, 1.1 * float(run.sigma[:, 0].max())))
        twin = ax.twinx()
        twin.plot(frames, run.mu[:, 0], color="#2ca02c", lw=1.2, label=r"$\mu$ (Eq. 6)")
        twin.axhline(1.0, color="#2ca02c", ls="--", lw=0.8)
        twin.set_ylim(0, 1.5)
        twin.set_ylabel(r"$\mu$")
        lines = ax.get_lines()[:2] + twin.get_lines()[:1]
        ax.legend(lines, [ln.get_label() for ln in lines], fontsize=8, loc="upper right")
        ax.set_title(rf"$\kappa$ = {s.kappa:g}: $\sigma$ and $\mu$ after each frame's update", fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    return [path]


def xie_fig2_cold_start(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None) -> list[Path]:
    """Xie 2020 Fig. 2: the circle scenario from a cold start (H_0 = 0), kappa = 0 and 1.

    ``profile`` is not used (the scenario integrates a uniform disk, not a diffusion profile)."""
    return plot_circle(circle_runs(False), "Xie 2020 Fig. 2, circle scenario, cold start: b = [8, 64], "
                       r"$\alpha$ = 0.2, $\sigma_0^2 = 0.08^2$, $\mathcal{H}_0$ = 0",
                       Path(out) / "xie_fig2_circle_cold_start.png")


def xie_fig3_disocclusion(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None) -> list[Path]:
    """Xie 2020 Fig. 3: the circle scenario with the disocclusion initialisation (Eqs. 16-17), kappa = 0 and 1."""
    return plot_circle(circle_runs(True), "Xie 2020 Fig. 3, circle scenario, disocclusion initialisation "
                       r"(Eqs. 16-17: $\mathcal{M}'$ = 1, $\hat\sigma^2 = \sigma_0^2$ on frame 1)",
                       Path(out) / "xie_fig3_circle_disocclusion.png")




# ---- Fig. 4, Figs. 10, 11 and 13 and Table 1 in kind: frame sequences with TAA ---------------------------
#
# The scene: a fronto-parallel SSS plane at 1080p's scale (f = 1000 px, 400 mm away: 2.5 px per mm; a
# small crop of a 1080p frame), lit on its right half (0.8) and in shadow on its left (0.05) with a lit
# disk inside the shadow, a skin-like Burley material (albedo 0.8 / 0.5 / 0.3, dmfp 2 / 1 / 0.5 mm): light
# scatters across both shadow edges, where adaptation matters, and the lit and shadowed plateaus need few
# samples. Exact sampler, no mips, so the pass's limit (:func:`ssskit.pipeline.burley_frame.burley_exact`) is the
# reference: with the prefiltered mips (Eqs. 22-23, a = 1/16) the pass carries the prefilter's own bias, about
# 0.0034 RMS (47.5 dB) on this plane whether the counts adapt or not (benchmarks/adaptive_mips_bias.py: the
# 256-frame averages of adaptive and fixed 64 spp with mips lie within one standard error of each other),
# and that bias would cap every final PSNR near 47.5 dB and hide the sampler's differences. Every frame: the
# adaptive counts (the guiding phase on ``backend``), the Burley pass, the history update, then a global TAA (:class:`ssskit.screenspace.taa.TemporalAA`, Karis 2014) that the
# sampler does not read. "Final PSNR": the mean over the last quarter of the frames of the TAA output's
# PSNR against the limit; "single-frame PSNR": the same of the pass's own frames (Xie 2020 Figs. 10-11).

#: focal length (px) and depth (mm) of the plane: 2.5 px per mm, as at 1080p (Figs. 10, 13); close: Fig. 11
PLANE_FOCAL = 1000.0
PLANE_DEPTH_MM = {"regular": 400.0, "close": 150.0}
PLANE_DMFP_MM = (2.0, 1.0, 0.5)
PLANE_ALBEDO = (0.8, 0.5, 0.3)
#: Figs. 10, 11: the grid of sigma0^2 and kappa at b_max = 64 (Xie 2020 Sec. 6)
GRID_SIGMA0_SQ = (1e-4, 3e-4, 1e-3, 3e-3)
GRID_KAPPA = (0.0, 0.2, 0.6, 1.0)
GRID_SIZE = (160, 90)
GRID_FRAMES = 24
#: Fig. 13: the two settings Xie 2020 found best for the Buddha scene
EQUAL_TIME_SETTINGS = ((1e-3, 0.2), (1e-4, 0.6))
#: Fig. 4: sigma0^2 = 0.01^2, alpha 0.2, kappa 1, b = [8, 64] (Xie 2020 Sec. 4.1.5)
FIG4_SIGMA0_SQ = 0.01**2
FIG4_SIZE = (96, 54)
FIG4_FRAMES = 64
FIG4_REPLICAS = 12


def shadow_plane(width: int, height: int, distance: str = "regular") -> GBuffer:
    """The G-buffer of the scene above (a plane of profile id 1 filling the frame)."""
    from ..screenspace import Camera, GBuffer

    yy, xx = np.mgrid[0:height, 0:width]
    diffuse = np.full((height, width, 3), 0.05, np.float32)
    diffuse[xx >= width // 2] = 0.8
    diffuse[(xx - width / 4) ** 2 + (yy - height / 2) ** 2 < (height / 5) ** 2] = 0.8
    return GBuffer(diffuse=diffuse, albedo=np.ones_like(diffuse),
                   depth=np.full((height, width), PLANE_DEPTH_MM[distance], np.float32),
                   profile_id=np.ones((height, width), np.uint32),
                   camera=Camera(width, height, PLANE_FOCAL, PLANE_FOCAL, width / 2, height / 2))


def plane_params() -> BurleyParams:
    from ..screenspace import BurleyParams

    return BurleyParams.from_dmfp(PLANE_ALBEDO, PLANE_DMFP_MM)


def _cached(name: str, key: dict[str, Any], compute: Callable[[], _T]) -> _T:
    """compute() once per (name, key, ssskit's source), kept in the ``figures`` cache (a pickle)."""
    from ..cache import source_digest
    from .stored import stored

    return stored("figures", name, {"name": name, "key": key, "source": source_digest()}, compute)


def run_plane_frames(gbuffer: GBuffer, params: BurleyParams, reference: np.ndarray | None,
                     settings: AdaptiveSettings | None, frames: int, *, spp: int = 64, backend: str = "numba",
                     seed: int = 0, taa: TAASettings | None = None, pixels: tuple[tuple[int, int], ...] = (),
                     mips: bool = False) -> dict[str, Any]:
    """``frames`` frames of the Burley pass on a still G-buffer (the library's frame loop,
    :func:`ssskit.screenspace.frames.run_frames`), adaptive (``settings``) or at a fixed ``spp`` (``settings``
    None), each followed by the global TAA (``taa``: TAASettings; default TAASettings()). Per frame:
    ``mean_spp``, ``psnr`` (the frame's blurred diffuse layer against ``reference`` over the whole image),
    ``psnr_taa`` (the TAA output), ``ms`` (the pass + guiding phase: estimate, prefilter, sampling, update;
    GPU/glFinish time on gl; a fixed count has no guiding phase), and per pixel (x, y) of ``pixels``:
    ``value`` and ``value_taa`` (the gamma-corrected luminance of the frame and of the TAA output, as the
    history records it) and ``sigma_local`` (the history's sigma, Eq. 9); ``phases``: median ms per phase;
    ``last``, ``last_taa``, ``counts`` (of the last frame). The plane's albedo is 1 and its specular 0, so
    the composite the loop's TAA resolves is the blurred diffuse layer itself."""
    from ..backends.base import PHASES
    from ..metrics import psnr
    from ..screenspace import BurleySettings
    from ..screenspace.adaptive import VAR, shading_value
    from ..screenspace.frames import run_frames
    from ..screenspace.taa import TAASettings

    assert reference is not None, "the PSNR needs a reference (the plane's pixels are square)"
    bs = BurleySettings(sampler="exact", sequence="r2", mips=mips, seed=seed, backend=backend)
    fixed = settings is None
    gamma = (AdaptiveSettings() if settings is None else settings).gamma
    out: dict[str, list[float]] = {k: [] for k in ("psnr", "psnr_taa")}
    traces: dict[tuple[int, int], dict[str, list[float]]] = {
        p: {"value": [], "value_taa": [], "sigma_local": []} for p in pixels}
    last: dict[str, Any] = {}

    def on_frame(frame: Frame) -> None:
        assert frame.image_taa is not None  # the loop runs TAA
        out["psnr"].append(psnr(reference, frame.sss))
        out["psnr_taa"].append(psnr(reference, frame.image_taa))
        if pixels:
            v, vt = shading_value(frame.sss, gamma), shading_value(frame.image_taa, gamma)
            hist = frame.history()
            for (x, y) in pixels:
                traces[(x, y)]["value"].append(float(v[y, x]))
                traces[(x, y)]["value_taa"].append(float(vt[y, x]))
                traces[(x, y)]["sigma_local"].append(float(np.sqrt(hist[y, x, VAR])))
        last.update(img=frame.sss, res=frame.image_taa, counts=frame.counts)

    run = run_frames([gbuffer] * frames, params, bs, adaptive=None if fixed else settings, spp=spp if fixed else None,
                     taa=TAASettings() if taa is None else taa, on_frame=on_frame)
    timed = ("prefilter", "sampling") if fixed else PHASES
    times = {p: (list(run.phases[p]) if p in timed else []) for p in PHASES}
    result: dict[str, Any] = {k: np.asarray(v) for k, v in out.items()}
    result["mean_spp"] = np.asarray(run.mean_spp)
    result["ms"] = np.asarray([sum(run.phases[p][f] for p in timed) for f in range(frames)])
    result["phases"] = {p: (float(np.median(v[1:] if len(v) > 1 else v)) if v else None) for p, v in times.items()}
    result["traces"] = {p: {k: np.asarray(v) for k, v in t.items()} for p, t in traces.items()}
    result.update(last=last["img"], last_taa=last["res"], counts=np.asarray(last["counts"]))
    return result


def _final(run: dict[str, Any], key: str) -> float:
    """The mean of the last quarter of the frames (at least one)."""
    v = run[key]
    return float(np.mean(v[-max(1, len(v) // 4):]))


# ---- Fig. 4 -------------------------------------------------------------------------------------------------

def fig4_pixels(width: int, height: int) -> dict[str, tuple[int, int]]:
    """On the row at a sixth of the height (above the lit disk): P1, a shadowed pixel 4 px from the shadow
    edge (light scatters in from the lit side: high variance, many samples); P2, a lit pixel 9 px from it
    (a little light scatters out: low variance, near b_min). Deep inside either plateau the estimator of a
    constant irradiance is exact (no variance at all), so neither pixel is taken there."""
    return {"P1 (shadow)": (width // 2 - 4, height // 6), "P2 (lit)": (width // 2 + 9, height // 6)}


def fig4_data(backend: str = "numba", frames: int = FIG4_FRAMES, replicas: int = FIG4_REPLICAS,
              size: tuple[int, int] = FIG4_SIZE, progress: Progress | None = None) -> dict[str, Any]:
    """Xie 2020 Fig. 4 in kind: per frame, at P1 and P2, the local and the global (after TAA) standard
    deviation, from ``replicas`` independent runs (seeds 0..replicas-1): ``sigma_l`` the standard deviation
    across runs of the frame's value S (what the guiding phase targets: sigma0), ``sigma_g`` that of the
    TAA output, ``sigma_hist`` the history's own estimate (Eq. 9; the mean over runs), ``spp`` the mean
    count. sigma0^2 = 0.01^2, alpha 0.2, kappa 1, b = [8, 64]."""
    def compute():
        gb = shadow_plane(*size)
        params = plane_params()
        from ..pipeline.burley_frame import burley_exact

        ref = burley_exact(gb, params)
        settings = AdaptiveSettings(sigma0_sq=FIG4_SIGMA0_SQ, kappa=1.0, b_min=8, b_max=64, alpha=0.2)
        pix = fig4_pixels(*size)
        runs = []
        for r in range(replicas):
            if progress is not None:
                progress(f"xie-fig4: run {r + 1}/{replicas}")
            runs.append(run_plane_frames(gb, params, ref, settings, frames, backend=backend, seed=r,
                                     pixels=tuple(pix.values())))
        out: dict[str, Any] = {"pixels": pix, "frames": frames, "replicas": replicas, "size": size,
                               "backend": backend, "series": {}}
        for name, p in pix.items():
            v = np.stack([run["traces"][p]["value"] for run in runs])
            vt = np.stack([run["traces"][p]["value_taa"] for run in runs])
            sh = np.stack([run["traces"][p]["sigma_local"] for run in runs])
            out["series"][name] = {"sigma_l": v.std(axis=0, ddof=1), "sigma_g": vt.std(axis=0, ddof=1),
                                   "sigma_hist": sh.mean(axis=0), "value": v.mean(axis=0)}
        counts = np.stack([run["counts"] for run in runs])
        out["spp"] = {name: float(counts[:, p[1], p[0]].mean()) for name, p in pix.items()}
        return out

    return _cached("xie-fig4", {"backend": backend, "frames": frames, "replicas": replicas, "size": list(size)},
                   compute)


def xie_fig4(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None, backend: str = "numba") -> list[Path]:
    """Xie 2020 Fig. 4 in kind: per-frame local and global (after TAA) standard deviation at a shadowed and a
    lit pixel (sigma0^2 = 0.01^2, alpha 0.2, kappa 1, b = [8, 64]). ``profile`` is not used."""
    d = fig4_data(backend, progress=progress)
    plt = pyplot()
    fig, axes = plt.subplots(1, len(d["series"]), figsize=(12, 3.6), squeeze=False)
    skip = 8  # the start-up frames (the disocclusion initialisation and the TAA's first frames)
    for ax, (name, s) in zip(axes[0], d["series"].items()):
        frames = np.arange(1, d["frames"] + 1)
        ax.plot(frames, s["sigma_l"], color="#d62728", lw=1.2,
                label=rf"local $\sigma_l$ (mean {s['sigma_l'][skip:].mean():.4f})")
        ax.plot(frames, s["sigma_g"], color="#1f77b4", lw=1.2,
                label=rf"global $\sigma_g$ after TAA (mean {s['sigma_g'][skip:].mean():.4f})")
        ax.plot(frames, s["sigma_hist"], color="#d62728", lw=0.8, ls=":", label=r"history's $\sigma$ (Eq. 9)")
        ax.axhline(np.sqrt(FIG4_SIGMA0_SQ), color="0.4", ls="--", lw=0.8, label=r"$\sigma_0$")
        ax.set_xlabel("frame")
        ax.set_ylabel("SD of gamma-corrected luminance" if ax is axes[0][0] else "")
        ax.set_title(f"{name}, pixel {d['pixels'][name]}: {d['spp'][name]:.1f} spp in the last frame", fontsize=9)
        ax.legend(fontsize=8)
        ax.set_ylim(0, None)
    fig.suptitle(rf"Xie 2020 Fig. 4 in kind: shadow-edge plane {d['size'][0]}x{d['size'][1]}, "
                 rf"$\sigma_0^2 = 0.01^2$, $\alpha$ = 0.2, $\kappa$ = 1, b = [8, 64]; standard deviations over "
                 f"{d['replicas']} independent runs ({d['backend']})", fontsize=9)
    fig.tight_layout()
    path = Path(out) / "xie_fig4_local_global_sd.png"
    save_figure(fig, path)
    return [path]


# ---- Figs. 10, 11, 13 and Table 1 ---------------------------------------------------------------------------

def grid_data(distance: str = "regular", backend: str = "numba", frames: int = GRID_FRAMES,
              size: tuple[int, int] = GRID_SIZE, progress: Progress | None = None) -> dict[str, Any]:
    """The sigma0^2 x kappa grid at b = [8, 64] (Xie 2020 Figs. 10-11) beside fixed 64 spp, and the equal-time
    comparison (Fig. 13): per setting ``psnr_taa`` (final), ``psnr`` (single frame), ``mean_spp`` and ``ms``
    (medians over the frames after the first, whose time includes compiling); ``fixed64`` and ``fixed8``;
    ``equal_time``: for each of :data:`EQUAL_TIME_SETTINGS` the fixed count whose time, by the line through
    the fixed runs at 8 and 64 spp, matches the adaptive run's, and both runs (each time measured)."""
    def summary(run):
        return {"psnr_taa": _final(run, "psnr_taa"), "psnr": _final(run, "psnr"), "mean_spp": _final(run, "mean_spp"),
                "ms": float(np.median(run["ms"][1:])), "phases": run["phases"]}

    def compute():
        from ..pipeline.burley_frame import burley_exact

        gb = shadow_plane(*size, distance)
        params = plane_params()
        ref = burley_exact(gb, params)
        fixed = run_plane_frames(gb, params, ref, None, frames, spp=64, backend=backend)
        out: dict[str, Any] = {"distance": distance, "backend": backend, "frames": frames, "size": size,
                               "fixed64": summary(fixed), "grid": {}, "equal_time": []}
        runs = {}
        for s0 in GRID_SIGMA0_SQ:
            for k in GRID_KAPPA:
                if progress is not None:
                    progress(f"adaptive grid ({distance}): sigma0^2 = {s0:g}, kappa = {k:g}")
                run = run_plane_frames(gb, params, ref, AdaptiveSettings(sigma0_sq=s0, kappa=k, b_min=8, b_max=64),
                                   frames, backend=backend)
                runs[(s0, k)] = run
                out["grid"][(s0, k)] = summary(run)
        # the fixed pass's time per frame as t0 + c n, from its runs at 8 and 64 spp
        out["fixed8"] = summary(run_plane_frames(gb, params, ref, None, frames, spp=8, backend=backend))
        c = max(out["fixed64"]["ms"] - out["fixed8"]["ms"], 1e-9) / 56.0
        t0 = out["fixed8"]["ms"] - 8.0 * c
        for s0, k in EQUAL_TIME_SETTINGS:
            a = out["grid"][(s0, k)]
            n = int(np.clip(round((a["ms"] - t0) / c), 1, 64))
            if progress is not None:
                progress(f"equal time ({distance}): fixed {n} spp vs sigma0^2 = {s0:g}, kappa = {k:g}")
            f = run_plane_frames(gb, params, ref, None, frames, spp=n, backend=backend)
            ad = runs[(s0, k)]
            out["equal_time"].append({"sigma0_sq": s0, "kappa": k, "fixed_spp": n, "fixed": summary(f),
                                      "adaptive": a, "images": {"reference": ref, "fixed": f["last"],
                                                                "adaptive": ad["last"], "counts": ad["counts"]}})
        return out

    return _cached("xie-grid", {"distance": distance, "backend": backend, "frames": frames, "size": list(size)},
                   compute)


def phase_data(backend: str = "numba", frames: int = 12, size: tuple[int, int] = GRID_SIZE, progress: Progress | None = None) -> dict[str, Any]:
    """Xie 2020 Table 1 in kind: median ms per phase (prefilter, sampling, update; estimate on the first
    frame), fixed 64 spp vs adaptive (sigma0^2 = 1e-3, kappa = 0.2), with mips on (the paper's setting), and
    the combine step (albedo x result + specular, numpy)."""
    def compute():
        import time

        from ..pipeline.burley_frame import burley_exact

        gb = shadow_plane(*size)
        params = plane_params()
        ref = burley_exact(gb, params)
        rows = {}
        for label, settings in (("fixed 64 spp", None),
                                ("adaptive (1e-3, 0.2)", AdaptiveSettings(sigma0_sq=1e-3, kappa=0.2))):
            if progress is not None:
                progress(f"table 1: {label}")
            run_plane_frames(gb, params, ref, settings, 2, backend=backend, mips=True)  # compile, warm up
            run = run_plane_frames(gb, params, ref, settings, frames, backend=backend, mips=True)
            t = []
            for _ in range(5):
                t0 = time.perf_counter()
                gb.composite(run["last"])
                t.append(1e3 * (time.perf_counter() - t0))
            rows[label] = dict(run["phases"], combine=float(np.median(t)), mean_spp=_final(run, "mean_spp"),
                               psnr_taa=_final(run, "psnr_taa"))
        return {"backend": backend, "size": size, "frames": frames, "rows": rows}

    return _cached("xie-table1", {"backend": backend, "frames": frames, "size": list(size)}, compute)


def plot_grid(d: dict, path: Path) -> list[Path]:
    """Figs. 10-11 in kind: final PSNR (single-frame in parentheses), mean spp and ms per frame per cell,
    coloured by ms per frame."""
    plt = pyplot()
    ms = np.array([[d["grid"][(s0, k)]["ms"] for k in GRID_KAPPA] for s0 in GRID_SIGMA0_SQ])
    fig, ax = plt.subplots(figsize=(8.5, 5.2))
    im = ax.imshow(ms, cmap="viridis", aspect="auto")
    for i, s0 in enumerate(GRID_SIGMA0_SQ):
        for j, k in enumerate(GRID_KAPPA):
            c = d["grid"][(s0, k)]
            ax.text(j, i, f"{c['psnr_taa']:.2f} ({c['psnr']:.2f}) dB\n{c['mean_spp']:.1f} spp, {c['ms']:.0f} ms",
                    ha="center", va="center", fontsize=8, color="w" if ms[i, j] < ms.mean() else "k")
    ax.set_xticks(range(len(GRID_KAPPA)), [f"{k:g}" for k in GRID_KAPPA])
    ax.set_yticks(range(len(GRID_SIGMA0_SQ)), [f"{s:g}" for s in GRID_SIGMA0_SQ])
    ax.set_xlabel(r"$\kappa$")
    ax.set_ylabel(r"$\sigma_0^2$")
    fig.colorbar(im, ax=ax, label="ms per frame (pass + guiding phase)")
    f = d["fixed64"]
    ax.set_title(f"Xie 2020 Fig. {10 if d['distance'] == 'regular' else 11} in kind ({d['distance']} distance, "
                 f"{d['size'][0]}x{d['size'][1]}, {d['frames']} frames, b = [8, 64], {d['backend']}): final PSNR "
                 f"with TAA (single frame)\nfixed 64 spp: {f['psnr_taa']:.2f} ({f['psnr']:.2f}) dB, {f['ms']:.0f} ms",
                 fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)
    return [path]


def xie_fig10(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None, backend: str = "numba") -> list[Path]:
    """Xie 2020 Fig. 10 in kind: the sigma0^2 x kappa grid at regular distance (2.5 px per mm)."""
    return plot_grid(grid_data("regular", backend, progress=progress), Path(out) / "xie_fig10_grid_regular.png")


def xie_fig11(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None, backend: str = "numba") -> list[Path]:
    """Xie 2020 Fig. 11 in kind: the same grid at close distance (6.7 px per mm)."""
    return plot_grid(grid_data("close", backend, progress=progress), Path(out) / "xie_fig11_grid_close.png")


def xie_fig13(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None, backend: str = "numba") -> list[Path]:
    """Xie 2020 Fig. 13 in kind: equal time, fixed vs adaptive (the last frame before TAA, and the counts)."""
    d = grid_data("regular", backend, progress=progress)
    plt = pyplot()
    rows = d["equal_time"]
    fig, axes = plt.subplots(len(rows), 4, figsize=(13, 2.3 * len(rows)), squeeze=False)
    for row, e in zip(axes, rows):
        im = e["images"]
        top = float(im["reference"].max())
        for ax, key, title in ((row[0], "reference", "the pass's limit"),
                               (row[1], "fixed", f"fixed {e['fixed_spp']} spp: {e['fixed']['psnr']:.2f} dB, "
                                                 f"{e['fixed']['ms']:.0f} ms"),
                               (row[2], "adaptive",
                                rf"adaptive $\sigma_0^2$={e['sigma0_sq']:g}, $\kappa$={e['kappa']:g}: "
                                                    f"{e['adaptive']['psnr']:.2f} dB, {e['adaptive']['ms']:.0f} ms")):
            ax.imshow(np.clip(im[key] / top, 0, 1) ** (1 / 2.2))
            ax.set_title(title, fontsize=8)
            ax.axis("off")
        c = row[3].imshow(im["counts"], cmap="magma", vmin=0, vmax=64)
        row[3].set_title(f"adaptive counts ({e['adaptive']['mean_spp']:.1f} spp mean)", fontsize=8)
        row[3].axis("off")
        fig.colorbar(c, ax=row[3], fraction=0.04)
    fig.suptitle("Xie 2020 Fig. 13 in kind: equal time, fixed vs adaptive (single frame, no TAA; PSNR of the "
                 "frame against the limit)", fontsize=9)
    fig.tight_layout()
    path = Path(out) / "xie_fig13_equal_time.png"
    save_figure(fig, path)
    return [path]


def xie_table1(out: Path, profile: RGBProfile | None = None, progress: Progress | None = None, backend: str = "numba") -> list[Path]:
    """Xie 2020 Table 1 in kind: per-phase ms, fixed 64 spp vs adaptive, as a CSV and a bar chart."""
    from ..io import atomic_output

    d = phase_data(backend, progress=progress)
    phases = ("estimate", "prefilter", "sampling", "update", "combine")
    csv = Path(out) / "xie_table1_phases.csv"
    lines = ["setting," + ",".join(phases) + ",total,mean_spp,final_psnr_db"]
    for label, r in d["rows"].items():
        vals = [r.get(p) for p in phases]
        total = sum(v for v in vals if v is not None)
        lines.append(",".join([label] + ["" if v is None else f"{v:.3f}" for v in vals]
                              + [f"{total:.3f}", f"{r['mean_spp']:.2f}", f"{r['psnr_taa']:.2f}"]))
    with atomic_output(csv) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 2.6))
    for i, (label, r) in enumerate(d["rows"].items()):
        left = 0.0
        for p, color in zip(phases, ("#8c564b", "#9467bd", "#1f77b4", "#d62728", "#2ca02c")):
            v = r.get(p) or 0.0
            ax.barh(i, v, left=left, color=color, label=p if i == 0 else None)
            left += v
    ax.set_yticks(range(len(d["rows"])), list(d["rows"]))
    ax.set_xlabel("ms per frame (medians)")
    ax.legend(fontsize=8, ncol=5, loc="lower right")
    ax.set_title(f"Xie 2020 Table 1 in kind: phases per frame, {d['size'][0]}x{d['size'][1]}, mips on, "
                 f"{d['backend']}", fontsize=9)
    fig.tight_layout()
    png = Path(out) / "xie_table1_phases.png"
    save_figure(fig, png)
    return [csv, png]



# ---- the demo report's section ------------------------------------------------------------------------------

def demo_section(out: Path, progress: Progress | None, ctx: dict[str, Any]) -> str:
    """The demo report's section on the adaptive sampler (``ssskit.report.SECTIONS`` signature ``(out,
    progress, ctx) -> html``): Figs. 2-4, the grid of Figs. 10-11, Fig. 13 and Table 1 in kind, on numba
    (``ctx["adaptive_backend"]``, else the demo's ``ctx["backend"]``, to choose another backend)."""
    import html

    backend = ctx.get("adaptive_backend", ctx.get("backend", "numba"))
    figs = Path(out) / "figures"
    figs.mkdir(parents=True, exist_ok=True)
    say = progress if progress is not None else (lambda _msg: None)
    paths = {}
    for name, fn in (("fig2", xie_fig2_cold_start), ("fig3", xie_fig3_disocclusion)):
        paths[name] = fn(figs)[0]
    paths["fig4"] = xie_fig4(figs, progress=say, backend=backend)[0]
    paths["fig10"] = xie_fig10(figs, progress=say, backend=backend)[0]
    paths["fig11"] = xie_fig11(figs, progress=say, backend=backend)[0]
    paths["fig13"] = xie_fig13(figs, progress=say, backend=backend)[0]
    paths["table1"] = xie_table1(figs, progress=say, backend=backend)[1]
    f4 = fig4_data(backend)
    grids = {dist: grid_data(dist, backend) for dist in ("regular", "close")}
    phases = phase_data(backend)

    def img(key):
        return f"<img src='figures/{html.escape(paths[key].name)}' style='width:100%'>"

    f4_rows = "".join(
        f"<tr><td class=name>{html.escape(name)} {f4['pixels'][name]}</td><td>{s['sigma_l'][8:].mean():.4f}</td>"
        f"<td>{s['sigma_g'][8:].mean():.4f}</td><td>{s['sigma_l'][8:].mean() / max(s['sigma_g'][8:].mean(), 1e-12):.1f}"
        f"</td><td>{f4['spp'][name]:.1f}</td></tr>" for name, s in f4["series"].items())
    grid_rows = []
    for dist, g in grids.items():
        for n in (64, 8):
            f = g[f"fixed{n}"]
            grid_rows.append(f"<tr><td class=name>{dist}: fixed {n} spp</td><td>-</td><td>-</td>"
                             f"<td>{f['psnr_taa']:.2f}</td><td>{f['psnr']:.2f}</td><td>{n}</td>"
                             f"<td>{f['ms']:.1f}</td></tr>")
        for (s0, k), c in g["grid"].items():
            grid_rows.append(f"<tr><td class=name>{dist}</td><td>{s0:g}</td><td>{k:g}</td><td>{c['psnr_taa']:.2f}</td>"
                             f"<td>{c['psnr']:.2f}</td><td>{c['mean_spp']:.1f}</td><td>{c['ms']:.1f}</td></tr>")
    eq_rows = "".join(
        f"<tr><td>{e['sigma0_sq']:g}, {e['kappa']:g}</td><td>{e['adaptive']['mean_spp']:.1f}</td>"
        f"<td>{e['adaptive']['ms']:.1f}</td><td>{e['adaptive']['psnr']:.2f} / {e['adaptive']['psnr_taa']:.2f}</td>"
        f"<td>{e['fixed_spp']}</td><td>{e['fixed']['ms']:.1f}</td><td>{e['fixed']['psnr']:.2f} / "
        f"{e['fixed']['psnr_taa']:.2f}</td></tr>" for e in grids["regular"]["equal_time"])
    cols = ("estimate", "prefilter", "sampling", "update", "combine")
    ph_rows = "".join(
        f"<tr><td class=name>{html.escape(label)}</td>"
        + "".join("<td>N/A</td>" if r.get(c) is None else f"<td>{r[c]:.2f}</td>" for c in cols)
        + f"<td>{sum(r[c] for c in cols if r.get(c) is not None):.2f}</td><td>{r['mean_spp']:.1f}</td>"
        f"<td>{r['psnr_taa']:.2f}</td></tr>" for label, r in phases["rows"].items())
    g0 = grids["regular"]
    return (
        "<h2 id=adaptive>Variance-guided adaptive sampling with temporal history (Xie et al. 2020, Sec. 4.1 and 6)"
        "</h2><p class=note>Per pixel and frame the guiding phase (one RGBA32F history texture: n&#772;, &mu;, "
        "&sigma;&sup2;, m) picks the next frame's Burley sample count from Eqs. 13-15; the engine's TAA (Karis "
        "2014; here ssskit.screenspace.taa with its defaults) runs after it and is not read by it. The circle "
        "scenario of Sec. 4.1.3 (Figs. 2-3), then a shadow-edge plane at 1080p's scale (2.5 px per mm; "
        "skin-like Burley material, dmfp 2 / 1 / 0.5 mm): half lit, half in shadow with a lit disk, exact "
        f"sampler, no mips, against the pass's limit. Guiding phase and pass on the <b>{html.escape(backend)}"
        "</b> backend; times are this machine's CPU.</p>"
        + img("fig2") + img("fig3")
        + "<h3>Fig. 4 in kind: local and global (after TAA) standard deviation</h3><p class=note>"
        f"{f4['replicas']} independent runs of {f4['frames']} frames, {f4['size'][0]}x{f4['size'][1]}; &sigma;<sub>l"
        "</sub>: the standard deviation across runs of the frame's gamma-corrected luminance, &sigma;<sub>g</sub>: "
        "that of the TAA output; means over frames 9 on. Xie: P1 0.0097 / 0.0029, P2 0.0044 / 0.0031.</p>"
        "<table><tr><th>pixel</th><th>&sigma;<sub>l</sub></th><th>&sigma;<sub>g</sub></th><th>ratio</th>"
        f"<th>spp (last frame)</th></tr>{f4_rows}</table>" + img("fig4")
        + "<h3>Figs. 10-11 in kind: &sigma;<sub>0</sub>&sup2; &times; &kappa; at b = [8, 64]</h3><p class=note>"
        f"{g0['size'][0]}x{g0['size'][1]}, {g0['frames']} frames. Final PSNR: the TAA output's, mean of the last "
        "quarter of the frames; single-frame PSNR: the pass's own frames, same frames; ms per frame: the pass and "
        "the guiding phase (median). Regular distance 2.5 px per mm, close 6.7 px per mm.</p>"
        "<table><tr><th>distance</th><th>&sigma;<sub>0</sub>&sup2;</th><th>&kappa;</th><th>final PSNR (TAA)</th>"
        f"<th>single-frame PSNR</th><th>mean spp</th><th>ms / frame</th></tr>{''.join(grid_rows)}</table>"
        + img("fig10") + img("fig11")
        + "<h3>Fig. 13 in kind: equal time, fixed vs adaptive</h3><p class=note>The fixed count whose time matches "
        "the adaptive run's (by the line through the fixed runs at 8 and 64 spp; both times measured, on a shared "
        "machine). PSNR single frame / with TAA.</p>"
        "<table><tr><th>&sigma;<sub>0</sub>&sup2;, &kappa;</th><th>adaptive spp</th><th>ms</th><th>PSNR</th>"
        f"<th>fixed spp</th><th>ms</th><th>PSNR</th></tr>{eq_rows}</table>" + img("fig13")
        + "<h3>Table 1 in kind: phases per frame (ms)</h3><p class=note>Mips on (Xie's setting). The PSNR is "
        "against the limit without mips, so it includes the prefilter's own bias: about 0.0034 RMS (47.5 dB) on "
        "this plane, for adaptive counts and fixed 64 spp alike (their 256-frame averages with mips lie within "
        "one standard error of each other, benchmarks/adaptive_mips_bias.py), though Eq. 22's level depends on "
        "n. That bias caps fixed 64's final PSNR; the adaptive run's is limited by its noise. Estimate: the "
        "first frame's (a static camera takes later counts from the update). Combine: albedo &times; result + "
        "specular in numpy.</p><table><tr><th>setting</th>"
        + "".join(f"<th>{c}</th>" for c in cols)
        + f"<th>total</th><th>mean spp</th><th>final PSNR</th></tr>{ph_rows}</table>" + img("table1")
    )


__all__ = ["circle_runs", "fig4_data", "fig4_pixels", "grid_data", "phase_data", "plane_params", "plot_circle",
           "plot_grid", "run_plane_frames", "shadow_plane", "xie_fig10", "xie_fig11", "xie_fig13", "xie_fig2_cold_start",
           "xie_fig3_disocclusion", "xie_fig4", "xie_table1", "demo_section"]
