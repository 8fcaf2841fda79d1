"""``ssskit export``: kernels and material parameters in the formats engines load.

Kernel formats (``--kernel`` required): ``hlsl`` / ``glsl`` (``float4 kernel[N]`` in the 2012
separable-SSS demo layout, offsets in mm), ``bn`` (the 2015 pre-integrated kernel files), ``json``
(ssskit's own kernel file). Parameter formats (a material required, no kernel): ``unreal``,
``unity``, ``blender`` (``.json``: the engine's parameters, with units, formulas, sources and what is
lost; ``.py``/``.asset``: the engine's own importable file) and ``materialx`` (``.mtlx``).

The material: ``--material`` (a preset, a material file, or an engine file ssskit reads back: an ssskit
engine JSON export, an HDRP .asset with ``--albedo``, a .mtlx), or artists' terms ``--albedo`` with
``--mfp`` or ``--dmfp`` (and ``--eta``, ``--g``). Engine files and artists' terms default to ``--model
burley`` (the Burley-fit inversion, no coefficients); ``--model montecarlo`` or ``dipole`` goes through the
Monte Carlo inversion of :mod:`ssskit.profiles.artist` to a physical material first. See :mod:`ssskit.export`
and docs/exports.md.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from ..errors import SsskitError

if TYPE_CHECKING:
    from ..kernels import KernelMethod
    from ..materials import LayeredMaterial, Material
    from ..profiles.base import RGBProfile
from .options import (
    DEFAULT_MODEL,
    DEFAULT_PHOTONS,
    TAP_RANGE,
    OutputFile,
    depth_mode_option,
    echo_json,
    examples,
    given,
    json_option,
    kernel_spec_option,
    model_option,
    photons_option,
    tap_method_option,
)
from .profiles import check_material_for_model, resolve_profile


def _formats():
    from ..export import FORMATS

    return FORMATS


def _all_suffixes() -> tuple[str, ...]:
    return tuple(sorted({s for suffixes, _ in _formats().values() for s in suffixes}))


SHADERS = ("glsl-shader", "hlsl-shader")


class ExportMaterial(click.ParamType):
    """--material of export: a preset or material file (checked as ``ssskit profile`` checks it), or an engine
    file (.asset, .mtlx, or a .json with an "engine" key), read later with the other checks."""

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
            get_material(text)
        except SsskitError as exc:
            self.fail(str(exc), param, ctx)
        return text


class Triple(click.ParamType):
    """A number or three comma-separated numbers (R,G,B)."""

    name = "R,G,B"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, tuple):
            return value
        parts = [p.strip() for p in str(value).split(",")]
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            self.fail(f"needs a number or 3 comma-separated numbers (R,G,B), got {value!r}", param, ctx)
        if len(vals) == 1:
            vals = vals * 3
        if len(vals) != 3:
            self.fail(f"needs 1 or 3 values (R,G,B), got {len(vals)}", param, ctx)
        return tuple(vals)


def _material_source(ctx: click.Context, fmt: str, material: str | None, albedo: tuple[float, float, float] | None, mfp: tuple[float, float, float] | None,
                     dmfp: tuple[float, float, float] | None, eta: float, g: float,
                     model: str) -> tuple[Callable[[], RGBProfile] | None, Material | None, str | None, str]:
    """Every material check, before any work: returns (profile factory, Material or None, name, model used).

    An engine file or artists' terms default to --model burley (no coefficients); montecarlo / dipole
    invert to a physical material first (ssskit.profiles.artist)."""
    from ..export.readers import is_engine_file, read_engine_file
    from ..profiles.artist import ArtistMaterial, burley_from_artist, check_artist, material_from_artist

    artist = albedo is not None or mfp is not None or dmfp is not None
    engine_file = material is not None and is_engine_file(material)
    for name, flag in (("eta", "--eta"), ("g", "--g")):
        if given(ctx, name) and not artist:
            raise SsskitError(f"{flag} belongs to artists' terms (--albedo with --mfp or --dmfp)")
    if artist and material is not None and not (engine_file and str(material).lower().endswith(".asset")):
        raise SsskitError("give the material once: --material or artists' terms (--albedo with --mfp or --dmfp)")
    if engine_file:  # an HDRP .asset takes --albedo only: the file holds the distances and the index
        for name, flag in (("mfp", "--mfp"), ("dmfp", "--dmfp"), ("eta", "--eta"), ("g", "--g")):
            if given(ctx, name):
                raise SsskitError(f"give the material once: {flag} does not apply to an engine file ({material}), "
                                  "which holds its own parameters (an HDRP .asset takes only --albedo)")
    model_given = given(ctx, "model")
    if engine_file or artist:
        used = model.lower() if model_given else "burley"
        if used not in ("burley", "montecarlo", "dipole"):
            raise SsskitError(f"--model {model} does not apply to an engine file or artists' terms (burley, the "
                              "Burley-fit inversion, or montecarlo / dipole through the Monte Carlo inversion)")
    if engine_file:
        if used == "burley":
            for opt in ("photons", "grid_fraction"):
                if given(ctx, opt):
                    raise SsskitError(f"--{opt.replace('_', '-')} needs --model montecarlo")
        assert material is not None  # (engine_file)
        src = read_engine_file(material, albedo=albedo)
        if albedo is not None:
            check_artist(albedo, src.d_mm, "dmfp", 1.0, 0.0)
        for clamp in src.clamps:  # read the way the engine reads it: say which of its clamps fired
            click.echo(f"ssskit: note: {material}: read as {src.engine} reads it: {clamp}", err=True)
        if used == "burley":
            return src.profile, None, src.name, used
        mat = src.material()
        return _physical(ctx, mat, used), mat, src.name, used
    if artist:
        if albedo is None or (mfp is None) == (dmfp is None):
            raise SsskitError("artists' terms need --albedo and one of --mfp (volume mean free path, mm) or --dmfp "
                              "(diffuse mean free path, mm)")
        kind, dist = ("mfp", mfp) if mfp is not None else ("dmfp", dmfp)
        assert dist is not None  # one of them, checked above
        art = ArtistMaterial("artist", albedo, dist, kind, eta, g)  # checks the domain
        if used == "burley":
            from ..profiles import BurleyProfile, RGBProfile

            a, d = burley_from_artist(art)
            chans = [BurleyProfile(float(x), float(y)) for x, y in zip(a, d)]
            prof = RGBProfile((chans[0], chans[1], chans[2]), "burley", "artist", {"inversion": f"Burley fit ({kind})"})
            return (lambda: prof), None, "artist", used
        mat = material_from_artist(art)
        return _physical(ctx, mat, used), mat, "artist", used
    return None, None, None, model


def _physical(ctx: click.Context, mat: Material, model: str) -> Callable[[], RGBProfile]:
    from .profiles import resolve_profile

    return resolve_profile(ctx, mat, model, {"photons": ("photons", ctx.params.get("photons")),
                                             "grid_fraction": ("grid_fraction", ctx.params.get("grid_fraction"))})


def _check_options(ctx: click.Context, fmt: str, kernel_spec: str | None, material: str | None, taps: int | None,
                   out: str) -> tuple[KernelMethod | None, dict[str, Any], int | None]:
    """Every combination check, before any work: returns (method, params, tap count for make_taps)."""
    from ..export import FORMATS
    from ..io import check_suffix
    from ..kernels import parse_method_spec

    suffixes, is_kernel = FORMATS[fmt]
    check_suffix(out, suffixes, f"--out for --format {fmt}")
    if fmt not in SHADERS:
        for name, flag in (("jitter", "--jitter"), ("depth_mode", "--depth-mode")):
            if given(ctx, name):
                raise SsskitError(f"{flag} applies to the whole shaders only (--format glsl-shader or hlsl-shader)")
    if fmt == "materialx":
        import importlib.util

        if importlib.util.find_spec("MaterialX") is None:
            raise SsskitError("--format materialx needs the materialx package (pip install 'materialx>=1.39,<1.40', the extra \".[materialx]\")")
    if fmt == "hlsl-shader":
        from ..export.shaders import tools_available

        ok, why = tools_available()
        if not ok:
            raise SsskitError(f"--format hlsl-shader needs glslangValidator and spirv-cross: {why}")
    if not is_kernel:
        for name in ("kernel_spec", "taps", "tap_method"):
            if given(ctx, name):
                flag = {"kernel_spec": "--kernel", "taps": "--taps", "tap_method": "--tap-method"}[name]
                raise SsskitError(f"{flag} does not apply to --format {fmt} (it exports material parameters)")
        if material is None:
            raise SsskitError(f"--material is required for --format {fmt}")
        return None, {}, None
    if kernel_spec is None:
        raise SsskitError(f"--kernel is required for --format {fmt}")
    m, params, _ = parse_method_spec(kernel_spec)
    tap_kernel = m.primary == "taps"  # an engine tap kernel (jimenez2012): built with its taps
    tap_count = None
    if taps is not None:
        if taps % 2 == 0:
            raise SsskitError(f"--taps must be odd (a centre tap), got {taps}")
        if tap_kernel:
            if params.get("taps", taps) != taps:
                raise SsskitError(f"--kernel {kernel_spec} and --taps {taps} disagree; give the tap count once")
            params["taps"] = taps
        elif fmt in ("bn", "json"):
            raise SsskitError(f"--taps does not apply to --format {fmt} (it writes the tabulated kernel itself)")
        else:
            tap_count = taps
    if given(ctx, "tap_method") and (tap_kernel or fmt in ("bn", "json")):
        why = f"the {m.name} kernel ships its own taps" if tap_kernel else f"--format {fmt} writes no taps"
        raise SsskitError(f"--tap-method does not apply: {why}")
    if fmt == "bn":
        if tap_kernel:
            raise SsskitError(f"--format bn holds a tabulated kernel on a uniform grid; {m.name} is a list of taps "
                              "(export it as hlsl, glsl or json)")
        if int(params.get("rank", 1)) != 1:
            raise SsskitError(f"--format bn holds one separable term; --kernel {kernel_spec} has rank "
                              f"{params['rank']} (use a rank-1 method such as preintegrated)")
    return m, params, tap_count


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
@click.option("--format", "fmt", required=True, type=click.Choice(list(_formats()), case_sensitive=False),
              help="hlsl/glsl: shader arrays (demo layout); bn: pre-integrated kernel file; json: ssskit kernel; "
                   "unreal/unity/blender: engine material parameters (.json) or the engine's file (.py script for Blender "
                   "and Unreal, .asset for Unity); materialx: an .mtlx (OpenPBR); glsl-shader/hlsl-shader: the whole "
                   "separable compute shader with the taps baked in (the gl backend's source).")
@click.option("--out", required=True, type=OutputFile(_all_suffixes()), help="Output file (suffix by format).")
@click.option("--material", type=ExportMaterial(), default=None,
              help="Preset name, material file, or an engine file to read back (an ssskit engine .json, an HDRP "
                   ".asset with --albedo, a .mtlx); not needed by jimenez2012 or artist presets.")
@click.option("--albedo", type=Triple(), default=None,
              help="Artists' terms: surface albedo R,G,B in (0, 1] (with --mfp or --dmfp, mm, in [1e-6, 1e6]).")
@click.option("--mfp", type=Triple(), default=None, help="Artists' terms: volume mean free path 1/sigma_t, mm.")
@click.option("--dmfp", type=Triple(), default=None,
              help="Artists' terms: diffuse mean free path, mm (Burley's convention: d = dmfp / (3.5 + 100 (A - 0.33)^4)).")
@click.option("--eta", type=float, default=1.3, show_default=True, help="Artists' terms: relative refractive index.")
@click.option("--g", type=float, default=0.0, show_default=True, help="Artists' terms: Henyey-Greenstein anisotropy.")
@click.option("--unreal-form", type=click.Choice(("mfp", "dmfp")), default="mfp", show_default=True,
              help="--format unreal with a .py: the Burley form the script writes (mfp: UE 5; dmfp: UE 4.25-4.27).")
@click.option("--standard-surface", is_flag=True, help="--format materialx: add a standard_surface beside OpenPBR.")
@click.option("--pass", "pass_", type=click.Choice(("separable", "transmission")), default="separable",
              show_default=True,
              help="--format glsl-shader/hlsl-shader: the separable pass (with --kernel) or the transmittance pass (light "
                   "through thin parts, docs/transmission.md: --material's model baked in).")
@click.option("--transmission-model", type=click.Choice(("mcml", "jimenez2010", "unreal")), default="mcml",
              show_default=True, help="--pass transmission: the transmittance model baked into the shader.")
@click.option("--no-transmission", is_flag=True,
              help="--format unreal/unity: leave out the transmission fields (by default fitted to the material's MCML "
                   "slab transmittance T(t), which a material not seen before simulates first: docs/transmission.md).")
@kernel_spec_option(help="Kernel method name[:value] for hlsl/glsl/bn/json (e.g. jimenez2012, preintegrated, svd:2).")
@click.option("--taps", type=click.IntRange(*TAP_RANGE), default=None,
              help="Taps per 1D pass (odd): jimenez2012's tap count, or the taps placed on a tabulated kernel "
                   "for hlsl/glsl [default: 11 for jimenez2012, 7 otherwise].")
@tap_method_option("importance")
@click.option("--jitter", type=click.FloatRange(0.0, 1.0), default=0.1, show_default=True,
              help="glsl-shader/hlsl-shader: taps within this fraction of the kernel size on rotated axes.")
@depth_mode_option()
@model_option(DEFAULT_MODEL, help="Profile model of the material (the source of the kernel or of the parameters); engine "
                             "files and artists' terms default to burley (Burley-fit inversion), montecarlo or "
                             "dipole invert them to a physical material first.")
@photons_option(DEFAULT_PHOTONS, help="--model montecarlo: photons per channel (shipped for the presets at 10^7, else cached).")
@click.option("--grid-fraction", type=click.FloatRange(0, 1, min_open=True, max_open=True), default=None,
              help="--model montecarlo: lengthen each channel's grid until it holds this fraction of the light.")
@json_option("Print one JSON object describing what was written.")
@click.pass_context
def export(ctx: click.Context, fmt: str, out: str, material: str | None, albedo: tuple[float, float, float] | None, mfp: tuple[float, float, float] | None,
           dmfp: tuple[float, float, float] | None, eta: float, g: float, unreal_form: str, standard_surface: bool,
           pass_: str, transmission_model: str, no_transmission: bool, kernel_spec: str | None,
           taps: int | None, tap_method: str, jitter: float, depth_mode: str | None, model: str, photons: int,
           grid_fraction: float | None, as_json: bool) -> None:
    """Write a kernel or a material's parameters in a format an engine loads."""
    from ..export import export_kernel
    from ..io import check_distinct, write_text
    from ..kernels import TapKernel, build_kernel

    fmt = fmt.lower()
    mat: Material | LayeredMaterial | None
    if given(ctx, "pass_") and fmt not in SHADERS:
        raise SsskitError("--pass applies to --format glsl-shader or hlsl-shader (the whole compute shaders)")
    if given(ctx, "transmission_model") and pass_ != "transmission":
        raise SsskitError("--transmission-model applies with --pass transmission")
    if pass_ == "transmission":
        _transmission_export(ctx, fmt, out, material, albedo, mfp, dmfp, eta, g, model, transmission_model, as_json)
        return
    prof, mat, src_name, used_model = _material_source(ctx, fmt, material, albedo, mfp, dmfp, eta, g, model)
    have_material = material is not None or prof is not None
    m, params, tap_count = _check_options(ctx, fmt, kernel_spec, "given" if have_material else None, taps, out)
    if m is not None and not m.uses_profile:  # as `ssskit kernel` refuses it: the header named an unused material
        for name, flag in (("material", "--material"), ("albedo", "--albedo"), ("model", "--model"),
                           ("photons", "--photons"), ("grid_fraction", "--grid-fraction")):
            if given(ctx, name):
                raise SsskitError(f"--kernel {m.name} is a fixed engine kernel that reads no profile; drop {flag} "
                                  "(its fit to a material's profile is --kernel burley_fit)")
    check_distinct(out, material, what="--out")
    suffix = str(out).lower().rsplit(".", 1)[-1]
    if given(ctx, "unreal_form") and not (fmt == "unreal" and suffix == "py"):
        raise SsskitError("--unreal-form applies to --format unreal with a .py output (the editor script)")
    if standard_surface and fmt != "materialx":
        raise SsskitError("--standard-surface applies to --format materialx")
    if no_transmission and fmt not in ("unreal", "unity"):
        raise SsskitError("--no-transmission applies to --format unreal or unity (the engines with transmission fields)")
    if prof is None:
        needs_profile = m is None or m.needs_profile
        if material is not None or needs_profile:
            check_material_for_model(ctx, material, model,
                                     needed_by=f"--format {fmt}" if m is None else f"--kernel {m.name}")
            prof = resolve_profile(ctx, material, model, {"photons": ("photons", photons),
                                                          "grid_fraction": ("grid_fraction", grid_fraction)})
        elif given(ctx, "model") or given(ctx, "photons") or given(ctx, "grid_fraction"):
            assert m is not None  # only a kernel method may need no profile
            raise SsskitError(f"--model, --photons and --grid-fraction need a --material (--kernel {m.name} "
                              "without one uses no profile)")
    if mat is None and material is not None and src_name is None:
        from ..materials import get_material

        mat = get_material(material)
    from ..materials import Material

    if m is None and not no_transmission and fmt in ("unreal", "unity") and isinstance(mat, Material):
        from ..profiles.montecarlo.transmission import check_table_request

        check_table_request(mat)  # the transmission table's domain, from sigma_t, before the profile's MCML
    # ---- work starts here: every check above has passed
    profile = prof() if prof is not None else None
    summary: dict[str, Any] = {"format": fmt, "out": out, "material": material if material is not None else src_name,
               "model": used_model if profile is not None else None}
    if m is None:
        assert profile is not None  # a parameter export has its material's profile
        text = _engine_file(profile, fmt, suffix, mat, src_name or (mat.name if mat is not None else "ssskit"),
                            unreal_form, standard_surface, summary, not no_transmission)
        write_text(out, text)
    else:
        kernel = build_kernel(m.name, profile, **params)
        comment = (f"ssskit export: {kernel_spec} kernel" + (f" of {profile.name} ({profile.model})" if profile else "")
                   + ("" if isinstance(kernel, TapKernel) or fmt not in ("hlsl", "glsl")
                      else f", {tap_count or 7} {tap_method} taps"))
        export_kernel(kernel, fmt, out, tap_count, tap_method, comment,
                      jitter if fmt in SHADERS else None, depth_mode)
        with_taps = fmt in ("hlsl", "glsl") + SHADERS
        summary.update(kernel=kernel_spec, rank=kernel.rank,
                       taps=kernel.taps if isinstance(kernel, TapKernel) else (tap_count or 7) if with_taps else None)
        if fmt in SHADERS:
            summary.update(jitter=jitter, depth_mode=depth_mode)
    if as_json:
        echo_json(summary)
    else:
        click.echo(f"# wrote {out} ({fmt})")


def _transmission_export(ctx: click.Context, fmt: str, out: str, material: str | None,
                         albedo: tuple[float, float, float] | None, mfp: tuple[float, float, float] | None,
                         dmfp: tuple[float, float, float] | None, eta: float, g: float, model: str, tmodel: str,
                         as_json: bool) -> None:
    """``--pass transmission``: the transmittance pass's compute shader with the material's model baked in
    (:func:`ssskit.export.shaders.transmission_shader`); every check before any work."""
    from ..export import FORMATS
    from ..io import check_distinct, check_suffix, write_text
    from ..materials import Material

    check_suffix(out, FORMATS[fmt][0], f"--out for --format {fmt}")
    for name, flag in (("kernel_spec", "--kernel"), ("taps", "--taps"), ("tap_method", "--tap-method"),
                       ("jitter", "--jitter"), ("depth_mode", "--depth-mode"), ("photons", "--photons"),
                       ("grid_fraction", "--grid-fraction"), ("unreal_form", "--unreal-form"),
                       ("standard_surface", "--standard-surface"), ("no_transmission", "--no-transmission")):
        if given(ctx, name):
            raise SsskitError(f"{flag} does not apply to --pass transmission (the shader bakes the material's "
                              "transmittance model)")
    if given(ctx, "model") and model.lower() != "montecarlo":  # the models read the material's MCML transport
        raise SsskitError(f"--model {model} does not apply to --pass transmission (the shader bakes the material's "
                          "transmittance model from its MCML transport; artists' terms take --model montecarlo, "
                          "the Monte Carlo inversion)")
    if fmt == "hlsl-shader":
        from ..export.shaders import tools_available

        ok, why = tools_available()
        if not ok:
            raise SsskitError(f"--format hlsl-shader needs glslangValidator and spirv-cross: {why}")
    mat: Any = None
    if tmodel != "jimenez2010":
        if material is None and albedo is None:
            raise SsskitError(f"--transmission-model {tmodel} needs --material (its {'MCML slab transmittance' if tmodel == 'mcml' else 'Burley profile'})")
        _, mat, _, _ = _material_source(ctx, fmt, material, albedo, mfp, dmfp, eta, g, model)
        if mat is None and material is not None:
            from ..export.readers import is_engine_file
            from ..materials import get_material

            mat = None if is_engine_file(material) else get_material(material)
        if not isinstance(mat, Material):
            raise SsskitError(f"--transmission-model {tmodel} needs a homogeneous material (a preset, a material file, "
                              "or artists' terms with --model montecarlo)")
    elif material is not None or albedo is not None:
        raise SsskitError("--transmission-model jimenez2010 takes no material (Jimenez et al. 2010's skin Gaussians)")
    check_distinct(out, material, what="--out")
    # ---- work starts here
    from ..export.shaders import transmission_shader
    from ..pipeline.transmission import slot_model
    from ..screenspace.transmission import transmission_plan

    plan = transmission_plan({1: slot_model(tmodel, mat)})
    stage = "fragment" if Path(out).suffix.lower() == ".frag" else "compute"  # .frag: the GLSL ES 3.00 form
    text = transmission_shader(plan, fmt.split("-")[0], stage)
    what = f"{tmodel} transmittance of {mat.name}" if mat is not None else f"{tmodel} transmittance"
    version, _, rest = text.partition("\n")  # GLSL ES: the #version line comes first, before any comment
    text = (f"{version}\n// ssskit export: the transmittance pass, {what}\n{rest}" if stage == "fragment"
            else f"// ssskit export: the transmittance pass, {what}\n{text}")
    write_text(out, text)
    if as_json:
        echo_json({"format": fmt, "out": out, "pass": "transmission", "transmission_model": tmodel,
                   "material": mat.name if mat is not None else None, "terms": plan.terms,
                   "table": bool(plan.has_lut)})
    else:
        click.echo(f"# wrote {out} ({fmt}, transmittance pass)")


def _engine_file(profile: RGBProfile, fmt: str, suffix: str, mat: Material | LayeredMaterial | None, name: str, unreal_form: str,
                 standard_surface: bool, summary: dict[str, Any], transmission: bool = True) -> str:
    """The text of a parameter export (the suffix picks the engine's own file or the JSON); ``transmission``: the
    engines' transmission fields fitted to a homogeneous material's MCML T(t)."""
    import json

    from ..export import engine_parameters, fit_burley
    from ..export.engines import TRANSMISSION_ENGINES
    from ..materials import Material

    if fmt == "materialx":
        from ..export.materialx import materialx_document

        a, d = fit_burley(profile)
        g = float(sum(mat.g) / 3.0) if isinstance(mat, Material) else 0.0  # (a layered one has no single g, eta)
        eta = float(mat.eta) if isinstance(mat, Material) else None
        summary["parameters"] = {"subsurface_color": a.tolist(), "d_mm": d.tolist()}
        return materialx_document(a, d, name, g, eta, standard_surface)
    table = None
    if transmission and fmt in TRANSMISSION_ENGINES and isinstance(mat, Material):
        from ..profiles.montecarlo.transmission import transmission_table

        table = transmission_table(mat)  # the material's MCML slab T(t) (cached like the profiles)
    data = engine_parameters(profile, fmt, mat, table)
    if fmt in TRANSMISSION_ENGINES and table is None:
        why = ("left out (--no-transmission)" if not transmission else
               "the transmission fields are fitted to a homogeneous material's MCML slab transmittance: give a preset "
               "or material file, or artists' terms with --model montecarlo")
        data["transmission"] = {"available": False, "why": why + "; the engine's defaults stay"}
        if transmission:  # asked for (no --no-transmission) but not there: say so where the user looks
            what = ("artists' terms and engine files under --model burley (their default, the Burley-fit inversion) "
                    "have no coefficients, so no slab transmittance" if mat is None else
                    "a layered material has no single slab transmittance")
            click.echo(f"ssskit: note: --format {fmt}: the transmission fields are left out, the engine's defaults "
                       f"stay: {what}; give --material (a preset or material file)"
                       + (" or --model montecarlo" if mat is None else "") + " for them", err=True)
    summary["parameters"] = {k: v for k, v in data.items() if k not in ("sources", "lost")}
    if suffix == "json":
        return json.dumps(data, indent=1) + "\n"
    asset = "".join(ch if ch.isalnum() or ch in "_-" else "_" for ch in name) or "ssskit"
    if fmt == "blender":
        from ..export.blender import blender_script

        return blender_script(data, asset)
    if fmt == "unreal":
        from ..export.unreal import unreal_script

        summary["unreal_form"] = unreal_form
        return unreal_script(data, f"SP_{asset}", unreal_form)
    from ..export.unity import unity_asset

    return unity_asset(data, asset)


__all__ = ["export"]
