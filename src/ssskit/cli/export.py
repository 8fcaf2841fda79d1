"""``ssskit export``: kernels and material parameters in the formats engines load.

Kernel formats (``--kernel`` required): ``hlsl`` / ``glsl`` (``float4 kernel[N]`` in the 2012
separable-SSS demo layout, offsets in mm), ``bn`` (the 2015 pre-integrated kernel files), ``json``
(ssskit's own kernel file). Parameter formats (``--material`` required, no kernel): ``unreal``,
``unity``, ``blender`` (a JSON file of the engine's parameters, with units, formulas, sources and
what is lost). See :mod:`ssskit.export` and docs/exports.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import click

from ..errors import SsskitError

if TYPE_CHECKING:
    from ..kernels import KernelMethod
from .options import (
    TAP_RANGE,
    OutputFile,
    depth_mode_option,
    echo_json,
    examples,
    given,
    json_option,
    kernel_spec_option,
    material_option,
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
    "ssskit export --material skin1 --kernel preintegrated --taps 7 --format glsl-shader --out sss.comp"))
@click.option("--format", "fmt", required=True, type=click.Choice(list(_formats()), case_sensitive=False),
              help="hlsl/glsl: shader arrays (demo layout); bn: pre-integrated kernel file; json: ssskit kernel; "
                   "unreal/unity/blender: engine material parameters (JSON); glsl-shader/hlsl-shader: the whole "
                   "separable compute shader with the taps baked in (the gl backend's source).")
@click.option("--out", required=True, type=OutputFile(_all_suffixes()), help="Output file (suffix by format).")
@material_option(help="Preset name or material file (not needed by jimenez2012 or artist presets).")
@kernel_spec_option(help="Kernel method name[:value] for hlsl/glsl/bn/json (e.g. jimenez2012, preintegrated, svd:2).")
@click.option("--taps", type=click.IntRange(*TAP_RANGE), default=None,
              help="Taps per 1D pass (odd): jimenez2012's tap count, or the taps placed on a tabulated kernel "
                   "for hlsl/glsl [default: 11 for jimenez2012, 7 otherwise].")
@tap_method_option("importance")
@click.option("--jitter", type=click.FloatRange(0.0, 1.0), default=0.1, show_default=True,
              help="glsl-shader/hlsl-shader: taps within this fraction of the kernel size on rotated axes.")
@depth_mode_option()
@model_option("dipole", help="Profile model of the material (the source of the kernel or of the parameters).")
@photons_option(200_000, help="--model montecarlo: photons per channel (cached).")
@json_option("Print one JSON object describing what was written.")
@click.pass_context
def export(ctx: click.Context, fmt: str, out: str, material: str | None, kernel_spec: str | None, taps: int | None,
           tap_method: str, jitter: float, depth_mode: str | None, model: str, photons: int, as_json: bool) -> None:
    """Write a kernel or a material's parameters in a format an engine loads."""
    from ..export import engine_parameters, export_kernel
    from ..io import check_distinct, write_text
    from ..kernels import TapKernel, build_kernel

    import json

    fmt = fmt.lower()
    m, params, tap_count = _check_options(ctx, fmt, kernel_spec, material, taps, out)
    check_distinct(out, material, what="--out")
    needs_profile = m is None or m.needs_profile
    prof = None
    if material is not None or needs_profile:
        check_material_for_model(ctx, material, model, needed_by=f"--format {fmt}" if m is None else f"--kernel {m.name}")
        prof = resolve_profile(ctx, material, model, {"photons": ("photons", photons)})
    elif given(ctx, "model") or given(ctx, "photons"):
        assert m is not None  # only a kernel method may need no profile
        raise SsskitError(f"--model and --photons need a --material (--kernel {m.name} without one uses no profile)")
    # ---- work starts here: every check above has passed
    profile = prof() if prof is not None else None
    summary: dict[str, Any] = {"format": fmt, "out": out, "material": material, "model": model if profile is not None else None}
    if m is None:
        from ..materials import get_material

        assert material is not None and profile is not None  # _check_options: an engine export has a material
        mat = get_material(material)
        data = engine_parameters(profile, fmt, mat)
        write_text(out, json.dumps(data, indent=1) + "\n")
        summary["parameters"] = {k: v for k, v in data.items() if k not in ("sources", "lost")}
    else:
        kernel = build_kernel(m.name, profile, **params)
        comment = (f"ssskit export: {kernel_spec} kernel" + (f" of {profile.name} ({profile.model})" if profile else "")
                   + ("" if isinstance(kernel, TapKernel) or fmt not in ("hlsl", "glsl")
                      else f", {tap_count or 7} {tap_method} taps"))
        export_kernel(kernel, fmt, out, tap_count, tap_method, comment, jitter, depth_mode)
        with_taps = fmt in ("hlsl", "glsl") + SHADERS
        summary.update(kernel=kernel_spec, rank=kernel.rank,
                       taps=kernel.taps if isinstance(kernel, TapKernel) else (tap_count or 7) if with_taps else None)
        if fmt in SHADERS:
            summary.update(jitter=jitter, depth_mode=depth_mode)
    if as_json:
        echo_json(summary)
    else:
        click.echo(f"# wrote {out} ({fmt})")


__all__ = ["export"]
