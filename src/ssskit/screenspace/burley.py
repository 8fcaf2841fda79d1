"""The screen-space Burley Monte Carlo SSS pass (Xie et al. 2020, Sec. 4.2 and 5), one frame.

For every pixel p inside the SSS mask, n samples q_j of Burley's normalized diffusion (Eq. 4) are
drawn in the plane through p perpendicular to the view axis: a radius r_j from the sampling channel
(the channel with the largest d) and a uniform angle, converted to pixels with p's own pixels per
mm (fx / z_p horizontally, fy / z_p vertically). The blurred diffuse value is the bilateral,
self-normalised estimator (Xie 2020, Eq. 24, from Eq. 19)

    L_c(p) = sum_j 1_s(q_j) r'_j R_c(r'_j) / pdf(r_j) E_c(q_j)  /  sum_j 1_s(q_j) r'_j R_c(r'_j) / pdf(r_j)

with r' = sqrt(r^2 + dz^2) (dz the depth difference in mm), pdf the radius density per unit radius
of the sampling channel (Eq. 20's derivative), and 1_s the indicator of the same profile id; the
albedo layer multiplies the result afterwards (:meth:`GBuffer.composite`). What every backend
computes, step by step (random numbers, samplers, weights): :mod:`ssskit.backends.burley_plan`.

Samplers: ``exact`` (Eq. 20 inverted exactly), ``xie`` (Eq. 21 with ``c``, default 2.5715; Unreal
ships 2.6; biased since the weights keep Burley's pdf) and ``golubev`` (Golubev 2018 / Unity HDRP:
stratified radii, golden-angle rotation, exact inverse, samples capped by the footprint).

    >>> from ssskit.screenspace import burley_sss, BurleyParams            # doctest: +SKIP
    >>> out = burley_sss(gbuffer, {1: BurleyParams.from_dmfp(0.8, (1.0, 0.5, 0.25))}, spp=32)  # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from typing import TYPE_CHECKING, Any

import numpy as np

from ..backends import BACKENDS, DEFAULT_BACKEND, get_backend
from ..backends.burley_plan import (
    BURLEY_SPP,
    SAMPLER,
    SEQUENCES,
    XIE_C,
    XIE_C_RANGE,
    XIE_MIP_SCALE,
    BurleyParams,
    BurleyPlan,
    SampleCounts,
    build_burley_plan,
)
from ..backends.plan import per_id, profile_ids
from ..errors import GBufferError, PassError
from ..quantities import FRACTION, FRAME, SCALE, SEED, Choice, Flag, check_instance
from ..settings import Settings, setting
from .gbuffer import GBuffer

if TYPE_CHECKING:
    from ..backends.base import Backend
    from ..materials import Material


#: the backend (the sampler, spp and c: ssskit.backends.burley_plan's quantities): what the pipeline's settings
#: declare too
BACKEND = Choice("backend", BACKENDS.names)


@dataclass(frozen=True)
class BurleySettings(Settings):
    """How the Burley pass runs (Xie 2020 Sec. 4.2, 5; :mod:`ssskit.backends.burley_plan`).

    ``sampler``: exact, xie or golubev; ``spp``: samples per pixel (1..65536; a per-pixel count image
    goes to :func:`burley_sss` as ``counts``); ``c``: Eq. 21's damping, in (2, 3); ``sequence``: r2
    (low-discrepancy, default) or random (independent samples); ``bleed``: weight of samples on
    another profile id, in [0, 1] (Unreal's BoundaryColorBleed; 0: none); ``frame`` and ``seed`` key
    the per-pixel random numbers; ``stable``: a pattern that stays the same across frames (a hash of
    pixel and depth instead of the frame, as HDRP does); ``mips``: fetch from a prefiltered pyramid
    of the diffuse layer (Eqs. 22-23; on by default as in Xie 2020, biased) with Eq. 22's
    ``mip_scale`` a (Xie: 1/16); ``backend``: a name from
    :data:`ssskit.backends.BACKENDS` whose ``passes`` include "burley".
    """

    sampler: str = setting(SAMPLER, "exact")
    spp: int = setting(BURLEY_SPP, 32)
    c: float = setting(XIE_C_RANGE, XIE_C)
    sequence: str = setting(Choice("sequence", SEQUENCES), "r2")
    bleed: float = setting(FRACTION, 0.0)
    frame: int = setting(FRAME, 0)
    seed: int = setting(SEED, 0)
    stable: bool = setting(Flag("stable"), False)
    mips: bool = setting(Flag("mips"), True)
    mip_scale: float = setting(SCALE, XIE_MIP_SCALE)
    backend: str = setting(BACKEND, DEFAULT_BACKEND)


def burley_params_for_material(material: Material | str, configuration: str = "searchlight") -> BurleyParams:
    """:class:`BurleyParams` of a Material or preset name through :func:`ssskit.profiles.burley_profile`
    (A: the dipole's total diffuse reflectance; d: the Eq. 5 ``configuration``, Xie 2020)."""
    from ..materials import get_material
    from ..profiles import burley_profile

    mat = get_material(material) if isinstance(material, str) else material
    return BurleyParams.from_profile(burley_profile(mat, configuration))


def _settings(settings: BurleySettings | None, overrides: dict[str, Any]) -> BurleySettings:
    base = check_instance(BurleySettings() if settings is None else settings, BurleySettings, "settings", PassError)
    return base.replace(**overrides) if overrides else base


def _params_by_id(params: BurleyParams | Mapping[int, BurleyParams], ids: Iterable[int]) -> dict[int, BurleyParams]:
    return per_id(params, BurleyParams, ids, "Burley parameters")


def burley_plan_for(params: BurleyParams | Mapping[int, BurleyParams], ids: Iterable[int], fx: float, fy: float, settings: BurleySettings) -> BurleyPlan:
    """The pass plan for profile ``ids`` (each with its :class:`BurleyParams`) under ``settings``."""
    return build_burley_plan(_params_by_id(params, ids), fx, fy, sampler=settings.sampler, sequence=settings.sequence,
                             c=settings.c, bleed=settings.bleed, frame=settings.frame, seed=settings.seed,
                             stable=settings.stable, mips=settings.mips, mip_scale=settings.mip_scale)


def burley_backend(name: str) -> Backend:
    """The named backend if it has the Burley pass, else a BackendError saying so."""
    return get_backend(name).require("burley")


def burley_sss(gbuffer: GBuffer, params_by_id: BurleyParams | Mapping[int, BurleyParams],
               settings: BurleySettings | None = None, *, counts: SampleCounts | None = None,
               **overrides: Any) -> np.ndarray:
    """Blurred diffuse layer (H, W, 3) float32 by the Burley Monte Carlo pass, every profile id at once.

    ``params_by_id``: one :class:`BurleyParams` for every region, or a mapping profile id -> params.
    ``settings`` (:class:`BurleySettings`; keyword ``overrides`` such as ``spp=64`` replace its fields).
    ``counts``: an optional (H, W) integer image of samples per pixel (the adaptive sampler's), used
    instead of ``settings.spp``. Pixels without SSS keep their diffuse value.
    """
    check_instance(gbuffer, GBuffer, "gbuffer", GBufferError)
    s = _settings(settings, overrides)
    backend = burley_backend(s.backend)
    ids = profile_ids(gbuffer.profile_id)
    cam = gbuffer.camera
    plan = burley_plan_for(params_by_id, ids, cam.fx, cam.fy, s)
    spp = s.spp if counts is None else counts
    out = backend.burley(plan, gbuffer.diffuse, gbuffer.depth_mm, plan.slot_map(gbuffer.profile_id), spp)
    return np.asarray(out, dtype=np.float32)


__all__ = ["BurleyParams", "BurleySettings", "burley_backend", "burley_params_for_material", "burley_plan_for",
           "burley_sss"]
