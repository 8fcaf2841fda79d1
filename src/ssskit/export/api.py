"""One export request: :class:`ExportSettings` (what to write, from what), :data:`FORMATS` (the registry of
formats: each one's suffixes, writer, reader and the options that apply to it) and :func:`export`, which checks
the whole request before any work and writes one file atomically.

    >>> from ssskit.export import ExportSettings, export
    >>> export(ExportSettings(format="unreal", out="skin1_unreal.json", material="skin1"))   # doctest: +SKIP

An option is a field of :class:`ExportSettings`; None (or False for the flags) means "not given". A field
given that the request's format does not take (:attr:`Format.options`) is refused here, once, in one wording
(:func:`check_applies`). The material comes from one entry point, :func:`ssskit.export.readers.material_source`
(a preset, a material file, an engine file ssskit wrote, or artists' terms).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..errors import SsskitError
from ..settings import Settings
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


@dataclass(frozen=True)
class ExportSettings(Settings):
    """One export (module docstring): ``format`` (a name in :data:`FORMATS`) written to ``out``; the material
    (``material``: a preset, material file or engine file; or artists' terms ``albedo`` with ``mfp`` or ``dmfp``,
    and ``eta`` (default 1.3) and ``g`` (default 0)); its profile ``model`` (``photons``, ``grid_fraction``); a
    kernel format's ``kernel``, ``taps``, ``tap_method``; a whole shader's ``jitter``, ``depth_mode``,
    ``shader_pass`` (separable or transmission) and ``transmission_model``; ``unreal_form`` (mfp or dmfp, an
    Unreal .py), ``standard_surface`` (MaterialX) and ``no_transmission`` (Unreal, Unity)."""

    format: str
    out: str
    material: str | None = None
    albedo: RGB | None = None
    mfp: RGB | None = None
    dmfp: RGB | None = None
    eta: float | None = None
    g: float | None = None
    model: str | None = None
    photons: int | None = None
    grid_fraction: float | None = None
    kernel: str | None = None
    taps: int | None = None
    tap_method: str | None = None
    jitter: float | None = None
    depth_mode: str | None = None
    shader_pass: str | None = None
    transmission_model: str | None = None
    unreal_form: str | None = None
    standard_surface: bool = False
    no_transmission: bool = False

    def __post_init__(self) -> None:
        from ..io import check_suffix

        fmt = get_format(self.format)
        object.__setattr__(self, "format", fmt.name)
        object.__setattr__(self, "out", str(self.out))
        check_suffix(self.out, fmt.suffixes, f"--out for --format {fmt.name}")
        check_applies(self)

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


def check_applies(req: ExportSettings) -> None:
    """Every option given that the format does not take, refused in one wording naming the formats that take it
    (the unused-option rule, stated once)."""
    fmt = get_format(req.format)
    for name, flag in FLAGS.items():
        if req.given(name) and name not in COMMON and name not in fmt.options:
            takers = [f.name for _, f in FORMATS.items() if name in f.options]
            raise SsskitError(f"{flag} does not apply to --format {fmt.name} (it applies to --format "
                              f"{' or '.join(takers)})")


def export(request: ExportSettings) -> dict[str, Any]:
    """Write ``request`` (module docstring): every check first, then the work, then one atomic write. Returns
    the summary (format, out, material, model, and the format's own: parameters, kernel, taps...) with
    ``notes``: what the user should know (the engine's clamps that fired reading an engine file, transmission
    fields left out)."""
    from ..io import check_distinct, write_text
    from .readers import material_source

    fmt = get_format(request.format)
    if fmt.check is not None:
        fmt.check(request)
    source = material_source(request, needs=fmt.kind)
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


__all__ = ["COMMON", "ExportSettings", "FLAGS", "FORMATS", "Format", "Job", "check_applies", "export", "get_format"]
