"""Monte Carlo diffuse reflectance profiles: an MCML engine (Wang, Jacques, Zheng 1995) with the
separable-SSS supplement's settings (section F).

Supplement F: 10^7 photons per channel; grid spacing dr = min(MFP_rgb) / 20; nr = ceil(32
max(MFP_rgb) / dr) radial bins; semi-infinite medium (10^7 cm); MFP = 1 / (sigma_a + sigma_s').

The transport itself is :mod:`ssskit.profiles.mcml_kernel` (numba, parallel over batches of
photons). This module sets it up, runs batches in chunks with a progress bar, keeps the work done
when interrupted (Ctrl-C) so ``resume=True`` continues it, caches finished results on disk keyed
by every input, and turns the tallies into a :class:`MonteCarloProfile`.

Normalisation (as MCML's SumScaleResult): Rd(r_i) = W_i / (2 pi r_i dr N) with r_i = (i + 1/2) dr the bin
centre and W_i the weight escaping in annulus i (the last bin also collects everything beyond it);
totals are weight sums / N. Standard errors use the batch method: the spread of per-batch means.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ProfileError, SimulationInterrupted
from ..materials import CHANNELS, LayeredMaterial, Material
from ..io import save_arrays
from .base import RadialProfile

#: bump when the transport or the tallies change: it is part of every cache key
ENGINE_VERSION = 1
DEFAULT_PHOTONS = 10_000_000  # supplement F
DEFAULT_BATCH = 10_000


@dataclass(frozen=True)
class MCLayer:
    """One layer of one channel: coefficients in mm^-1, thickness in mm (inf: semi-infinite)."""

    sigma_a: float
    sigma_s: float
    g: float = 0.0
    eta: float = 1.3
    thickness_mm: float = math.inf

    def __post_init__(self) -> None:
        if not (self.sigma_a >= 0 and self.sigma_s >= 0 and self.sigma_a + self.sigma_s > 0):
            raise ProfileError(f"layer needs sigma_a, sigma_s >= 0 with a positive sum, got {self.sigma_a}, {self.sigma_s}")
        if not -1 < self.g < 1:
            raise ProfileError(f"layer needs |g| < 1, got {self.g}")
        if not (math.isfinite(self.eta) and self.eta >= 1):
            raise ProfileError(f"layer needs eta >= 1, got {self.eta}")
        if not self.thickness_mm > 0:
            raise ProfileError(f"layer thickness must be > 0 mm, got {self.thickness_mm}")


@dataclass(frozen=True)
class MCConfig:
    """Everything that determines a simulation's result (and its cache key)."""

    layers: tuple[MCLayer, ...]
    dr_mm: float
    nr: int
    photons: int = DEFAULT_PHOTONS
    seed: int = 1
    eta_above: float = 1.0
    eta_below: float = 1.0
    batch_size: int = DEFAULT_BATCH

    def __post_init__(self) -> None:
        if not self.layers:
            raise ProfileError("a simulation needs at least one layer")
        if any(math.isinf(l.thickness_mm) for l in self.layers[:-1]):
            raise ProfileError("only the last layer may be semi-infinite")
        if not (self.dr_mm > 0 and math.isfinite(self.dr_mm)):
            raise ProfileError(f"grid spacing dr must be > 0 mm, got {self.dr_mm}")
        if not (isinstance(self.nr, (int, np.integer)) and self.nr >= 1):
            raise ProfileError(f"number of radial bins must be >= 1, got {self.nr}")
        if not (isinstance(self.photons, (int, np.integer)) and self.photons >= 1):
            raise ProfileError(f"photon count must be a positive integer, got {self.photons!r}")
        if not (isinstance(self.seed, (int, np.integer)) and 0 <= self.seed < 2**63):
            raise ProfileError(f"seed must be an integer in [0, 2^63), got {self.seed!r}")
        if not (isinstance(self.batch_size, (int, np.integer)) and self.batch_size >= 1):
            raise ProfileError(f"batch size must be a positive integer, got {self.batch_size!r}")
        for name in ("eta_above", "eta_below"):
            if not getattr(self, name) >= 1:
                raise ProfileError(f"{name} must be >= 1")

    @property
    def n_batches(self) -> int:
        return -(-self.photons // self.batch_size)

    def batch_sizes(self) -> np.ndarray:
        sizes = np.full(self.n_batches, self.batch_size, dtype=np.int64)
        sizes[-1] = self.photons - self.batch_size * (self.n_batches - 1)
        return sizes

    def key(self) -> str:
        """Hash of every input and the engine version."""
        data = asdict(self)
        data["engine"] = ENGINE_VERSION
        text = json.dumps(data, sort_keys=True, default=repr)
        return hashlib.sha256(text.encode()).hexdigest()[:24]

    def specular_reflectance(self) -> float:
        """Rsp = ((n0 - n1) / (n0 + n1))^2 at normal incidence (MCML's Rspecular, no glass layer)."""
        n0, n1 = self.eta_above, self.layers[0].eta
        return ((n0 - n1) / (n0 + n1)) ** 2


def _layers_of(material) -> tuple[Material, ...]:
    return tuple(material.layers) if isinstance(material, LayeredMaterial) else (material,)


def supplement_grid(material: Material | LayeredMaterial) -> tuple[float, int]:
    """Supplement F's grid: dr = min(MFP_rgb) / 20, nr = ceil(32 max(MFP_rgb) / dr), MFP = 1/sigma_t'
    (over every layer of a layered material)."""
    mfp = [v for layer in _layers_of(material) for v in layer.mfp_reduced_mm]
    dr = min(mfp) / 20.0
    return dr, int(math.ceil(32.0 * max(mfp) / dr - 1e-9))


def config_for_material(material: Material | LayeredMaterial, channel: int | str, photons: int = DEFAULT_PHOTONS,
                        seed: int = 1, batch_size: int = DEFAULT_BATCH) -> MCConfig:
    """The supplement's simulation of one channel of a (single-layer) material."""
    c = CHANNELS.index(channel.upper()) if isinstance(channel, str) else int(channel)
    dr, nr = supplement_grid(material)
    layers = tuple(MCLayer(m.sigma_a[c], m.sigma_s[c], m.g[c], m.eta, m.thickness_mm) for m in _layers_of(material))
    if isinstance(material, LayeredMaterial):
        above, below = material.eta_above, material.eta_below
    else:
        above = below = material.eta_ambient
    return MCConfig(layers, dr, nr, photons, seed, above, below, batch_size)


@dataclass
class MCResult:
    """Tallies of one simulation (one channel). Lengths mm, Rd mm^-2."""

    config: MCConfig
    r_mm: np.ndarray
    rd: np.ndarray
    rd_se: np.ndarray
    total_rd: float
    total_rd_se: float
    tt: float
    tt_se: float
    absorbed: float
    absorbed_se: float
    rsp: float
    seconds: float
    photons: int
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def photons_per_second(self) -> float:
        return self.photons / self.seconds if self.seconds > 0 else float("inf")

    def profile(self) -> MonteCarloProfile:
        return MonteCarloProfile(self)

    def to_dict(self) -> dict[str, Any]:
        return {
            "Rd": self.rd.tolist(),
            "Rd_se": self.rd_se.tolist(),
            "total_Rd": self.total_rd,
            "total_Rd_se": self.total_rd_se,
            "Tt": self.tt,
            "Tt_se": self.tt_se,
            "absorbed": self.absorbed,
            "absorbed_se": self.absorbed_se,
            "Rsp": self.rsp,
        }


class MonteCarloProfile(RadialProfile):
    """A simulated profile as a RadialProfile over the regular bins: R(r) constant on each annulus
    (MCML's bins), so the energy within rho is linear in rho^2 inside a bin.

    MCML's last bin collects every photon escaping beyond the grid; it is not a density, so it is
    left out: eval() is 0 from its inner edge on, total_rd() is the energy of the regular bins,
    and ``overflow`` (= result.total_rd - total_rd()) says how much escaped beyond the grid.
    """

    model = "montecarlo"

    def __init__(self, result: MCResult) -> None:
        self.result = result
        dr = result.config.dr_mm
        self.dr = dr
        rd = result.rd[:-1] if result.rd.shape[0] > 1 else result.rd
        self.rd = rd
        self.edges = np.arange(rd.shape[0] + 1) * dr
        # energy per bin, exactly W_i / N (inverting the 2 pi r_i dr normalisation)
        energy = rd * 2.0 * np.pi * result.r_mm[: rd.shape[0]] * dr
        self._total = float(energy.sum())
        self.overflow = float(result.total_rd - self._total)
        # S at the bin edges: energy outside edge k (within the grid)
        self._outside = np.concatenate([np.cumsum(energy[::-1])[::-1], [0.0]])
        self._energy = energy

    def eval(self, r):
        r = np.asarray(r, dtype=float)
        n = self.rd.shape[0]
        i = np.floor(r / self.dr).astype(np.int64)
        inside = (i >= 0) & (i < n)
        return np.where(inside, self.rd[np.clip(i, 0, n - 1)], 0.0)

    def total_rd(self) -> float:
        return self._total

    def energy_outside(self, rho):
        rho = np.asarray(rho, dtype=float)
        n = self.rd.shape[0]
        i = np.clip(np.floor(rho / self.dr).astype(np.int64), 0, n - 1)
        lo = self.edges[i]
        frac = np.clip((rho**2 - lo**2) / (self.edges[i + 1] ** 2 - lo**2), 0.0, 1.0)
        out = self._outside[i] - frac * self._energy[i]
        return np.where(rho >= self.edges[-1], 0.0, np.maximum(out, 0.0))

    def length_scale_mm(self) -> float:
        return self.edges[-1] / 32.0

    def params(self) -> dict[str, Any]:
        cfg = self.result.config
        return {"photons": cfg.photons, "seed": cfg.seed, "dr_mm": cfg.dr_mm, "nr": cfg.nr,
                "overflow": self.overflow, "layers": [asdict(l) for l in cfg.layers]}


# ---- running ---------------------------------------------------------------------------------


def cache_dir() -> Path:
    """$SSSKIT_CACHE_DIR, else ~/.cache/ssskit (XDG_CACHE_HOME respected)."""
    env = os.environ.get("SSSKIT_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "ssskit"


def _kernel_arrays(cfg: MCConfig) -> dict[str, Any]:
    layers = cfg.layers
    n_l = len(layers)
    mua = np.zeros(n_l + 2)
    mus = np.zeros(n_l + 2)
    g = np.zeros(n_l + 2)
    z_top = np.zeros(n_l + 2)
    z_bot = np.zeros(n_l + 2)
    n_idx = np.zeros(n_l + 2)
    n_idx[0], n_idx[-1] = cfg.eta_above, cfg.eta_below
    z = 0.0
    for i, layer in enumerate(layers, start=1):
        mua[i], mus[i], g[i], n_idx[i] = layer.sigma_a, layer.sigma_s, layer.g, layer.eta
        z_top[i] = z
        z = z + layer.thickness_mm
        z_bot[i] = z
    # cosines of the critical angles (as MCML's CriticalAngle): 0 where no TIR is possible
    up = np.zeros(n_l + 2)
    down = np.zeros(n_l + 2)
    for i in range(1, n_l + 1):
        n1 = n_idx[i]
        up[i] = math.sqrt(1.0 - (n_idx[i - 1] / n1) ** 2) if n1 > n_idx[i - 1] else 0.0
        down[i] = math.sqrt(1.0 - (n_idx[i + 1] / n1) ** 2) if n1 > n_idx[i + 1] else 0.0
    return dict(mua=mua, mus=mus, g=g, z_top=z_top, z_bot=z_bot, n_idx=n_idx, cos_crit_up=up, cos_crit_down=down)


@contextlib.contextmanager
def _numba_threads(threads: int | None):
    import numba

    if threads is None:
        yield numba.get_num_threads()
        return
    if not (isinstance(threads, int) and 1 <= threads <= numba.config.NUMBA_NUM_THREADS):
        raise ProfileError(f"threads must be in 1..{numba.config.NUMBA_NUM_THREADS}, got {threads!r}")
    old = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        yield threads
    finally:
        numba.set_num_threads(old)


def simulate(cfg: MCConfig, *, threads: int | None = None, progress: bool = False, resume: bool = False,
             use_cache: bool = True, label: str = "") -> MCResult:
    """Run (or load from the cache) one MCML simulation.

    ``resume=True`` continues from the batches an interrupted run kept; otherwise they are
    discarded. The result is bit-identical for any ``threads`` and for resumed runs.
    """
    key = cfg.key()
    cdir = cache_dir() / "mcml"
    final_path = cdir / f"{key}.npz"
    partial_path = cdir / f"{key}.partial.npz"
    if use_cache and final_path.exists():
        with contextlib.suppress(Exception):
            return _load_result(cfg, final_path)

    sizes = cfg.batch_sizes()
    n_b = sizes.shape[0]
    bins = np.zeros((n_b, cfg.nr))
    totals = np.zeros((n_b, 3))
    done = np.zeros(n_b, dtype=bool)
    elapsed = 0.0
    if resume and partial_path.exists():
        with np.load(partial_path) as z:
            if z["bins"].shape == bins.shape:
                bins, totals, done = z["bins"].copy(), z["totals"].copy(), z["done"].copy()
                elapsed = float(z["seconds"])
    elif partial_path.exists():
        partial_path.unlink()

    from .mcml_kernel import run_batches

    arrays = _kernel_arrays(cfg)
    rsp = cfg.specular_reflectance()
    todo = np.flatnonzero(~done)
    bar = _progress_bar(cfg.photons, int(sizes[done].sum()), label) if progress else None
    t0 = time.perf_counter()
    try:
        with _numba_threads(threads) as nthreads:
            chunk = max(2 * nthreads, 1)
            for start in range(0, todo.shape[0], chunk):
                ids = todo[start : start + chunk]
                b_rows = np.zeros((ids.shape[0], cfg.nr))
                t_rows = np.zeros((ids.shape[0], 3))
                run_batches(np.uint64(cfg.seed), ids.astype(np.int64), sizes[ids], arrays["mua"], arrays["mus"],
                            arrays["g"], arrays["z_top"], arrays["z_bot"], arrays["n_idx"], arrays["cos_crit_up"],
                            arrays["cos_crit_down"], rsp, cfg.dr_mm, b_rows, t_rows)
                bins[ids], totals[ids], done[ids] = b_rows, t_rows, True
                if bar is not None:
                    bar.update(int(sizes[ids].sum()))
    except KeyboardInterrupt:
        if use_cache:
            save_arrays(partial_path, bins=bins, totals=totals, done=done,
                      seconds=np.array(elapsed + time.perf_counter() - t0))
        n_done = int(sizes[done].sum())
        raise SimulationInterrupted(
            f"simulation interrupted after {n_done} of {cfg.photons} photons; "
            + ("run again with resume to continue" if use_cache else "nothing was kept (cache disabled)")
        ) from None
    finally:
        if bar is not None:
            bar.close()
    seconds = elapsed + time.perf_counter() - t0
    result = _assemble(cfg, bins, totals, sizes, rsp, seconds)
    if use_cache:
        save_arrays(final_path, r_mm=result.r_mm, rd=result.rd, rd_se=result.rd_se,
                  scalars=np.array([result.total_rd, result.total_rd_se, result.tt, result.tt_se,
                                    result.absorbed, result.absorbed_se, result.rsp, result.seconds]))
        with contextlib.suppress(OSError):
            partial_path.unlink()
    return result


def _batch_stats(values: np.ndarray, sizes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean per photon and its standard error from per-batch weight sums (batch method).

    values: (B, ...) weight sums per batch; sizes: (B,) photons per batch.
    """
    n = sizes.sum()
    mean = values.sum(axis=0) / n
    b = sizes.shape[0]
    if b < 2:
        return mean, np.full_like(mean, np.nan)
    shape = (-1,) + (1,) * (values.ndim - 1)
    per = values / sizes.reshape(shape)
    wts = (sizes / n).reshape(shape)
    var = np.sum(wts**2 * (per - mean) ** 2, axis=0) * b / (b - 1)
    return mean, np.sqrt(var)


def _assemble(cfg: MCConfig, bins, totals, sizes, rsp: float, seconds: float) -> MCResult:
    r_mm = (np.arange(cfg.nr) + 0.5) * cfg.dr_mm
    area = 2.0 * np.pi * r_mm * cfg.dr_mm
    mean_bins, se_bins = _batch_stats(bins, sizes)
    mean_tot, se_tot = _batch_stats(totals, sizes)
    return MCResult(
        config=cfg, r_mm=r_mm, rd=mean_bins / area, rd_se=se_bins / area,
        total_rd=float(mean_tot[0]), total_rd_se=float(se_tot[0]), tt=float(mean_tot[1]), tt_se=float(se_tot[1]),
        absorbed=float(mean_tot[2]), absorbed_se=float(se_tot[2]), rsp=rsp, seconds=seconds, photons=cfg.photons,
    )


def _load_result(cfg: MCConfig, path: Path) -> MCResult:
    with np.load(path) as z:
        s = z["scalars"]
        return MCResult(
            config=cfg, r_mm=z["r_mm"].copy(), rd=z["rd"].copy(), rd_se=z["rd_se"].copy(),
            total_rd=float(s[0]), total_rd_se=float(s[1]), tt=float(s[2]), tt_se=float(s[3]),
            absorbed=float(s[4]), absorbed_se=float(s[5]), rsp=float(s[6]), seconds=float(s[7]),
            photons=cfg.photons, extra={"cached": True},
        )


def _progress_bar(total: int, initial: int, label: str):
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="photon", unit_scale=True, desc=label or "MCML",
                smoothing=0.1, dynamic_ncols=True, leave=False, disable=None)


# ---- materials, many at once ----------------------------------------------------------------


def simulate_material(material: Material, channels: str = "all", *, photons: int = DEFAULT_PHOTONS, seed: int = 1,
                      threads: int | None = None, progress: bool = False, resume: bool = False,
                      use_cache: bool = True, batch_size: int = DEFAULT_BATCH) -> dict[str, MCResult]:
    """Simulate the requested channels ('R', 'G', 'B' or 'all') of a material: {channel: MCResult}.

    Each channel uses its own seed stream derived from ``seed`` and the channel index, on the
    supplement's grid shared by all three channels.
    """
    wanted = list(CHANNELS) if channels.strip().lower() == "all" else [channels.strip().upper()]
    for ch in wanted:
        if ch not in CHANNELS:
            raise ProfileError(f"channel must be R, G, B or all, got {channels!r}")
    out = {}
    for ch in wanted:
        c = CHANNELS.index(ch)
        cfg = config_for_material(material, c, photons, _channel_seed(seed, c), batch_size)
        out[ch] = simulate(cfg, threads=threads, progress=progress, resume=resume, use_cache=use_cache,
                           label=f"{material.name} {ch}")
    return out


def _channel_seed(seed: int, c: int) -> int:
    """Distinct, reproducible seeds per channel (the streams are further split per batch)."""
    return (int(seed) * 3 + c) % (2**63)


def montecarlo_rgb(material: Material, photons: int = 200_000, seed: int = 1, **kwargs):
    """An RGBProfile of simulated profiles (cached), usable wherever a profile is."""
    from .base import RGBProfile

    results = simulate_material(material, "all", photons=photons, seed=seed, **kwargs)
    chans = tuple(results[ch].profile() for ch in CHANNELS)
    return RGBProfile(chans, "montecarlo", material.name,  # type: ignore[arg-type]
                      {"material": material.to_dict(), "photons": photons, "seed": seed})


def _sweep_job(args):
    material, channels, photons, seed, batch_size = args
    return material.name, simulate_material(material, channels, photons=photons, seed=seed, threads=1,
                                            batch_size=batch_size)


def simulate_many(materials: list[Material], channels: str = "all", *, photons: int = DEFAULT_PHOTONS, seed: int = 1,
                  jobs: int = 1, batch_size: int = DEFAULT_BATCH, progress: bool = False,
                  scheduler: str | None = None, connect_timeout_s: float = 20.0) -> dict[str, dict[str, MCResult]]:
    """Simulate several materials across ``jobs`` local processes (one numba thread each), or
    across a dask.distributed cluster when ``scheduler`` (an address such as 'tcp://host:8786')
    is given (optional extra ``ssskit[cluster]``).

    Results depend only on each simulation's inputs and seed, so they are identical to a
    single-process run; on one machine finished simulations land in the shared cache.
    """
    if not (isinstance(jobs, int) and jobs >= 1):
        raise ProfileError(f"jobs must be a positive integer, got {jobs!r}")
    names = [m.name for m in materials]
    if len(set(names)) != len(names):
        raise ProfileError("material names in a sweep must be distinct")
    tasks = [(m, channels, photons, seed, batch_size) for m in materials]
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise ProfileError("a scheduler address needs dask.distributed: pip install 'ssskit[cluster]'") from None
        try:
            client = Client(scheduler, timeout=f"{connect_timeout_s}s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise ProfileError(f"cannot reach the dask scheduler at {scheduler!r}: {exc}") from None
        try:
            futures = client.map(_sweep_job, tasks, pure=False)
            return dict(client.gather(futures))
        finally:
            client.close()
    if jobs == 1 or len(tasks) == 1:
        return {m.name: simulate_material(m, channels, photons=photons, seed=seed, progress=progress,
                                          batch_size=batch_size) for m in materials}
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    ctx = mp.get_context("spawn")  # numba's threading layers are not fork-safe
    with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
        return dict(pool.map(_sweep_job, tasks))
