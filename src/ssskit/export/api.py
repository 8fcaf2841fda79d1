"""One export request: :class:`ExportSettings` (what to write, from what), :data:`FORMATS` (the registry of
formats: each one's suffixes, writer, reader and the options that apply to it) and :func:`export`, which checks
the whole request before any work and writes one file atomically.

    >>> from ssskit.export import ExportSettings, export
    >>> export(ExportSettings(format="unreal", out="skin1_unreal.json", material="skin1"))   # doctest: +SKIP

An option is a field of :class:`ExportSettings`; None (or False for the flags) means "not given". A field
given that the request's format does not take (:attr:`Format.options`) is refused here, once, in one wording
(:meth:`ExportSettings.unused`). The material comes from one entry point, :func:`ssskit.export.readers.material_source`
(a preset, a material file, an engine file ssskit wrote, or artists' terms).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from ..quantities import ANISOTROPY, BURLEY_ALBEDO, ETA, FRACTION, MFP_MM, PHOTONS, TAPS, Choice, Flag
from ..settings import Settings, setting
from .registry import FORMATS, Format, get_format

#: the options of ExportSettings and their command-line flags (the wording of every refusal)
FLAGS = {"material": "--material", "albedo": "--albedo", "mfp": "--mfp", "dmfp": "--dmfp", "eta": "--eta",
         "g": "--g", "model": "--model", "photons": "--photons", "grid_fraction": "--grid-fraction",
         "kernel": "--kernel", "taps": "--taps", "tap_method": "--tap-method", "jitter": "--jitter",
         "depth_mode": "--depth-mode", "shader_pass": "--pass", "transmission_model": "--transmission-model",
         "unreal_form": "--unreal-form", "standard_surface": "--standard-surface",
         "no_transmission": "--no-transmission"}
#: options every format takes (the material and its profile)
COMMON = ("material", "albedo", "mfp", "dmfp", "eta", "g", "model", "photons", "grid_fraction")
KERNEL_OPTIONS = ("kernel", "taps", "tap_method")
SHADER_OPTIONS = KERNEL_OPTIONS + ("jitter", "depth_mode", "shader_pass", "transmission_model")
RGB = tuple[float, float, float]
#: the options a shader's pass (``--pass``, separable where not given) takes where not every pass does: the separable
#: pass's kernel and profile, the model of a material's profile or of the inversion of artists' terms, the
#: transmittance's model; and those a transmittance model (``--transmission-model``, mcml where not given) takes
PASS_OPTIONS: dict[str, dict[str, tuple[str, ...]]] = {
    "--pass": {**dict.fromkeys(KERNEL_OPTIONS + ("jitter", "depth_mode", "photons", "grid_fraction"), ("separable",)),
               "model": ("separable", "transmission"), "transmission_model": ("transmission",)},
    "--transmission-model": dict.fromkeys(("material", "albedo"), ("mcml", "unreal"))}
#: why an option does not apply there: what the pass's shader bakes in instead, what the model takes
PASS_BAKES = {"burley": "the shader bakes the material's Burley parameters: Xie 2020 Eq. 5, the searchlight "
                        "configuration", "transmission": "the shader bakes the material's transmittance model",
              "jimenez2010": "Jimenez et al. 2010's skin Gaussians: no material"}


def _models() -> list[str]:
    from ..profiles import MODELS

    return MODELS.names()


def _tap_methods() -> list[str]:
    from ..sampling.taps import TAP_METHODS

    return list(TAP_METHODS)


def _depth_modes() -> list[str]:
    from ..backends import DEPTH_MODES

    return list(DEPTH_MODES)


#: the fraction of the light a Monte Carlo grid holds: in (0, 1)
GRID_FRACTION = replace(FRACTION, name="grid_fraction", lo_open=True, hi_open=True,
                        reason="the share of the light the lengthened grid holds")


@dataclass(frozen=True)
class ExportSettings(Settings):
    """One export (module docstring): ``format`` (a name in :data:`FORMATS`) written to ``out``; the material
    (``material``: a preset, material file or engine file; or artists' terms ``albedo`` with ``mfp`` or ``dmfp``,
    and ``eta`` (default 1.3) and ``g`` (default 0)); its profile ``model`` (``photons``, ``grid_fraction``); a
    kernel format's ``kernel``, ``taps``, ``tap_method``; a whole shader's ``jitter``, ``depth_mode``,
    ``shader_pass`` (separable or transmission) and ``transmission_model``; ``unreal_form`` (mfp or dmfp, an
    Unreal .py), ``standard_surface`` (MaterialX) and ``no_transmission`` (Unreal, Unity). Each field is a
    quantity of :mod:`ssskit.quantities`; which format takes it is the format's (:attr:`Format.options`)."""

    format: str = setting(Choice("format", lambda: FORMATS.names()))
    out: str = setting(None)
    material: str | None = setting(None, None)
    albedo: RGB | None = setting(BURLEY_ALBEDO, None, optional=True, rgb=True)
    mfp: RGB | None = setting(MFP_MM, None, optional=True, rgb=True)
    dmfp: RGB | None = setting(MFP_MM, None, optional=True, rgb=True)
    eta: float | None = setting(ETA, None, optional=True)
    g: float | None = setting(ANISOTROPY, None, optional=True)
    model: str | None = setting(Choice("model", _models), None, optional=True)
    photons: int | None = setting(PHOTONS, None, optional=True)
    grid_fraction: float | None = setting(GRID_FRACTION, None, optional=True)
    kernel: str | None = setting(None, None)
    taps: int | None = setting(TAPS, None, optional=True)
    tap_method: str | None = setting(Choice("tap_method", _tap_methods), None, optional=True)
    jitter: float | None = setting(FRACTION, None, optional=True)
    depth_mode: str | None = setting(Choice("depth_mode", _depth_modes), None, optional=True)
    shader_pass: str | None = setting(Choice("shader_pass", ("separable", "transmission", "burley")), None,
                                      optional=True)
    transmission_model: str | None = setting(Choice("transmission_model", ("mcml", "jimenez2010", "unreal")), None,
                                             optional=True)
    unreal_form: str | None = setting(Choice("unreal_form", ("mfp", "dmfp")), None, optional=True)
    standard_surface: bool = setting(Flag("standard_surface"), False)
    no_transmission: bool = setting(Flag("no_transmission"), False)

    def __post_init__(self) -> None:
        from ..io import check_suffix

        super().__post_init__()  # every declared quantity, then check_applies (unused)
        object.__setattr__(self, "out", str(self.out))
        check_suffix(self.out, get_format(self.format).suffixes, f"--out for --format {self.format}")

    def unused(self) -> dict[tuple[str, tuple[str, ...], str], list[str]]:
        """Every option given that the format does not take (:attr:`Format.options`), by the formats that take
        it, then every one the shader's pass or the transmittance model does not take (:data:`PASS_OPTIONS`): what
        :meth:`~ssskit.settings.Settings.check_applies` refuses in the one wording of an unused option (``--eta
        applies to --format unity or unreal, not --format glsl``)."""
        fmt = get_format(self.format)
        now_by = {"--pass": self.shader_pass or "separable", "--transmission-model": self.transmission_model or "mcml"}
        unused: dict[tuple[str, tuple[str, ...], str], list[str]] = {}
        for name, flag in FLAGS.items():
            if self.given(name) and name not in COMMON and name not in fmt.options:
                takers = tuple(f.name for _, f in FORMATS.items() if name in f.options)
                unused.setdefault(("--format", takers, fmt.name), []).append(flag)
        for category, options in PASS_OPTIONS.items():
            now = now_by[category]
            for name, takers in options.items():
                if self.given(name) and now not in takers:
                    why = f" ({PASS_BAKES[now]})" if now in PASS_BAKES else ""
                    unused.setdefault((category, takers, now + why), []).append(FLAGS[name])
        return unused

    def given(self, name: str) -> bool:
        v = getattr(self, name)
        return v is not None and v is not False

    @property
    def suffix(self) -> str:
        return self.out.lower().rsplit(".", 1)[-1]


@dataclass
class Job:
    """What a writer gets: the checked request, the material source, and the summary it fills."""

    request: ExportSettings
    source: Any  # readers.Source
    summary: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def export(request: ExportSettings) -> dict[str, Any]:
    """Write ``request`` (module docstring): every check first, then the work, then one atomic write. Returns
    the summary (format, out, material, model, and the format's own: parameters, kernel, taps...) with
    ``notes``: what the user should know (the engine's clamps that fired reading an engine file, transmission
    fields left out)."""
    from ..io import check_distinct, write_text
    from .readers import material_source

    fmt = get_format(request.format)
    source = material_source(request, needs=fmt.kind)
    if fmt.check is not None:
        fmt.check(request, source)
    check_distinct(request.out, request.material, what="--out")
    job = Job(request, source)
    job.notes.extend(source.notes)
    # ---- work starts here: every check above has passed
    text = fmt.write(job)
    if text is not None:
        write_text(request.out, text)
    summary = {"format": fmt.name, "out": request.out, **job.summary}
    summary.setdefault("material", request.material if request.material is not None else source.name)
    summary["notes"] = job.notes
    return summary


__all__ = ["COMMON", "ExportSettings", "FLAGS", "FORMATS", "Format", "Job", "export", "get_format"]
