"""Monte Carlo diffuse reflectance profiles: an MCML engine (Wang, Jacques, Zheng 1995) with the
separable-SSS supplement's settings (section F).

One concept per module:

* :mod:`.config` -- what determines a simulation (:class:`MCLayer`, :class:`MCConfig`), the
  supplement's grid and configuration for a material, the arrays the engines take;
* :mod:`.engine_numba` -- the photon transport (numba, parallel over batches, compiled on first
  use and cached on disk); :mod:`.engine_numpy` -- the same algorithm in plain numpy;
* :mod:`.result` -- :class:`MCResult` assembled from per-batch tallies (batch-method errors);
* :mod:`.run` -- :func:`simulate`: batches in chunks, progress bar, a partial result kept on
  Ctrl-C (continued with ``resume``, discarded with ``restart``), the on-disk cache;
* :mod:`.sweep` -- a material's channels (:func:`simulate_material`), many materials
  (:func:`simulate_many`, local processes or dask.distributed);
* :mod:`.profile` -- simulated profiles as radial profiles (:class:`MonteCarloProfile`,
  :func:`montecarlo_rgb`).

Importing this package does not import numba: :func:`simulate` imports the engine when it runs
(not for a cached result), and ``simulate_numpy`` loads :mod:`.engine_numpy` on first access.
"""

from __future__ import annotations

from typing import Any

from ...errors import SimulationInterrupted
from .config import (
    DEFAULT_BATCH,
    DEFAULT_PHOTONS,
    ENGINE_VERSION,
    MCConfig,
    MCLayer,
    config_for_material,
    layer_arrays,
    supplement_grid,
)
from .profile import MonteCarloProfile, montecarlo_rgb
from .result import MCResult, assemble_result, batch_stats
from .run import rough_boundary_albedo, simulate
from .sweep import simulate_many, simulate_material


def __getattr__(name: str) -> Any:
    if name == "simulate_numpy":  # the numpy twin imports the numba engine's constants (and numba)
        from .engine_numpy import simulate_numpy

        return simulate_numpy
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "DEFAULT_BATCH",
    "DEFAULT_PHOTONS",
    "ENGINE_VERSION",
    "MCConfig",
    "MCLayer",
    "MCResult",
    "MonteCarloProfile",
    "SimulationInterrupted",
    "assemble_result",
    "batch_stats",
    "config_for_material",
    "layer_arrays",
    "montecarlo_rgb",
    "rough_boundary_albedo",
    "simulate",
    "simulate_many",
    "simulate_material",
    "simulate_numpy",
    "supplement_grid",
]
