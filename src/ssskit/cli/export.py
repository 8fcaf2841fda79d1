"""``ssskit export``: kernels and material parameters in the formats engines load.

Kernel formats (``--kernel`` required): ``hlsl`` / ``glsl`` (``float4 kernel[N]`` in the 2012
separable-SSS demo layout, offsets in mm), ``bn`` (the 2015 pre-integrated kernel files), ``json``
(ssskit's own kernel file). Parameter formats (a material required, no kernel): ``unreal``,
``unity``, ``blender`` (``.json``: the engine's parameters, with units, formulas, sources and what is
lost; ``.py``/``.asset``: the engine's own importable file) and ``materialx`` (``.mtlx``).

The command maps its options onto one :class:`ssskit.export.ExportSettings` and calls
:func:`ssskit.export.export`, which checks and writes; the formats are the registry :data:`ssskit.export.FORMATS`.
The material: ``--material`` (a preset, a material file, or an engine file ssskit reads back: an ssskit
engine JSON export, a Blender or Unreal .py script, an HDRP .asset with ``--albedo``, a .mtlx), or artists' terms ``--albedo`` with
``--mfp`` or ``--dmfp`` (and ``--eta``, ``--g``). Engine files and artists' terms default to ``--model
burley`` (the Burley-fit inversion, no coefficients); ``--model montecarlo`` or ``dipole`` goes through the
Monte Carlo inversion of :mod:`ssskit.profiles.artist` to a physical material first. See :mod:`ssskit.export`
and docs/exports.md.
"""

from __future__ import annotations

from typing import Any

import click

from ..errors import SettingsError, SsskitError
from ..export.api import FLAGS, ExportSettings
from ..quantities import refuse_unused
from .options import (DEPTH_MODE, DEPTH_MODE_HELP, MODEL, TAP_METHOD, OutputFile, RGBFloats, echo_json, examples,
                      json_option, kernel_spec_option, setting_option)


def _formats() -> Any:
    from ..export import FORMATS

    return FORMATS


class ExportOut(OutputFile):
    """--out: a suffix of some registered format (looked up when parsed; the format's own suffixes are checked by
    ExportSettings), not a directory, its folder writable."""

    def __init__(self) -> None:
        super().__init__(())

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "FILE"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        self.suffixes = tuple(sorted({s for _, f in _formats().items() for s in f.suffixes}))
        return super().convert(value, param, ctx)


class FormatName(click.ParamType):
    """A name in the registry of formats (:data:`ssskit.export.FORMATS`), looked up when parsed, so a format
    registered after this module was imported is taken too."""

    name = "format"

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "[" + "|".join(_formats().names()) + "]"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        try:
            return _formats().get(str(value)).name
        except SsskitError as exc:
            self.fail(str(exc), param, ctx)


class ExportMaterial(click.ParamType):
    """--material of export: a preset, a material file or an engine file ssskit wrote, read by the one material
    entry point (:func:`ssskit.export.readers.material_source`) with the other checks."""

    name = "material"

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "NAME|FILE"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from ..export.readers import is_engine_file
        from ..materials import get_material

        text = str(value).strip()
        if text and is_engine_file(text):
            return text
        try:
            for part in text.split(",") if "," in text else [text]:  # several: --format babylon (one scene)
                get_material(part.strip())
        except SsskitError as exc:
            self.fail(str(exc), param, ctx)
        return text


@click.command(epilog=examples(
    "ssskit export --kernel jimenez2012 --taps 11 --format hlsl --out SeparableSSSKernel.hlsl",
    "ssskit export --material skin1 --kernel preintegrated --taps 9 --format glsl --out kernel.glsl",
    "ssskit export --material skin1 --kernel preintegrated --format bn --out skin1.bn",
    "ssskit export --material marble --format unreal --out marble_unreal.json",
    "ssskit export --material ketchup --model burley --format unity --out ketchup_hdrp.json",
    "ssskit export --material skin1 --format blender --out skin1_blender.py",
    "ssskit export --material marble --format unreal --out marble_unreal.py",
    "ssskit export --material skin1 --format unity --out Skin1.asset",
    "ssskit export --material skin1 --format materialx --standard-surface --out skin1.mtlx",
    "ssskit export --albedo 0.44,0.22,0.12 --dmfp 4.9,2.4,1.4 --model montecarlo --format blender --out a.py",
    "ssskit export --material skin1_unreal.json --format unity --out Skin1.asset",
    "ssskit export --material skin1 --kernel preintegrated --taps 7 --format glsl-shader --out sss.comp",
    "ssskit export --material skin1 --format glsl-shader --pass transmission --out transmission.comp"))
@click.option("--format", "fmt", required=True, type=FormatName(),
              help="; ".join(f"{f.name}: {f.description}" for _, f in _formats().items()) + ".")
@click.option("--out", required=True, type=ExportOut(), help="Output file (suffix by format).")
@click.option("--material", type=ExportMaterial(), default=None,
              help="Preset name, material file, or an engine file to read back (an ssskit engine .json or .py script, "
                   "an HDRP .asset with --albedo, a .mtlx); not needed by jimenez2012 or artist presets.")
@setting_option(ExportSettings, "albedo", type=RGBFloats(), help="Artists' terms: surface albedo R,G,B (with --mfp or "
                                                                   "--dmfp)")
@setting_option(ExportSettings, "mfp", type=RGBFloats(), help="Artists' terms: volume mean free path 1/sigma_t")
@setting_option(ExportSettings, "dmfp", type=RGBFloats(),
                help="Artists' terms: diffuse mean free path (Burley's convention: d = dmfp / (3.5 + 100 (A - 0.33)^4))")
@setting_option(ExportSettings, "eta",
                help="Artists' terms: relative refractive index, written as the engine's IOR [default: 1.3]")
@setting_option(ExportSettings, "g", help="Artists' terms: Henyey-Greenstein anisotropy [default: 0]")
@setting_option(ExportSettings, "unreal_form",
                help="--format unreal with a .py: the Burley form the script writes (mfp: UE 5, the default; dmfp: UE "
                     "4.25-4.27).")
@setting_option(ExportSettings, "standard_surface", help="--format materialx: add a standard_surface beside OpenPBR.")
@setting_option(ExportSettings, "shader_pass", "--pass", "shader_pass",
                help="--format glsl-shader/hlsl-shader: the separable pass (with --kernel) or the transmittance pass "
                     "(light through thin parts, docs/transmission.md: --material's model baked in); --format "
                     "glsl-shader: the Burley Monte Carlo pass (Xie 2020, --material's Burley parameters baked in).")
@setting_option(ExportSettings, "transmission_model",
                help="--pass transmission: the transmittance model baked into the shader [default: mcml].")
@setting_option(ExportSettings, "no_transmission",
                help="--format unreal/unity: leave out the transmission fields (by default fitted to the material's "
                     "MCML slab transmittance T(t), which a material not seen before simulates first: "
                     "docs/transmission.md).")
@kernel_spec_option(help="Kernel method name[:value] for hlsl/glsl/bn/json (e.g. jimenez2012, preintegrated, svd:2).")
@setting_option(ExportSettings, "taps",
                help="Taps per 1D pass: jimenez2012's tap count, or the taps placed on a tabulated kernel for hlsl/glsl "
                     "[default: 11 for jimenez2012, 7 otherwise]")
@setting_option(ExportSettings, "tap_method", type=TAP_METHOD, help="Tap placement.")
@setting_option(ExportSettings, "jitter", help="glsl-shader/hlsl-shader: taps within this fraction of the kernel size "
                                               "on rotated axes [default: 0.1]")
@setting_option(ExportSettings, "depth_mode", type=DEPTH_MODE, help=DEPTH_MODE_HELP)
@setting_option(ExportSettings, "model", type=MODEL,
                help="Profile model of the material (the source of the kernel or of the parameters); engine files and "
                     "artists' terms default to burley (Burley-fit inversion), montecarlo or dipole invert them to a "
                     "physical material first [default: montecarlo; burley for engine files and artists' terms].")
@setting_option(ExportSettings, "photons", help="--model montecarlo: photons per channel (shipped for the presets at "
                                                "10^7, else cached) [default: 10^7]")
@setting_option(ExportSettings, "grid_fraction",
                help="--model montecarlo: lengthen each channel's grid until it holds this fraction of the light")
@json_option("Print one JSON object describing what was written.")
def export(fmt: str, out: str, as_json: bool, kernel_spec: str | None, **options: Any) -> None:
    """Write a kernel or a material's parameters in a format an engine loads."""
    from ..export import export as run

    given = {k: v for k, v in options.items() if v is not None and v is not False}
    material = given.get("material")
    try:
        if material is not None and "," in material:  # one Babylon.js scene's materials
            if fmt != "babylon":  # (one scene's profiles)
                refuse_unused(["--material with several names (a,b,c)"], "--format", ("babylon",), fmt)
            from ..export.babylon import export_scene

            given.pop("material")
            if kernel_spec is not None:
                given["kernel"] = kernel_spec
            summary = export_scene([m.strip() for m in material.split(",")], out, **given)
        else:
            summary = run(ExportSettings(format=fmt, out=out, kernel=kernel_spec, **given))
    except SettingsError as exc:  # a field's value refused by ExportSettings (its quantity): named by its option
        field = str(exc).split(" ", 1)[0]
        if field in given and not str(exc).startswith("--"):
            raise SettingsError(f"{FLAGS[field]}: {exc}") from None
        raise
    for note in summary.pop("notes"):
        click.echo(f"ssskit: note: {note}", err=True)
    if as_json:
        echo_json(summary)
    else:
        what = {"transmission": ", transmittance pass", "burley": ", Burley pass"}.get(summary.get("pass") or "", "")
        click.echo(f"# wrote {out} ({summary['format']}{what})")


__all__ = ["export"]
