"""Settings of one render: material, profile, kernel, taps, scene size, ground truths, the frame, the seed,
the backend, and one screen-space pass. A frozen tree, loadable from and savable to TOML/JSON (``ssskit
render --settings FILE``), used alike by the Python API and the CLI, and checked when made: a bad value
fails before any work starts.

The tree holds every value once. ``frame``, ``seed`` and ``backend`` are top-level (the G-buffer's frame
along the scene's paths and the pass's random numbers, the G-buffer render's and the pass's seed, who
runs the pass); the pass is one tagged member, ``pass_``, written as exactly one table named after it::

    material = "skin1"
    kernel = "svd:2"
    seed = 3
    backend = "numba"
    [separable]            # or [burley], or [adaptive]; none: the separable pass with its defaults
    jitter = 0.3

:data:`PASSES` names the passes (``separable``, ``burley``, ``burley-adaptive``) and their member classes
(:class:`SeparablePass`, :class:`BurleyPass`, :class:`AdaptivePass`); a member holds only how its pass
runs, and :meth:`RenderSettings.pass_settings`, :meth:`~RenderSettings.burley_settings` and
:meth:`~RenderSettings.adaptive_settings` give the complete settings the screen-space functions take.
Files in the layout before the single tree (``method = ...``, an ``[sss]`` table, ``frame``/``seed``/
``backend`` per pass) still load: they are migrated with a :class:`SettingsMigrated` warning, and a file
whose values the new tree cannot hold (two different seeds, a table the file's method never read that
holds values of its own) is refused with the reason.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass
from typing import Any, ClassVar

from ..backends import DEFAULT_BACKEND
from ..backends.transmission_plan import MODELS as TRANSMISSION_MODELS
from ..errors import SettingsError
from ..registry import Registry
from ..screenspace.adaptive import AdaptiveSettings
from ..screenspace.burley import BurleyParams, BurleySettings
from ..screenspace.settings import PassSettings
from ..quantities import (BURLEY_ALBEDO, FRAME, FRAMES, MFP_MM, PHOTONS, REFERENCE_SPP, REL_SE, SEED, SIZE_PX, SPP,
                          TAPS, TYPE, Choice, ErrorClass, Flag, Quantity, Rule, check_choice, check_instance,
                          check_keys, fail, refuse_twice, refuse_unused)
from ..screenspace.burley import BACKEND, BURLEY_SPP
from ..settings import PHOTONS_RANGE, SIZE_RANGE, TAP_RANGE, Settings, like, setting

#: the samples per pixel of an adaptive run's converged references (moving camera)
LIMIT_SPP = Quantity("limit_spp", 2, 131072, "", "samples per pixel of a moving run's converged references",
                     integer=True)
LIMIT_SPP_RANGE = (int(LIMIT_SPP.lo), int(LIMIT_SPP.hi))
DEFAULT_LIMIT_SPP = 2048
#: the values the tree holds once, which the layout before it kept per pass
SHARED = ("frame", "seed", "backend")
#: when the transmittance pass runs: auto (where the G-buffer has the light layers), on, off
TRANSMISSION = ("auto", "on", "off")
#: the lateral spread of the transmitted light: MCML's Tt(r) widths per thickness (backends.spread_plan), or none
TRANSMISSION_SPREADS = ("mcml", "off")


class SettingsMigrated(UserWarning):
    """A settings file in the layout before the single tree was read and migrated (the message says how)."""


@dataclass(frozen=True)
class SeparablePass(Settings):
    """How the separable pass runs (separable-SSS paper section 6, supplement E): ``jitter`` (a fraction
    of the kernel size, in [0, 1]; paper: 0.1, 0.3 for close-ups) and ``depth_mode`` (gaussian, follow,
    none, or None for the kernel's default). The kernel itself is the tree's ``kernel``, ``taps`` and
    ``tap_method``; frame, seed and backend are the tree's."""

    name: ClassVar[str] = "separable"
    table: ClassVar[str] = "separable"

    jitter: float = like(PassSettings, "jitter")
    depth_mode: str | None = like(PassSettings, "depth_mode")

    def settings(self, frame: int, seed: int, backend: str) -> PassSettings:
        """The complete :class:`~ssskit.screenspace.PassSettings` of the pass."""
        return PassSettings(jitter=self.jitter, depth_mode=self.depth_mode, frame=frame, seed=seed, backend=backend)


#: the Burley sampler's fields shared by the Burley pass and the adaptive run (BurleySettings' own)
_SAMPLING = ("sampler", "c", "sequence", "bleed", "stable", "mips", "mip_scale")
_B = BurleySettings()


@dataclass(frozen=True)
class _BurleySampling(Settings):
    """The Burley sampler (Xie 2020 Sec. 4.2, 5; :class:`~ssskit.screenspace.BurleySettings`): ``sampler``
    (exact, xie or golubev), ``c`` (Eq. 21's damping, for the xie sampler only), ``sequence``, ``bleed``,
    ``stable``, ``mips``, ``mip_scale``; and the Burley parameters ``albedo`` with ``dmfp_mm`` (Eq. 5,
    configuration 3: each a number or [R, G, B]; both or neither) instead of the material's Burley
    profile."""

    sampler: str = like(BurleySettings, "sampler")
    c: float = like(BurleySettings, "c", applies=("sampler", ("xie",)))
    sequence: str = like(BurleySettings, "sequence")
    bleed: float = like(BurleySettings, "bleed")
    stable: bool = like(BurleySettings, "stable")
    mips: bool = like(BurleySettings, "mips")
    mip_scale: float = like(BurleySettings, "mip_scale")
    albedo: tuple[float, float, float] | None = setting(BURLEY_ALBEDO, None, optional=True, rgb=True)
    dmfp_mm: tuple[float, float, float] | None = setting(MFP_MM, None, optional=True, rgb=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        if (self.albedo is None) != (self.dmfp_mm is None):
            raise SettingsError("albedo and dmfp_mm go together (Burley parameters from albedo and diffuse mean free "
                                "path, Xie 2020 Eq. 5); give both or neither")
        self.params()  # out-of-range parameters fail here

    def params(self) -> BurleyParams | None:
        """The Burley parameters given by ``albedo`` and ``dmfp_mm`` (Xie 2020 Eq. 5), or None."""
        if self.albedo is None or self.dmfp_mm is None:
            return None
        return BurleyParams.from_dmfp(self.albedo, self.dmfp_mm)

    def settings(self, frame: int, seed: int, backend: str, spp: int = _B.spp) -> BurleySettings:
        """The complete :class:`~ssskit.screenspace.BurleySettings` of the sampler."""
        return BurleySettings(**{k: getattr(self, k) for k in _SAMPLING}, spp=spp, frame=frame, seed=seed,
                              backend=backend)


@dataclass(frozen=True)
class BurleyPass(_BurleySampling):
    """The Burley Monte Carlo pass of one frame (Xie 2020): the sampler (:class:`_BurleySampling`'s fields)
    and ``spp``, its samples per pixel (the tree's ``spp`` is the G-buffer render's)."""

    name: ClassVar[str] = "burley"
    table: ClassVar[str] = "burley"

    spp: int = like(BurleySettings, "spp")


_ADAPTIVE = ("sigma0_sq", "kappa", "b_min", "b_max", "alpha", "correction", "gamma")


@dataclass(frozen=True)
class AdaptivePass(_BurleySampling):
    """The Burley pass over ``frames`` frames with the variance-guided sample counts of Xie 2020 Sec. 4.1
    (:func:`ssskit.pipeline.adaptive.render_adaptive`): the sampler (:class:`_BurleySampling`'s fields),
    the guiding phase (``sigma0_sq``, ``kappa``, ``b_min``, ``b_max``, ``alpha``, ``correction``,
    ``gamma``: :class:`~ssskit.screenspace.AdaptiveSettings`), ``static`` (keep the camera and lights at
    the tree's ``frame``; a G-buffer file is always static), ``taa`` (every frame through the global TAA,
    Karis 2014), and for a moving camera ``limit_spp`` (each frame's converged reference: exact sampler,
    no mips; default :data:`DEFAULT_LIMIT_SPP`) and ``disocclusion_spp`` (the count where the history is
    missing; default b_min, Xie 2020 Sec. 4.1.4)."""

    name: ClassVar[str] = "burley-adaptive"
    table: ClassVar[str] = "adaptive"

    sigma0_sq: float = like(AdaptiveSettings, "sigma0_sq")
    kappa: float = like(AdaptiveSettings, "kappa")
    b_min: int = like(AdaptiveSettings, "b_min")
    b_max: int = like(AdaptiveSettings, "b_max")
    alpha: float = like(AdaptiveSettings, "alpha")
    correction: str = like(AdaptiveSettings, "correction")
    gamma: float = like(AdaptiveSettings, "gamma")
    frames: int = setting(FRAMES, 16)
    static: bool = setting(Flag("static"), False)
    taa: bool = setting(Flag("taa"), True)
    limit_spp: int | None = setting(LIMIT_SPP, None, optional=True, applies=("camera", ("moving",)))
    disocclusion_spp: int | None = setting(BURLEY_SPP, None, optional=True, applies=("camera", ("moving",)))

    def __post_init__(self) -> None:
        super().__post_init__()
        budget = self.adaptive_settings().budget()  # b_min <= b_max
        if self.disocclusion_spp is not None:
            budget.check(self.disocclusion_spp, "disocclusion_spp", SettingsError)

    def situation(self) -> dict[str, str]:
        return {"camera": "static" if self.static else "moving"}

    def adaptive_settings(self) -> AdaptiveSettings:
        """The guiding phase's :class:`~ssskit.screenspace.AdaptiveSettings`."""
        return AdaptiveSettings(**{k: getattr(self, k) for k in _ADAPTIVE})

    @property
    def reference_spp(self) -> int:
        """The samples per pixel of a moving run's per-frame references (``limit_spp`` or its default)."""
        return DEFAULT_LIMIT_SPP if self.limit_spp is None else self.limit_spp


PassMember = SeparablePass | BurleyPass | AdaptivePass
#: the screen-space passes a render can run: name -> member class (its ``table`` names it in a file)
PASSES: Registry[type[SeparablePass] | type[BurleyPass] | type[AdaptivePass]] = Registry("pass", SettingsError)
for _cls in (SeparablePass, BurleyPass, AdaptivePass):
    PASSES.register(_cls.name, _cls)
_BY_TABLE = {cls.table: cls for _, cls in PASSES.items()}
#: the fields of the tree that describe the separable pass's profile and kernel
KERNEL_FIELDS = ("model", "photons", "kernel", "taps", "tap_method")  # declared applies=_SEPARABLE below


def _material(value: object, name: str, error: ErrorClass) -> str:
    """``value`` if it is a preset or names a material file (.toml / .json, or an existing path; the file is read,
    and checked, when the render loads it: making settings reads no file), else ``error``."""
    from pathlib import Path

    from ..materials import MATERIALS

    if not isinstance(value, str) or not value.strip():
        raise fail(error, TYPE, name=name, kind="a preset name or a material file", actual=repr(value))
    if value in MATERIALS or value.strip().lower().endswith((".toml", ".json")) or Path(value).exists():
        return value
    raise error(f"material {value!r} is neither a preset ({', '.join(MATERIALS.names())}) nor a material "
                f"file (.toml / .json)")


def _kernel(value: object, name: str, error: ErrorClass) -> str:
    """``value`` if it is a kernel method spec (:func:`ssskit.kernels.parse_method_spec`: unknown names and
    out-of-range parameters fail there), else ``error``."""
    from ..kernels import parse_method_spec

    if not isinstance(value, str):
        raise fail(error, TYPE, name=name, kind="a method spec such as 'svd:2'", actual=repr(value))
    parse_method_spec(value)
    return value


def _models() -> list[str]:
    from ..profiles import MODELS

    return MODELS.names()


def _tap_methods() -> tuple[str, ...]:
    from ..sampling.taps import TAP_METHODS

    return tuple(TAP_METHODS)


#: what the fields of the tree apply to: the separable pass (its profile and kernel), a reference, a transmittance
_SEPARABLE = ("pass", ("separable",))
_REFERENCE = ("reference", ("true",))
_TRANSMITS = ("transmission", ("auto", "on"))


@dataclass(frozen=True)
class RenderSettings(Settings):
    """One render and its comparison with ground truth (module docstring for the file layout).

    ``material``: a preset name or a material file; ``model``: the profile the separable pass's kernel
    approximates (dipole, burley, gaussians, montecarlo; ``photons`` for montecarlo); ``kernel``: a method
    spec ``name[:value]`` (``svd:2``, ``artist:production``, ``jimenez2012:17``...); ``taps``: taps per 1D
    pass (odd; an engine tap kernel such as jimenez2012 is built with this many taps); ``tap_method``:
    importance, uniform or quadratic; ``width`` x ``height`` and ``spp``: the built-in scene's G-buffer
    render; ``seed``: the G-buffer render's and the pass's random numbers; ``frame``: the frame along the
    scene's camera and light paths (and of the pass's random numbers); ``backend``: who runs the pass (a
    name from :data:`ssskit.backends.BACKENDS`); ``exact``: also the exact 2D convolution;
    ``reference``: also a volumetric path trace with at least ``reference_spp`` samples per pixel,
    continued until the relative standard error of its mean over the SSS mask is at most
    ``reference_rel_se`` or ``reference_max_spp`` is spent (:func:`ssskit.scenes.render_reference`);
    ``perceptual``: FLIP in the metrics; ``transmission``: the transmittance pass (light through thin parts,
    docs/transmission.md) added to the reflectance SSS of every pass (separable, Burley, and each frame of
    burley-adaptive): ``auto`` (where
    the G-buffer has the light layers: a G-buffer file or GBuffer that carries them; a scene's own G-buffer
    is rendered without them), ``on`` (a scene's G-buffer is rendered with them; a G-buffer without them is
    an error), ``off``; ``transmission_model``: its T(t), ``mcml`` (the fit of the material's MCML slab
    transmittance's scattered part), ``jimenez2010`` (Jimenez et al. 2010's skin Gaussians, [JWSG10]) or ``unreal``
    (Unreal Engine 5's subsurface-profile transmission, [UE58]); ``transmission_spread``: the lateral spread of
    the transmitted light, ``mcml`` (a Gaussian per pixel as wide as MCML's Tt(r) at its thickness,
    :mod:`ssskit.backends.spread_plan`; homogeneous materials) or ``off`` (the default: on the CPU the spread
    costs several times the separable pass per frame and moved the ear's region levels by <= 1.4 %,
    docs/transmission.md "Lateral spread"); ``mcml`` needs the transmittance pass (transmission auto or on);
    ``pass_``: the pass (:data:`PASSES`: :class:`SeparablePass`, :class:`BurleyPass` or :class:`AdaptivePass`),
    which :func:`ssskit.pipeline.render` runs. The kernel fields apply to the separable pass only: with another
    pass they must keep their defaults.
    """

    material: str = setting(Rule("material", _material), "skin1")
    model: str = setting(Choice("model", _models), "montecarlo", applies=_SEPARABLE)
    photons: int = setting(PHOTONS, 10_000_000, applies=_SEPARABLE)
    kernel: str = setting(Rule("kernel", _kernel), "preintegrated", applies=_SEPARABLE)
    taps: int = setting(TAPS, 7, applies=_SEPARABLE)
    tap_method: str = setting(Choice("tap_method", _tap_methods), "importance", applies=_SEPARABLE)
    width: int = setting(SIZE_PX, 256)
    height: int = setting(SIZE_PX, 192)
    spp: int = setting(SPP, 32)
    seed: int = setting(SEED, 0)
    frame: int = setting(FRAME, 0)
    backend: str = setting(BACKEND, DEFAULT_BACKEND)
    exact: bool = setting(Flag("exact"), True)
    reference: bool = setting(Flag("reference"), False)
    reference_spp: int = setting(REFERENCE_SPP, 64, applies=_REFERENCE)
    reference_max_spp: int = setting(REFERENCE_SPP, 1024, applies=_REFERENCE)
    reference_rel_se: float = setting(REL_SE, 0.01, applies=_REFERENCE)
    perceptual: bool = setting(Flag("perceptual"), True)
    transmission: str = setting(Choice("transmission", TRANSMISSION), "auto")
    transmission_model: str = setting(Choice("transmission_model", TRANSMISSION_MODELS), "mcml", applies=_TRANSMITS)
    transmission_spread: str = setting(Choice("transmission_spread", TRANSMISSION_SPREADS), "off", applies=_TRANSMITS)
    pass_: PassMember = setting(Rule("pass_", lambda v, name, error: check_instance(
        v, (SeparablePass, BurleyPass, AdaptivePass), name, error)), default_factory=SeparablePass)

    def __post_init__(self) -> None:
        super().__post_init__()
        REFERENCE_SPP.within(lo=self.reference_spp, reason="the reference renders at least reference_spp samples and "
                             "at most reference_max_spp").check(self.reference_max_spp, "reference_max_spp", SettingsError)

    def situation(self) -> dict[str, str]:
        return {"pass": self.pass_name, "reference": "true" if self.reference else "false"}

    @property
    def pass_name(self) -> str:
        """The pass this render runs: ``separable``, ``burley`` or ``burley-adaptive``."""
        return self.pass_.name

    def pass_settings(self) -> PassSettings:
        """The separable pass's complete :class:`~ssskit.screenspace.PassSettings` (frame, seed and backend
        from the tree)."""
        return self.pass_as(SeparablePass, "the separable one").settings(self.frame, self.seed, self.backend)

    def burley_settings(self, spp: int | None = None) -> BurleySettings:
        """The Burley sampler's complete :class:`~ssskit.screenspace.BurleySettings` (frame, seed and backend
        from the tree; ``spp``: the Burley pass's own unless given)."""
        p = self.pass_as((BurleyPass, AdaptivePass), "a Burley one")
        n = spp if spp is not None else (p.spp if isinstance(p, BurleyPass) else _B.spp)
        return p.settings(self.frame, self.seed, self.backend, n)

    def adaptive_settings(self) -> AdaptiveSettings:
        """The adaptive run's guiding phase (:class:`~ssskit.screenspace.AdaptiveSettings`)."""
        return self.pass_as(AdaptivePass, "burley-adaptive").adaptive_settings()

    def pass_as(self, kind: type | tuple[type, ...], what: str) -> Any:
        """The render pass's settings if they are a ``kind``, else a SettingsError: the render runs another pass."""
        if not isinstance(self.pass_, kind):
            raise SettingsError(f"this render runs the {self.pass_name} pass, not {what}")
        return self.pass_

    def to_dict(self) -> dict[str, Any]:
        """Plain data: the top-level values, and the pass as one table named after it."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            if f.name != "pass_":
                out[f.name] = getattr(self, f.name)
        out[self.pass_.table] = self.pass_.to_dict()
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "") -> "RenderSettings":
        """Build from plain data (module docstring's layout; the old layout is migrated with a
        :class:`SettingsMigrated` warning); unknown keys, wrong types and a second pass table are errors
        naming the key."""
        label = where or cls.__name__
        check_keys(data, label, error=SettingsError)  # a table (its keys: the fields and one pass table, below)
        data = _migrate(data, label)
        tables = [t for t in _BY_TABLE if t in data]
        if len(tables) > 1:
            raise SettingsError(f"{label}: one pass per render, but the settings have the tables "
                                f"{', '.join(f'[{t}]' for t in tables)}")
        kwargs = {k: v for k, v in data.items() if k not in _BY_TABLE}
        names = {f.name for f in dataclasses.fields(cls)} - {"pass_"}
        unknown = sorted(set(kwargs) - names)
        if unknown:
            raise SettingsError(f"{label}: unknown setting(s) {', '.join(unknown)} (known: {', '.join(sorted(names))}, "
                                f"and one pass table: {', '.join(f'[{t}]' for t in _BY_TABLE)})")
        kwargs = {k: (tuple(v) if isinstance(v, list) else v) for k, v in kwargs.items()}
        if tables:
            member = _BY_TABLE[tables[0]]
            kwargs["pass_"] = member.from_dict(data[tables[0]], where=f"{where + '.' if where else ''}{tables[0]}")
        return cls(**kwargs)


#: the profile fields' defaults of the layout before the single tree (every command now defaults to the
#: Monte Carlo model at 10^7 photons, issue 23); an old file of another pass holds them as written by save
_OLD_KERNEL_DEFAULTS = {"model": "dipole", "photons": 200_000}


def _migrate(data: dict[str, Any], label: str) -> dict[str, Any]:
    """The layout before the single tree (``method``, ``[sss]``, ``[burley]`` with frame/seed/backend) in
    the new one: the method's own table gives the pass its values and frame, seed and backend (the values
    that pass used); the other table must hold only its defaults (the old code never read it); a top-level
    ``seed`` that differs from the pass's is refused (the tree has one seed). Data without the old keys is
    returned unchanged."""
    burley = data.get("burley")
    old = "method" in data or "sss" in data or (isinstance(burley, dict) and any(k in burley for k in SHARED))
    if not old:
        return data
    d = dict(data)
    method = check_choice("method", d.pop("method", "separable"), ("separable", "burley"), SettingsError)
    tables = {"separable": d.pop("sss", {}), "burley": d.pop("burley", {})}  # (a table not given: empty)
    full = {"separable": PassSettings, "burley": BurleySettings}
    for name, table in tables.items():
        check_keys(table, f"{label}: [{'sss' if name == 'separable' else name}]", error=SettingsError)
    other = "burley" if method == "separable" else "separable"
    if tables[other]:
        defaults = full[other]().to_dict()
        extra = sorted(k for k, v in tables[other].items() if defaults.get(k, object()) != v)
        if extra:
            old_table = "sss" if other == "separable" else other
            refuse_unused([f"{label}: the [{old_table}] table's {', '.join(extra)}"], "method", (other,), method,
                          SettingsError)
    own = dict(tables[method])
    for key in SHARED:
        if key not in own:
            continue
        value = own.pop(key)
        if key in d and d[key] != value:  # (one setting now)
            own_table = "sss" if method == "separable" else method
            refuse_twice(f"{label}: {key} = {d[key]!r}", f"[{own_table}] {key} = {value!r}", key, SettingsError)
        d[key] = value
    d[_BY_TABLE["separable" if method == "separable" else "burley"].table] = own
    if method != "separable":  # the old layout's defaults, written out by save and never read by this pass
        for key, was_default in _OLD_KERNEL_DEFAULTS.items():
            if d.get(key) == was_default:
                del d[key]
    warnings.warn(SettingsMigrated(
        f"{label} is in the old settings layout (method, [sss], frame/seed/backend per pass); read as one tree: "
        f"frame, seed and backend once, the pass as its [{method}] table (RenderSettings.save writes the new layout)"),
        stacklevel=3)
    return d


__all__ = ["AdaptivePass", "BurleyPass", "DEFAULT_LIMIT_SPP", "KERNEL_FIELDS", "PASSES", "PHOTONS_RANGE", "PassMember",
           "RenderSettings", "SHARED", "SIZE_RANGE", "SeparablePass", "SettingsMigrated", "TAP_RANGE",
           "TRANSMISSION", "TRANSMISSION_MODELS", "TRANSMISSION_SPREADS"]
