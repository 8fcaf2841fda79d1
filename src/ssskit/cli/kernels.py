"""``ssskit kernel`` and ``ssskit evaluate``: separable kernel approximations and their errors.

The kernel methods and their parameters come from :data:`ssskit.kernels.METHODS`: each method's
primary parameter (``rank``, ``count``, ``k``, ``taps``, ``preset``, ``error``...) becomes an option
``--<parameter>`` of ``ssskit kernel`` (or is given inline, ``--method svd:3``), parsed and
range-checked by the method itself; a new method needs no change here.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import click

from ..errors import SsskitError
from ..quantities import KERNEL_CELLS, refuse_twice, refuse_unused

if TYPE_CHECKING:
    from ..kernels import AnyKernel, KernelMethod
from .options import (
    DEFAULT_MODEL,
    DEFAULT_PHOTONS,
    SIZE_RANGE,
    KernelSpec,
    echo_json,
    examples,
    given,
    named,
    json_option,
    kernel_spec_option,
    material_option,
    model_option,
    out_option,
    photons_option,
    progress,
    signal_option,
)
from .profiles import resolve_profile

#: options of ``kernel`` itself; a method parameter of the same name is offered as --<method>-<name>
_OWN = {"material", "method", "model", "photons", "size", "json", "out", "help"}


def _primary_options() -> dict[str, tuple[str, list[str]]]:
    """{click parameter name: (method parameter, [methods whose primary parameter it is])} from METHODS."""
    from ..kernels import METHODS

    by_param: dict[str, list[str]] = {}
    for name, m in METHODS.items():
        if m.primary:
            by_param.setdefault(m.primary, []).append(name)
    out = {}
    for param, methods in by_param.items():
        opt = param if param not in _OWN else f"{methods[0]}-{param}"
        out[opt.replace("-", "_")] = (param, methods)
    return out


PRIMARY_OPTIONS = _primary_options()


def _option_flag(dest: str) -> str:
    return "--" + dest.replace("_", "-")


def _method_parameter_options(f):
    for dest, (param, methods) in reversed(PRIMARY_OPTIONS.items()):
        f = click.option(_option_flag(dest), dest, default=None, metavar="VALUE",
                         help=f"The {param!r} of --method {', '.join(methods)} (or inline: --method "
                              f"{methods[0]}:VALUE).")(f)
    return f


def method_parameters(method_spec: str, values: dict[str, str | None]) -> tuple[KernelMethod, dict[str, Any]]:
    """The method of ``method_spec`` and its parameters from the spec and the --<parameter> options,
    each parsed and range-checked by the method (KernelError naming the option otherwise)."""
    from ..kernels import check_params, parse_method_spec

    m, params, _ = parse_method_spec(method_spec)
    for dest, text in values.items():
        if text is None:
            continue
        flag = _option_flag(dest)
        param = PRIMARY_OPTIONS[dest][0]
        if m.primary != param:
            refuse_unused([flag], "--method", PRIMARY_OPTIONS[dest][1], m.name)
        with named(flag, SsskitError):
            value = m.parse(text)
            check_params(m, {param: value})
        if param in params and params[param] != value:
            refuse_twice(f"--method {method_spec}", f"{flag} {text}", f"the {param}")
        params[param] = value
    return m, params


def kernel_label(method: KernelMethod, params: dict[str, Any], kernel: AnyKernel) -> str:
    """``name:value`` of the kernel as built: its primary parameter as given, as the kernel records it,
    or the builder's default (``artist:production``, ``svd:1``)."""
    import inspect

    if method.primary is None:
        return method.name
    value = params.get(method.primary, kernel.params.get(method.primary) if hasattr(kernel, "params") else None)
    if value is None:
        value = inspect.signature(method.builder).parameters[method.primary].default
    return f"{method.name}:{value}"


@click.command(epilog=examples(
    "ssskit kernel --method jimenez2012 --taps 11 --json",
    "ssskit kernel --material skin1 --method preintegrated --out k.npz",
    "ssskit kernel --material marble --method svd --rank 3 --json",
    "ssskit kernel --material marble --method svd:3 --model dipole",
    "ssskit kernel --material skin1 --method artist --preset fit"))
@material_option(help="Preset name or material file (not needed by methods without a profile: jimenez2012, artist presets).")
@kernel_spec_option("--method", "method_spec", required=True, help="Kernel method name[:value] (the methods: docs/commands.md, 'Methods:').")
@model_option(DEFAULT_MODEL, help="Profile the kernel approximates.")
@photons_option(DEFAULT_PHOTONS, help="--model montecarlo: photons per channel (shipped for the presets at 10^7, else cached).")
@_method_parameter_options
@click.option("--size", "grid_n", type=click.IntRange(3, 2001), default=201, show_default=True,
              help="Cells across the kernel grid (odd).")
@json_option()
@out_option((".npz", ".json"), "Write FILE.npz or FILE.json.")
@click.pass_context
def kernel(ctx: click.Context, material: str | None, method_spec: str, model: str, photons: int, grid_n: int,
           as_json: bool, out: str | None, **method_values: str | None) -> None:
    """A separable kernel approximation of a material's profile."""
    from ..kernels import TapKernel, build_kernel, refuse_profile_options, save_kernel

    from ..io import check_distinct

    m, params = method_parameters(method_spec, method_values)
    KERNEL_CELLS.check(grid_n, "--size")
    check_distinct(out, material, what="--out")
    prof = None
    refuse_profile_options(m, [f for f, on in (("--material", material is not None), ("--model", given(ctx, "model")),
                                               ("--photons", given(ctx, "photons"))) if on], material is not None,
                           "--method")
    if material is not None or m.needs_profile:  # (a material-free model's profile needs none)
        prof = resolve_profile(ctx, material, model, {"photons": ("photons", photons)}, f"--method {m.name}")()
    k = build_kernel(m.name, prof, n=grid_n, **params)
    if out:
        save_kernel(k, out)
    if as_json:
        d = k.to_dict()
        d["material"] = material
        echo_json(d)
        return
    click.echo(f"# {kernel_label(m, params, k)} kernel: {m.description}" + (f"; of {prof.name} ({prof.model})" if prof else ""))
    click.echo(f"# rank {k.rank}, {k.convolutions_1d} 1D convolutions; total per channel: "
               + ", ".join(f"{v:.6f}" for v in k.total()))
    if isinstance(k, TapKernel):  # (offsets_mm: a tap kernel)
        click.echo("offset_mm,w_R,w_G,w_B")
        for o, w in zip(k.offsets_mm, k.weights):
            click.echo(f"{o:.6f}," + ",".join(f"{v:.6f}" for v in w))
    elif prof is not None:
        cmp = k.compare(prof)
        click.echo("# relative Frobenius error vs the discrete Rd: " + ", ".join(f"{v:.4g}" for v in cmp["relative_frobenius"]))
    if out:
        click.echo(f"# wrote {out}")


@click.command(epilog=examples(
    "ssskit evaluate --material ketchup --signal disk --methods svd:1,svd:3,preintegrated,guided:0 --json",
    "ssskit evaluate --material skin1 --model dipole --signal edge --size 128"))
@material_option(help="Preset name or material file.")
@signal_option("edge")
@kernel_spec_option("--methods", "methods", many=True,
                    default="svd:1,svd:3,gaussians:1,gaussians:6,preintegrated,guided:2,artist:close fit,jimenez2012",
                    help="Comma-separated method specs name[:value] (svd:3, guided:0, artist:production...).")
@model_option(DEFAULT_MODEL, help="Profile giving the ground truth.")
@photons_option(DEFAULT_PHOTONS, help="--model montecarlo: photons per channel (shipped for the presets at 10^7, else cached).")
@click.option("--size", type=click.IntRange(*SIZE_RANGE), default=256, show_default=True, help="Image size in pixels.")
@click.option("--no-perceptual", is_flag=True, help="Skip SSIM and FLIP.")
@json_option("Print one JSON object: method -> metrics.")
@click.pass_context
def evaluate(ctx: click.Context, material: str | None, signal: str, methods: list[str], model: str, photons: int,
             size: int, no_perceptual: bool, as_json: bool) -> None:
    """Each method's error against the exact 2D convolution on a test signal."""
    from ..metrics import check_ssim_size
    from ..pipeline import evaluate as run

    if not no_perceptual:  # before the profile (an MCML run) and the kernels
        check_ssim_size(size, size, f"--size {size}: ", "; give a larger --size, or --no-perceptual")
    prof = resolve_profile(ctx, material, model, {"photons": ("photons", photons)})()
    ev = run(prof, signal, methods, size=size, perceptual=not no_perceptual,
             progress=lambda m: progress(f"method {m}"))  # on stderr in every mode, --json included
    if as_json:
        echo_json(ev.to_json())
        return
    click.echo(f"# {prof.name} ({prof.model}), signal {signal}, {size}x{size} px at {ev.pixel_mm:.4g} mm/px")
    cols = ["relative_rmse", "psnr"] + ([] if no_perceptual else ["ssim", "flip"])
    click.echo(f"{'method':24s} conv1d " + " ".join(f"{c:>13s}" for c in cols))
    for label, r in ev.results.items():
        click.echo(f"{label:24s} {r['convolutions_1d']:6d} " + " ".join(f"{r[c]:13.5g}" for c in cols))


__all__ = ["KernelSpec", "PRIMARY_OPTIONS", "evaluate", "kernel", "method_parameters"]
