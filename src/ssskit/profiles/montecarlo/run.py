"""Running one MCML simulation: batches in chunks on the numba engine, a progress bar, a partial
result kept when interrupted (Ctrl-C) to resume later, and an on-disk cache of finished results.

The cache lives in ``ssskit.cache.cache_dir("mcml")``: ``<key>.npz`` for a finished result and
``<key>.partial.npz`` for the batches an interrupted run finished, keyed by every input
(:meth:`MCConfig.key`). A partial result is never discarded silently: running the same
simulation again needs ``resume=True`` (continue it) or ``restart=True`` (discard it).
"""

from __future__ import annotations

import contextlib
from types import ModuleType
import math
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ...cache import cache_dir
from ...errors import ProfileError, SimulationInterrupted
from ...io import ProgressBar, progress_bar, save_arrays
from ...progress import add_to_total
from ...quantities import ETA, Choice, Quantity, checks, refuse_unused
from .config import N_EXIT_BINS, MCConfig, layer_arrays

#: numba's threads, a cosine of incidence (0 excluded: grazing light never enters), estimate samples
THREADS = Quantity("threads", 1, 1, "", "numba's threads (NUMBA_NUM_THREADS)", integer=True)
COSINE = Quantity("cos_theta", 0.0, 1.0, "", "a cosine of incidence", lo_open=True)
SAMPLES = Quantity("samples", 2, math.inf, "", "a mean and its standard error", integer=True, hi_open=True)
from .result import N_TOTALS, MCResult, assemble_result


def simulate(cfg: MCConfig, *, threads: int | None = None, progress: bool | None = None, resume: bool = False,
             restart: bool = False, use_cache: bool = True, label: str = "", shipped: bool = True,
             backend: str = "numba", shared_bar: ProgressBar | None = None) -> MCResult:
    """Run (or load from the cache) one MCML simulation on the numba engine (``backend="numba"``) or the
    GLSL one (``backend="gl"``: :mod:`.engine_gl`, any GPU or llvmpipe; its own cache entries).

    A configuration the package ships (the supplement's profiles at 10^7 photons,
    :mod:`.shipped`) is returned from the shipped file at once, unless ``shipped=False`` or
    ``use_cache=False``; its ``extra`` says ``{"shipped": True}``.

    If an interrupted run of the same inputs left a partial result, ``resume=True`` continues it
    and ``restart=True`` discards it and starts over; with neither, a :class:`ProfileError` says
    so (the partial result is kept). Both need the cache (``use_cache=True``); without the cache
    nothing is read or written, a partial result included. The result is bit-identical for any
    ``threads`` and for resumed runs. ``label`` names the run in the progress bar and messages;
    ``progress=None`` shows the bar inside a :func:`ssskit.io.reporting` block (the CLI), not elsewhere.
    ``shared_bar``: a bar of several runs (:func:`~.sweep.simulate_material`'s channels) that this run advances
    instead of showing its own; photons it does not simulate (cached, shipped, resumed) leave its total.
    """
    check_resume(resume, restart)
    if not use_cache:  # (they act on the on-disk cache; `ssskit simulate` refuses --no-cache with them first)
        refuse_unused([n for n, on in (("resume", resume), ("restart", restart)) if on], "use_cache", ("True",), False,
                      ProfileError)
    backend = Choice("the Monte Carlo backend", ENGINES).check(backend, error=ProfileError)  # (its canonical name from here)
    check_threads(threads)  # before any answer, the shipped one included
    if use_cache and shipped and backend == "numba":  # (None inside shipped.recompute(): ssskit demo --full)
        from .shipped import shipped_result

        found = shipped_result(cfg)
        if found is not None:
            if shared_bar is not None:
                add_to_total(shared_bar, -cfg.photons)
            return found
    key = cfg.key() + ("" if backend == "numba" else f"-{backend}")
    cdir = cache_dir("mcml")
    final_path = cdir / f"{key}.npz"
    partial_path = cdir / f"{key}.partial.npz"
    if use_cache and final_path.exists():
        with contextlib.suppress(Exception):
            cached = _load_result(cfg, final_path)
            if shared_bar is not None:
                add_to_total(shared_bar, -cfg.photons)
            return cached

    sizes = cfg.batch_sizes()
    n_b = sizes.shape[0]
    bins = np.zeros((n_b, cfg.nr))
    tt_bins = np.zeros((n_b, cfg.nr))
    totals = np.zeros((n_b, N_TOTALS))
    done = np.zeros(n_b, dtype=bool)
    elapsed = 0.0
    prefix = f"{label}: " if label else ""
    if use_cache and partial_path.exists():
        if restart:
            partial_path.unlink(missing_ok=True)
        else:
            partial = _load_partial(cfg, partial_path)
            if not resume:
                held = "an unknown number of" if partial is None else f"{int(sizes[partial[3]].sum())} of {cfg.photons}"
                what = f"{prefix}a partial result of an interrupted run exists ({held} photons)"
                raise ProfileError(f"{what}; pass resume=True to continue it or restart=True to discard it",
                                   cli_message=f"{what}; {_CLI_AGAIN} and --resume to continue it, or --restart to "
                                               "discard it")
            if partial is None:
                what = f"{prefix}the partial result of an interrupted run ({partial_path}) cannot be read"
                raise ProfileError(f"{what}; pass restart=True to discard it",
                                   cli_message=f"{what}; {_CLI_AGAIN} and --restart to discard it")
            bins, tt_bins, totals, done, elapsed = partial

    engine = _engine(backend)
    arrays = layer_arrays(cfg)
    rsp = cfg.specular_reflectance()
    if cfg.roughness > 0:  # the engine launches with weight 1; the entry's reflectance is estimated apart
        rsp = rough_specular(cfg)
    ux0, uz0 = cfg.launch_direction()
    todo = np.flatnonzero(~done)
    if progress is None:
        from ...io import reporting_active

        progress = reporting_active()
    if shared_bar is not None:
        add_to_total(shared_bar, -int(sizes[done].sum()))
        bar: ProgressBar | None = shared_bar
    else:
        bar = photons_bar(cfg.photons, int(sizes[done].sum()), label) if progress else None
    t0 = time.perf_counter()
    try:
        with _numba_threads(threads) if backend == "numba" else contextlib.nullcontext(1) as nthreads:
            # numba: two batches per thread for balance; with progress shown, one when a chunk takes longer
            # than CHUNK_S (progress then advances more often); gl: the engine's own chunk. The result does not
            # depend on the chunks
            chunk = max(2 * nthreads, 1) if backend == "numba" else engine.chunk_batches()
            start = 0
            while start < todo.shape[0]:
                ids = todo[start : start + chunk]
                start += ids.shape[0]
                t_chunk = time.perf_counter()
                b_rows = np.zeros((ids.shape[0], cfg.nr))
                tt_rows = np.zeros((ids.shape[0], cfg.nr))
                t_rows = np.zeros((ids.shape[0], N_TOTALS))
                engine.run_batches(
                    np.uint64(cfg.seed), ids.astype(np.int64), sizes[ids], arrays["mua"], arrays["mus"],
                    arrays["g"], arrays["z_top"], arrays["z_bot"], arrays["n_idx"], arrays["cos_crit_up"],
                    arrays["cos_crit_down"], 0.0 if cfg.roughness > 0 else rsp, ux0, uz0, cfg.dr_mm,
                    float(cfg.roughness), b_rows, tt_rows, t_rows)
                bins[ids], tt_bins[ids], totals[ids], done[ids] = b_rows, tt_rows, t_rows, True
                if bar is not None and backend == "numba" and time.perf_counter() - t_chunk > CHUNK_S:
                    chunk = max(nthreads, 1)
                if bar is not None:
                    bar.update(int(sizes[ids].sum()))
    except KeyboardInterrupt:
        if use_cache:
            save_arrays(partial_path, bins=bins, tt_bins=tt_bins, totals=totals, done=done,
                        seconds=np.array(elapsed + time.perf_counter() - t0))
        n_done = int(sizes[done].sum())
        what = f"{prefix}simulation interrupted after {n_done} of {cfg.photons} photons; "
        raise SimulationInterrupted(
            what + ("they are kept: resume=True continues them, restart=True discards them" if use_cache
                    else "nothing was kept (the cache is off)"),
            cli_message=what + (f"they are kept: {_CLI_AGAIN} and --resume to continue them, or --restart to "
                                "discard them" if use_cache else "nothing was kept (--no-cache)"),
        ) from None
    finally:
        if bar is not None and shared_bar is None:
            bar.close()
    result = assemble_result(cfg, bins, totals, elapsed + time.perf_counter() - t0, rsp=rsp, tt_bins=tt_bins)
    if use_cache:
        save_arrays(final_path, r_mm=result.r_mm, rd=result.rd, rd_se=result.rd_se, exit_rd=result.exit_rd,
                    exit_rd_se=result.exit_rd_se, tt_r=result.tt_r, tt_r_se=result.tt_r_se, exit_tt=result.exit_tt,
                    exit_tt_se=result.exit_tt_se,
                    scalars=np.array([result.total_rd, result.total_rd_se, result.tt, result.tt_se,
                                      result.absorbed, result.absorbed_se, result.rsp, result.seconds,
                                      result.overflow, result.overflow_se, result.tt_overflow,
                                      result.tt_overflow_se]))
        with contextlib.suppress(OSError):
            partial_path.unlink()
    return result


def check_resume(resume: bool, restart: bool) -> None:
    """A ProfileError if both ``resume`` and ``restart`` are asked for (a run and a sweep state it once)."""
    if resume and restart:
        raise ProfileError("resume and restart exclude each other: resume continues an interrupted run, "
                           "restart discards it")


def check_threads(threads: int | None) -> None:
    """A ProfileError unless ``threads`` is None or an int in 1..numba's thread count."""
    if threads is not None:
        import numba

        # numba.config sets its NUMBA_* names through globals(), which its inline types cannot show
        THREADS.within(hi=numba.config.NUMBA_NUM_THREADS).check(threads, "threads", ProfileError)  # type: ignore[attr-defined]


#: a chunk of batches (one engine call) that takes longer than this is halved for the next (seconds)
CHUNK_S = 2.0

#: how a CLI message says to run the simulation again (``simulate`` is the command with --resume/--restart)
_CLI_AGAIN = "run ssskit simulate with the same material, photons and seed"
#: the Monte Carlo engines: numba (CPU, the default) and gl (GLSL compute through EGL)
ENGINES = ("numba", "gl")


def _engine(backend: str) -> ModuleType:
    """The engine module of ``backend`` (imported now: numba compiles, gl makes its context), or a
    ProfileError saying why the gl engine cannot run here."""
    if backend == "gl":
        from . import engine_gl

        ok, why = engine_gl.available()
        if not ok:
            raise ProfileError(f"the gl Monte Carlo engine cannot run here: {why}")
        return engine_gl
    from . import engine_numba

    return engine_numba


#: samples of the entry estimate of a rough surface's specular reflectance (SE ~ 2e-5)
RSP_SAMPLES = 1_000_000


@checks(ProfileError, cos_theta=COSINE, eta_from=ETA, eta_to=ETA,
        alpha=COSINE.within(reason="a Beckmann roughness; 0 is a smooth surface"), samples=SAMPLES)
def rough_boundary_albedo(cos_theta: float, eta_from: float, eta_to: float, alpha: float,
                          samples: int = RSP_SAMPLES, seed: int = 0) -> dict[str, tuple[float, float]]:
    """Directional albedo of the simulation's rough dielectric surface (Beckmann ``alpha``, Walter et
    al. 2007 Eqs. 27-29, 40-41, :func:`~.engine_numba._rough_interface`) for light arriving at
    ``cos_theta`` to the normal from the medium of index ``eta_from``: ``{"reflected", "transmitted",
    "lost"}``, each (mean, standard error) over ``samples`` samples of the stream ``seed``. "lost" is
    what the single-scattering BSDF removes (masking), 0 for a smooth surface."""
    from . import engine_numba

    out = engine_numba.rough_interface_albedo(float(cos_theta), float(eta_from), float(eta_to), float(alpha),
                                              int(samples), int(seed))
    return {k: (float(out[i]), float(out[3 + i])) for i, k in enumerate(("reflected", "transmitted", "lost"))}


def rough_specular(cfg: MCConfig) -> float:
    """The specular reflectance Rsp at the entry of ``cfg``'s rough top surface, for the beam at
    ``cfg.incidence_deg`` (:func:`rough_boundary_albedo`, a stream of its own derived from ``cfg.seed``)."""
    mu = math.cos(math.radians(cfg.incidence_deg))
    return rough_boundary_albedo(mu, cfg.eta_above, cfg.layers[0].eta, cfg.roughness,
                                 seed=cfg.seed)["reflected"][0]


def _load_partial(cfg: MCConfig, path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float] | None:
    """(bins, tt_bins, totals, done, seconds) of an interrupted run, or None if the file cannot be used (a
    file from before the transmitted tallies is used for a semi-infinite medium, whose are all zero)."""
    n_b = cfg.n_batches
    try:
        with np.load(path) as z:
            bins, totals, done = z["bins"].copy(), z["totals"].copy(), z["done"].copy()
            tt_bins = z["tt_bins"].copy() if "tt_bins" in z.files else None
            seconds = float(z["seconds"])
    except Exception:  # a truncated or foreign file: the caller reports it
        return None
    if tt_bins is None and not math.isfinite(cfg.layers[-1].thickness_mm) and totals.shape == (n_b, OLD_TOTALS):
        tt_bins = np.zeros_like(bins)
        totals = np.concatenate([totals, np.zeros((n_b, N_TOTALS - OLD_TOTALS))], axis=1)
    if (tt_bins is None or bins.shape != (n_b, cfg.nr) or tt_bins.shape != bins.shape or totals.shape != (n_b, N_TOTALS)
            or done.shape != (n_b,) or done.dtype != bool):
        return None
    return bins, tt_bins, totals, done, seconds


#: values per batch row of ``totals`` in a file from before the transmitted tallies
OLD_TOTALS = 3 + N_EXIT_BINS


def _load_result(cfg: MCConfig, path: Path) -> MCResult:
    """A finished result from the cache. A file written before the transmitted tallies (Tt_r, Tt_a) has
    none: for a semi-infinite medium they are zero (it transmits nothing) and the file serves; for a finite
    slab it raises, and :func:`simulate` runs the simulation again (the same streams: the same other
    tallies, bit for bit, and the transmitted ones)."""
    with np.load(path) as z:
        s = z["scalars"]
        rd = z["rd"].copy()
        if "tt_r" in z.files:
            tt_r, tt_r_se, exit_tt, exit_tt_se = (z[k].copy() for k in ("tt_r", "tt_r_se", "exit_tt", "exit_tt_se"))
            tt_over = (float(s[10]), float(s[11]))
        elif not math.isfinite(cfg.layers[-1].thickness_mm):
            tt_r, tt_r_se, exit_tt, exit_tt_se = (np.zeros_like(rd), np.zeros_like(rd), np.zeros(N_EXIT_BINS),
                                                  np.zeros(N_EXIT_BINS))
            tt_over = (0.0, 0.0)
        else:
            raise KeyError("the cached result predates the transmitted tallies")
        return MCResult(
            config=cfg, r_mm=z["r_mm"].copy(), rd=rd, rd_se=z["rd_se"].copy(),
            total_rd=float(s[0]), total_rd_se=float(s[1]), tt=float(s[2]), tt_se=float(s[3]),
            absorbed=float(s[4]), absorbed_se=float(s[5]), rsp=float(s[6]), seconds=float(s[7]),
            photons=cfg.photons, overflow=float(s[8]), overflow_se=float(s[9]), exit_rd=z["exit_rd"].copy(),
            exit_rd_se=z["exit_rd_se"].copy(), extra={"cached": True}, tt_r=tt_r, tt_r_se=tt_r_se,
            tt_overflow=tt_over[0], tt_overflow_se=tt_over[1], exit_tt=exit_tt, exit_tt_se=exit_tt_se,
        )


@contextlib.contextmanager
def _numba_threads(threads: int | None) -> Iterator[int]:
    import numba

    if threads is None:
        yield numba.get_num_threads()
        return
    old = numba.get_num_threads()  # (threads: checked by simulate, its one caller, before any work)
    numba.set_num_threads(threads)
    try:
        yield threads
    finally:
        numba.set_num_threads(old)


def photons_bar(total: int, initial: int, label: str) -> ProgressBar:
    """A bar of ``total`` photons (tqdm on a terminal, plain lines in a log) named ``label``."""
    return progress_bar(total, label or "MCML", "photons", initial=initial, unit_scale=True, smoothing=0.1,
                        dynamic_ncols=True, leave=False)


__all__ = ["ENGINES", "RSP_SAMPLES", "check_threads", "rough_boundary_albedo", "rough_specular", "simulate"]
