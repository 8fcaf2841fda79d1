"""Separable kernel approximations of 2D diffusion profiles, reachable by name from one registry.

    >>> from ssskit.kernels import build_kernel
    >>> k = build_kernel("svd", profile, rank=3)          # doctest: +SKIP

Method specs on the command line are ``name`` or ``name:value`` where value is the method's
primary parameter (``svd:3``, ``gaussians:6``, ``guided:0``, ``artist:production``,
``jimenez2012:25``, ``burley_fit:ratio``).
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from functools import partial
from typing import Any, Callable

from ..errors import KernelError, check_keywords
from ..profiles.base import RGBProfile
from ..registry import Registry
from ..materials import ARTIST_PRESETS
from ..quantities import Choice, check_instance, refuse_unused
from .base import MAX_SVD_RANK, SVD_RANK, AnyKernel, Kernel, TapKernel, _check_grid, default_grid, load_kernel, save_kernel
from .burley_fit import ERROR_FUNCTION
from .guided import GUIDE_K
from .jimenez2012 import JIMENEZ_TAPS
from .methods import GAUSSIAN_COUNT


@dataclass(frozen=True)
class KernelMethod:
    """A registered method: builder(profile, cell_mm, n, **params), its primary parameter and its type."""

    name: str
    builder: Callable[..., AnyKernel]
    primary: str | None
    parse: Callable[[str], Any]
    description: str
    unit_energy: bool = False  # kernel normalised to 1 by construction (energy matched in evaluations)
    needs_profile: bool = True
    #: False for a fixed kernel that never reads a profile (jimenez2012): a material given to it is refused
    uses_profile: bool = True


def _svd(profile, cell_mm, n, rank=1, renormalise=False):
    from .methods import kernel_svd

    return kernel_svd(profile, cell_mm, n, rank=rank, renormalise=renormalise)


def _svd_l1(profile, cell_mm, n, rank=1):
    return _svd(profile, cell_mm, n, rank=rank, renormalise=True)


def _gaussians(profile, cell_mm, n, count=6):
    from .methods import kernel_gaussians

    return kernel_gaussians(profile, cell_mm, n, count=count)


def _preintegrated(profile, cell_mm, n):
    from .methods import kernel_preintegrated

    return kernel_preintegrated(profile, cell_mm, n)


def _preintegrated_svd(profile, cell_mm, n, rank=1):
    from .methods import kernel_preintegrated_svd

    return kernel_preintegrated_svd(profile, cell_mm, n, rank=rank)


def _artist(profile, cell_mm, n, preset="close fit", sigma_near=None, sigma_far=None, weight=None, match_energy=True):
    from .methods import kernel_artist

    return kernel_artist(profile, cell_mm, n, preset=preset, sigma_near=sigma_near, sigma_far=sigma_far,
                         weight=weight, match_energy=match_energy)


def _guided(profile, cell_mm, n, k=2.0, b=50.0):
    from .guided import kernel_guided

    return kernel_guided(profile, cell_mm, n, k=k, b=b)


def _jimenez(profile, cell_mm, n, taps=11, strength=None, falloff=None):
    from .jimenez2012 import JIMENEZ2012_FALLOFF, JIMENEZ2012_STRENGTH, kernel_jimenez2012

    src = {"model": profile.model, "name": profile.name} if profile is not None else None
    return kernel_jimenez2012(taps, JIMENEZ2012_STRENGTH if strength is None else strength,
                              JIMENEZ2012_FALLOFF if falloff is None else falloff, source=src)


def _burley_fit(profile, cell_mm, n, error="difference", model="jimenez2012"):
    from .burley_fit import kernel_burley_fit

    return kernel_burley_fit(profile, cell_mm, n, model=model, error=error)


def _parser(cast: Callable[[str], Any], kind: str) -> Callable[[str], Any]:
    """The parser of a spec's number (``svd:3``, ``guided:2.5``): ``cast`` of the text, or a KernelError."""
    def parse(text: str) -> Any:
        try:
            return cast(text)
        except ValueError:
            raise KernelError(f"expected {kind}, got {text!r}") from None
    return parse


_int, _float = _parser(int, "an integer"), _parser(float, "a number")


METHODS: Registry[KernelMethod] = Registry("kernel method", KernelError)
for _m in (
    KernelMethod("svd", _svd, "rank", _int, "rank-N truncated SVD of Rd (supplement Eqs. S.2-S.4)"),
    KernelMethod("svd_l1", _svd_l1, "rank", _int, "SVD rank-N with the L1 energy renormalisation (supplement B)"),
    KernelMethod("gaussians", _gaussians, "count", _int, "sum of N Gaussians with the L1 constraint (Eq. S.1)"),
    KernelMethod("preintegrated", _preintegrated, None, str, "pre-integrated rank-1 kernel (paper Eqs. 4-5)"),
    KernelMethod("preintegrated_svd", _preintegrated_svd, "rank", _int,
                 "pre-integrated kernel + rank-N SVD of the residual (paper Sec. 7, 'Limitations and future work')"),
    KernelMethod("artist", _artist, "preset", str,
                 "artist-friendly two-Gaussian model (paper Eq. 6): a Table 2 preset, or the preset 'fit' fitted to the "
                 "profile", unit_energy=False, needs_profile=False),
    KernelMethod("guided", _guided, "k", _float, "guided rank-1 optimisation (paper Eqs. 7-8, supplement S.7-S.9)"),
    KernelMethod("jimenez2012", _jimenez, "taps", _int, "the engines' separable-SSS tap kernel (Jimenez 2012)",
                 unit_energy=True, needs_profile=False, uses_profile=False),
    KernelMethod("burley_fit", _burley_fit, "error", str, "engine profile fitted to Burley (Xie 2020 A.1, Eqs. 25-27)"),
):
    METHODS.register(_m.name, _m)


#: an artist kernel's preset: a Table 2 preset, or "fit" (fitted to the profile)
ARTIST_PRESET = Choice("artist preset", lambda: [*ARTIST_PRESETS.names(), "fit"])


#: range checks of each method's primary parameter, applied when a spec is parsed (before any work)
PARAM_CHECKS: dict[tuple[str, str], Callable[[Any], Any]] = {
    ("svd", "rank"): partial(SVD_RANK.check, error=KernelError),
    ("svd_l1", "rank"): partial(SVD_RANK.check, error=KernelError),
    ("preintegrated_svd", "rank"): partial(SVD_RANK.check, name="residual rank", error=KernelError),
    ("gaussians", "count"): partial(GAUSSIAN_COUNT.check, error=KernelError),
    ("guided", "k"): partial(GUIDE_K.check, error=KernelError),
    ("jimenez2012", "taps"): partial(JIMENEZ_TAPS.check, name="jimenez2012 taps", error=KernelError),
    ("artist", "preset"): partial(ARTIST_PRESET.check, error=KernelError),
    ("burley_fit", "error"): partial(ERROR_FUNCTION.check, error=KernelError),
}


def check_params(method: KernelMethod, params: dict[str, Any]) -> None:
    """Range-check a method's parameters (see :data:`PARAM_CHECKS`), or a KernelError naming them."""
    for key, value in params.items():
        check = PARAM_CHECKS.get((method.name, key))
        if check is not None:
            check(value)


def refuse_profile_options(method: KernelMethod, given: list[str], material: bool, how: str) -> None:
    """The rule of a kernel's profile options, stated once for ``ssskit kernel`` and ``ssskit export`` (``how``:
    the option that names the method, ``--method`` or ``--kernel``; ``given``: the profile options given, as
    flags): a fixed engine kernel (``uses_profile`` False) reads no profile, so takes none of them; one that reads
    a profile only from a material (``needs_profile`` False) takes no model options without ``--material``."""
    if not method.uses_profile:  # (e.g. --method jimenez2012, whose fit to a material's profile is burley_fit)
        refuse_unused(given[:1], how, [n for n, m in METHODS.items() if m.uses_profile], method.name, KernelError)
    if not material and not method.needs_profile:
        refuse_unused([g for g in given if g not in ("--material", "--albedo")][:1], how,
                      [*(n for n, m in METHODS.items() if m.needs_profile), f"{method.name} with a --material"],
                      f"{method.name} without a --material", KernelError)


def parse_method_spec(spec: str) -> tuple[KernelMethod, dict[str, Any], str]:
    """``"svd:3"`` -> (the svd method, {"rank": 3}, "svd:3"); a bare name uses the method's defaults.

    The parameter is range-checked here, so a bad spec fails before any profile is computed.
    """
    text = str(spec).strip()
    name, _, value = text.partition(":")
    method = METHODS.get(name)
    params: dict[str, Any] = {}
    if value:
        if method.primary is None:  # (preintegrated:3)
            refuse_unused([f"the parameter :{value}"], "kernel method", [n for n, m in METHODS.items() if m.primary],
                          method.name, KernelError)
        else:
            params[method.primary] = method.parse(value)
            check_params(method, params)
    label = method.name + (f":{value}" if value else "")
    return method, params, label


def build_kernel(method: str, profile: RGBProfile | None = None, cell_mm: float | None = None, n: int | None = None,
                 **params: Any) -> AnyKernel:
    """Build a kernel by method name for ``profile`` (an :class:`~ssskit.profiles.RGBProfile`) on the grid
    (cell_mm, n) (each default when None: :func:`default_grid`); ``params`` are the method's keywords (an
    unknown one is a KernelError naming the known ones)."""
    m = METHODS.get(method)
    check_instance(profile, RGBProfile, f"the profile of kernel method {m.name!r} (profile_for_material(material, "
                   "model) makes one)", KernelError, optional=not m.needs_profile)  # (None: where it needs none)
    takes = list(inspect.signature(m.builder).parameters)[3:]  # (after profile, cell_mm, n)
    check_keywords(f"kernel method {m.name!r}", params, takes, KernelError)
    if cell_mm is None or n is None:
        if profile is None:
            cell_mm, n = (0.05 if cell_mm is None else cell_mm), (201 if n is None else n)
        else:
            dc, dn = default_grid(profile, 201 if n is None else n)
            cell_mm, n = (dc if cell_mm is None else cell_mm), (dn if n is None else n)
    _check_grid(cell_mm, n)
    return m.builder(profile, float(cell_mm), int(n), **params)


__all__ = [
    "AnyKernel",
    "Kernel",
    "KernelMethod",
    "MAX_SVD_RANK",
    "METHODS",
    "TapKernel",
    "build_kernel",
    "check_params",
    "default_grid",
    "load_kernel",
    "parse_method_spec",
    "refuse_profile_options",
    "save_kernel",
]
