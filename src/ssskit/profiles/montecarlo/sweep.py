"""Simulating materials: the three channels of one material (:func:`simulate_material`) and many
materials across local processes or a dask.distributed cluster (:func:`simulate_many`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...errors import ProfileError
from ...materials import CHANNELS, LayeredMaterial, Material
from ...progress import add_to_total
from ...quantities import Choice, Quantity, checks
from ..domain import check_montecarlo
from .config import DEFAULT_BATCH, DEFAULT_PHOTONS, SUPPLEMENT_GRID_MFP, channel_seed, config_for_material
from .result import MCResult
from .run import check_resume, photons_bar, simulate

if TYPE_CHECKING:
    from distributed import Client


#: the share of the supplement's grid a sweep simulates
GRID_FRACTION = Quantity("grid fraction", 0.0, 1.0, "", "a share of the supplement's grid", lo_open=True, hi_open=True)

@checks(ProfileError, channels=Choice("channels", (*CHANNELS, "all")), grid_fraction=(GRID_FRACTION, "grid fraction"))
def simulate_material(material: Material | LayeredMaterial, channels: str = "all", *, photons: int = DEFAULT_PHOTONS,
                      seed: int = 1, threads: int | None = None, progress: bool | None = None, resume: bool = False,
                      restart: bool = False, use_cache: bool = True, batch_size: int = DEFAULT_BATCH,
                      grid_fraction: float | None = None, roughness: float = 0.0,
                      shipped: bool = True, backend: str = "numba") -> dict[str, MCResult]:
    """Simulate the requested channels ('R', 'G', 'B' or 'all') of a material: {channel: MCResult}.

    Each channel uses its own seed stream derived from ``seed`` and the channel index, on the
    supplement's grid shared by all three channels. ``resume`` / ``restart`` continue / discard
    the partial results of an interrupted run (see :func:`~ssskit.profiles.montecarlo.simulate`).

    ``grid_fraction`` (e.g. 0.999): a channel whose light beyond the supplement's 32-MFP grid is
    more than 1 - grid_fraction of its total is simulated again on a grid twice as long (same seed,
    so the same photons: only where they are tallied changes), until the grid holds that fraction
    (Marble and Cream lose ~1% beyond 32 MFP).

    ``roughness`` > 0: a rough top surface with that Beckmann alpha (the path-traced references'
    single-scattering rough dielectric, :class:`~ssskit.profiles.montecarlo.MCConfig`) instead of
    the supplement's smooth one. ``shipped=False``: simulate even what the package ships
    (:mod:`.shipped`). ``backend``: the engine, "numba" or "gl" (:func:`~.run.simulate`).
    """
    wanted = list(CHANNELS) if channels == "all" else [channels]
    if progress is None:
        from ...progress import reporting_active

        progress = reporting_active()
    # one bar for every channel, so its estimate of the time left covers them all (each run takes out what
    # it does not simulate; a longer grid adds its photons)
    bar = photons_bar(photons * len(wanted), 0, f"{material.name} {'/'.join(wanted)}") if progress else None
    out = {}
    try:
        for ch in wanted:
            c = CHANNELS.index(ch)
            extent = SUPPLEMENT_GRID_MFP
            while True:
                cfg = config_for_material(material, c, photons, channel_seed(seed, c), batch_size, extent, roughness)
                if bar is not None:
                    bar.set_postfix_str(f"channel {ch}")
                res = simulate(cfg, threads=threads, progress=progress, resume=resume, restart=restart,
                               use_cache=use_cache, label=f"{material.name} {ch}", shipped=shipped, backend=backend,
                               shared_bar=bar)
                if grid_fraction is None or res.overflow <= (1.0 - grid_fraction) * res.total_rd or extent >= 64 * 32:
                    break
                extent *= 2.0
                if bar is not None:
                    add_to_total(bar, photons)
            out[ch] = res
    finally:
        if bar is not None:
            bar.close()
    return out


def _sweep_job(args):
    material, channels, photons, seed, batch_size, resume, restart, roughness, progress = args
    if progress:  # a worker's lines go to the shared stderr; redrawn bars of several processes would garble it
        import os

        os.environ["SSSKIT_PROGRESS"] = "lines"
    return material.name, simulate_material(material, channels, photons=photons, seed=seed, threads=1,
                                            batch_size=batch_size, resume=resume, restart=restart,
                                            roughness=roughness, progress=progress)


#: the longest a sweep waits without a progress line (seconds)
HEARTBEAT_S = 5.0


def _gather(futures: list, names: list[str], progress: bool, where: str) -> dict[str, dict[str, MCResult]]:
    """Wait for the sweep's futures (concurrent.futures or dask.distributed ones), saying on stderr
    which materials are done, at least every :data:`HEARTBEAT_S` seconds while any runs."""
    import time

    from ...io import say

    t0 = last = time.perf_counter()
    pending = dict(zip(names, futures))
    out: dict[str, dict[str, MCResult]] = {}
    while pending:
        finished = [n for n, f in pending.items() if f.done()]
        for n in finished:
            out[n] = pending.pop(n).result()[1]  # re-raises a worker's error
            if progress:
                say(f"sweep ({where}): {n} done, {len(out)} of {len(names)} materials ({time.perf_counter() - t0:.0f} s)")
                last = time.perf_counter()
        if pending and progress and time.perf_counter() - last >= HEARTBEAT_S:
            say(f"sweep ({where}): {len(out)} of {len(names)} materials done, running {', '.join(pending)} "
                f"({time.perf_counter() - t0:.0f} s)")
            last = time.perf_counter()
        if pending:
            time.sleep(0.2)
    return {n: out[n] for n in names}


def check_scheduler(address: str, timeout_s: float = 20.0) -> Client:
    """A dask.distributed ``Client`` connected to the scheduler at ``address``, or a ProfileError unless one
    answers within ``timeout_s`` seconds: dask's own ``identity`` call (``distributed.core.rpc``) under one
    deadline for the connection and the answer, then the client's own connection under the same rule (a scheduler
    gone in between cannot be reached). Something else listening there (a web server, any other service) is
    refused in one line: dask's client read the first bytes of its answer as frame lengths (an HTTP reply asked
    for 3.07 EiB: MemoryError) or waited for ever on a server that says nothing."""
    import asyncio

    from distributed import Client
    from distributed.core import rpc

    async def identity() -> object:
        remote = rpc(address, timeout=timeout_s)
        try:
            return await remote.identity()
        finally:
            await remote.close_rpc()

    what = f"the dask scheduler address {address!r}"
    try:
        answer = asyncio.run(asyncio.wait_for(identity(), timeout_s))
        if isinstance(answer, dict) and answer.get("type") == "Scheduler":
            return Client(address, timeout=f"{timeout_s}s")
    except ValueError as exc:  # a malformed address: dask's own words (missing port, unknown scheme)
        if "address" in str(exc) or "scheme" in str(exc):
            raise ProfileError(f"{what} is not valid: {exc}") from None
    except asyncio.TimeoutError:
        raise ProfileError(f"no dask scheduler answered at {address!r} within {timeout_s:g} s (connect timeout)") from None
    except OSError as exc:
        raise ProfileError(f"cannot reach the dask scheduler at {address!r}: {exc}") from None
    except Exception:  # noqa: BLE001 - what another protocol's bytes make of dask's decoder (MemoryError, ...)
        pass
    raise ProfileError(f"what answers at {address!r} is not a dask scheduler (it does not speak dask's protocol)")


def simulate_many(materials: list[Material | LayeredMaterial], channels: str = "all", *,
                  photons: int = DEFAULT_PHOTONS, seed: int = 1, jobs: int = 1, batch_size: int = DEFAULT_BATCH,
                  progress: bool = False, resume: bool = False, restart: bool = False, scheduler: str | None = None,
                  connect_timeout_s: float = 20.0, roughness: float = 0.0) -> dict[str, dict[str, MCResult]]:
    """Simulate several materials across ``jobs`` local processes (one numba thread each), or
    across a dask.distributed cluster when ``scheduler`` (an address such as 'tcp://host:8786')
    is given (optional extra ``ssskit[cluster]``).

    Results depend only on each simulation's inputs and seed, so they are identical to a
    single-process run. ``progress``: lines on stderr, from the workers (local processes) and from this
    process as materials finish, at least every few seconds; on one machine finished simulations land in the shared cache, and so do
    the partial results of an interrupted sweep, which ``resume`` / ``restart`` continue / discard.
    """
    Quantity("jobs", 1, 2**31 - 1, "", "processes of a sweep", integer=True).check(jobs, "jobs", ProfileError)
    check_resume(resume, restart)
    names = [m.name for m in materials]
    if len(set(names)) != len(names):
        raise ProfileError("material names in a sweep must be distinct")
    for m in materials:  # every material in the model's domain (scattering among it) before any work
        check_montecarlo(m)
    tasks = [(m, channels, photons, seed, batch_size, resume, restart, roughness, progress) for m in materials]
    if scheduler is not None:
        try:
            import distributed  # noqa: F401 - the optional extra check_scheduler needs
        except ImportError:
            raise ProfileError("a scheduler address needs dask.distributed: pip install 'ssskit[cluster]'") from None
        client = check_scheduler(scheduler, connect_timeout_s)
        try:
            futures = client.map(_sweep_job, tasks, pure=False)
            return _gather(futures, names, progress, f"dask at {scheduler}")
        finally:
            client.close()
    if jobs == 1 or len(tasks) == 1:
        return {m.name: simulate_material(m, channels, photons=photons, seed=seed, progress=progress,
                                          resume=resume, restart=restart, batch_size=batch_size)
                for m in materials}
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    ctx = mp.get_context("spawn")  # numba's threading layers are not fork-safe
    with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
        if progress:
            from ...io import say

            say(f"sweep: {len(tasks)} materials on {min(jobs, len(tasks))} local processes (starting them takes a few seconds)")
        return _gather([pool.submit(_sweep_job, t) for t in tasks], names, progress, f"{jobs} processes")


__all__ = ["check_scheduler", "simulate_many", "simulate_material"]
