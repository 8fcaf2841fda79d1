"""The formats :func:`ssskit.export.export` writes, registered in :data:`ssskit.export.FORMATS`: kernels (shader
arrays, ``.bn``, ssskit's JSON), whole compute shaders, and engine files (Unreal, Unity HDRP, Blender, MaterialX),
each with its suffixes, writer, reader and the options that apply to it (docs/architecture.md, "How to add an
engine format")."""

from __future__ import annotations

import json
from typing import Any

from pathlib import Path

from ..errors import KernelError
from ..quantities import refuse_unused
from .api import FORMATS, KERNEL_OPTIONS, SHADER_OPTIONS, ExportSettings, Format, Job

# ------------------------------------------------------------------------------------------- kernels

#: ``--format bn`` crops the grid to the part holding this fraction of each channel's kernel mass
BN_SUPPORT = 0.999
def export_kernel(kernel: Any, fmt: str, path: str | Path, taps: int | None = None, tap_method: str = "importance",
                  comment: str = "", jitter: float | None = None, depth_mode: str | None = None) -> None:
    """Write ``kernel`` in a kernel format (``hlsl``, ``glsl``, ``bn``, ``json``, ``glsl-shader``,
    ``hlsl-shader``) to ``path`` (atomic). The shaders take ``jitter`` (None: :func:`~.shaders.separable_shader`'s default, the pass's 0.1) and
    ``depth_mode`` (the pass's); another format given either, or ``bn`` / ``json`` given ``taps`` (they write
    the tabulated kernel itself), is refused before anything is written."""
    from ..io import check_suffix, write_text
    from ..kernels.base import save_kernel
    from .arrays import LANGUAGES, format_shader_arrays, kernel_arrays
    from .bn import save_bn

    from ..quantities import check_choice, refuse_unused

    kernel_formats = [name for name, f in FORMATS.items() if f.kind in ("kernel", "shader")]
    key = check_choice("kernel format", fmt, kernel_formats, KernelError)
    shaders, tabulated = ("glsl-shader", "hlsl-shader"), ("bn", "json")  # (these write the tabulated kernel itself)
    refuse_unused([n for n, v in (("jitter", jitter), ("depth_mode", depth_mode)) if v is not None and key not in shaders],
                  "format", shaders, key, KernelError)
    refuse_unused(["taps"] if taps is not None and key in tabulated else [], "format",
                  [k for k in kernel_formats if k not in tabulated], key, KernelError)
    check_suffix(path, FORMATS.get(key).suffixes, f"{key} output")
    if key in ("glsl-shader", "hlsl-shader"):
        from ..kernels import TapKernel
        from ..sampling.taps import make_taps
        from .shaders import separable_shader

        n = kernel.taps if isinstance(kernel, TapKernel) else (taps or 7)
        given = {} if jitter is None else {"jitter": jitter}  # None: the shader's own default
        stage = shader_stage(path)
        text = separable_shader(make_taps(kernel, n, tap_method), key.split("-")[0], depth_mode=depth_mode,
                                stage=stage, **given)
        write_text(path, with_comment(text, comment, stage))
    elif key in LANGUAGES:
        write_text(path, format_shader_arrays(kernel_arrays(kernel, taps, tap_method), key, comment))
    elif key == "bn":
        save_bn(kernel, path, support=BN_SUPPORT)
    else:
        save_kernel(kernel, path)




def _kernel(job: Job) -> None:
    """A kernel format: the kernel of the source's profile, written by :func:`ssskit.export.export_kernel`."""
    from ..kernels import TapKernel, build_kernel

    req, src = job.request, job.source
    m, params, tap_count = src.kernel
    profile = src.profile() if src.profile is not None else None
    kernel = build_kernel(m.name, profile, **params)
    shader = req.format.endswith("-shader")
    tap_method = req.tap_method or "importance"
    comment = (f"ssskit export: {req.kernel} kernel" + (f" of {profile.name} ({profile.model})" if profile else "")
               + ("" if isinstance(kernel, TapKernel) or req.format not in ("hlsl", "glsl")
                  else f", {tap_count or 7} {tap_method} taps"))
    export_kernel(kernel, req.format, req.out, tap_count, tap_method, comment, req.jitter if shader else None,
                  req.depth_mode)
    with_taps = req.format in ("hlsl", "glsl") or shader
    job.summary.update(material=req.material, model=src.model if profile is not None else None, kernel=req.kernel,
                       rank=kernel.rank,
                       taps=kernel.taps if isinstance(kernel, TapKernel) else (tap_count or 7) if with_taps else None)
    if shader:
        job.summary.update(jitter=0.1 if req.jitter is None else req.jitter, depth_mode=req.depth_mode)
    return None


def _shader(job: Job) -> str | None:
    """A whole compute shader: the separable pass (a kernel) or, with ``shader_pass="transmission"``, the
    transmittance pass with the material's model baked in (:func:`ssskit.export.shaders.transmission_shader`)."""
    req = job.request
    if req.shader_pass == "burley":
        return _burley_shader(job)
    if req.shader_pass != "transmission":
        _kernel(job)
        return None
    from ..screenspace.transmission import transmission_plan
    from ..screenspace.transmission_slot import slot_model
    from .shaders import transmission_shader

    tmodel = req.transmission_model or "mcml"
    mat = job.source.material
    plan = transmission_plan({1: slot_model(tmodel, mat)})
    what = f"{tmodel} transmittance of {mat.name}" if mat is not None else f"{tmodel} transmittance"
    job.summary.update(material=mat.name if mat is not None else None, model=None, **{"pass": "transmission"},
                       transmission_model=tmodel, terms=plan.terms, table=bool(plan.has_lut))
    stage = shader_stage(req.out)
    return with_comment(transmission_shader(plan, req.format.split("-")[0], stage),
                        f"ssskit export: the transmittance pass, {what}", stage)


def _burley_shader(job: Job) -> str:
    """The Burley Monte Carlo pass (Xie 2020 Eq. 21's sampler, the plan's sequence and hash) with the material's
    Burley parameters baked in: the gl backend's compute source (:func:`ssskit.backends.gl.burley.burley_export_source`)
    or, for a ``.frag``, its GLSL ES 3.00 fragment form (:func:`ssskit.backends.gl.burley.burley_fragment_source`),
    the text the live viewer runs (:func:`ssskit.view.site.material_payload`: the same plan)."""
    from ..backends.burley_plan import build_burley_plan
    from ..backends.gl.burley import burley_export_source, burley_fragment_source
    from ..screenspace.burley import burley_params_for_material

    mat = job.source.material
    params = burley_params_for_material(mat)
    plan = build_burley_plan({1: params}, 1.0, 1.0)  # the focal lengths are uniforms (u_fx, u_fy), not baked in
    job.summary.update(material=mat.name, model=None, **{"pass": "burley"}, sampler=plan.sampler,
                       sequence=plan.sequence, dmfp_mm=[float(v) for v in params.dmfp_mm])
    stage = shader_stage(job.request.out)
    text = burley_fragment_source(plan) if stage == "fragment" else burley_export_source(plan)
    return with_comment(text, f"ssskit export: the Burley pass, {mat.name}", stage)


def shader_stage(path: str | Path) -> str:
    """``fragment`` for an output ending in ``.frag`` (the GLSL ES 3.00 fragment form of the same per-pixel body,
    what ``ssskit view`` runs), else ``compute``."""
    return "fragment" if str(path).lower().endswith(".frag") else "compute"


def with_comment(text: str, comment: str, stage: str) -> str:
    """``text`` with the ``// comment`` line: first for a compute shader, right after ``#version`` for the GLSL ES
    fragment form (which allows nothing before that line, comments included)."""
    if not comment:
        return text
    if stage == "fragment":
        version, _, rest = text.partition("\n")
        return f"{version}\n// {comment}\n{rest}"
    return f"// {comment}\n{text}"


def _shader_check(req: ExportSettings, source: Any) -> None:
    if req.shader_pass == "burley" and req.format != "glsl-shader":  # (.comp, or .frag for the fragment form)
        refuse_unused(["--pass burley"], "--format", ("glsl-shader",), req.format)
    if req.format == "hlsl-shader":  # glslangValidator and spirv-cross, or the error saying how to install them
        from .shaders import GLSLANG, SPIRV_CROSS, tool_path

        tool_path(GLSLANG), tool_path(SPIRV_CROSS)


# ------------------------------------------------------------------------------------------ engines


def engine_data(job: Job) -> dict[str, Any]:
    """The engine's parameters (:func:`ssskit.export.engine_parameters`) of the job's source, with the engines'
    transmission fields fitted to a homogeneous material's MCML T(t) unless ``no_transmission``; fills the summary
    and says (a note) why transmission fields are left out."""
    from ..materials import Material
    from .engines import TRANSMISSION_ENGINES, engine_parameters

    req, src = job.request, job.source
    fmt, mat = req.format, src.material
    table = None
    if not req.no_transmission and fmt in TRANSMISSION_ENGINES and isinstance(mat, Material):
        from ..profiles.montecarlo.transmission import transmission_table

        table = transmission_table(mat)  # (its domain checked before any work: _transmission_check)  # the material's MCML slab T(t) (cached like the profiles)
    data = engine_parameters(src.profile(), fmt, mat, table, eta=src.eta)
    if fmt in TRANSMISSION_ENGINES and table is None:
        why = ("left out (--no-transmission)" if req.no_transmission else
               "the transmission fields are fitted to a homogeneous material's MCML slab transmittance: give a preset "
               "or material file, or artists' terms with --model montecarlo")
        data["transmission"] = {"available": False, "why": why + "; the engine's defaults stay"}
        if not req.no_transmission:  # asked for but not there: say so where the user looks
            what = ("artists' terms and engine files under --model burley (their default, the Burley-fit inversion) "
                    "have no coefficients, so no slab transmittance" if mat is None else
                    "a layered material has no single slab transmittance")
            job.notes.append(f"--format {fmt}: the transmission fields are left out, the engine's defaults stay: "
                             f"{what}; give --material (a preset or material file)"
                             + (" or --model montecarlo" if mat is None else "") + " for them")
    job.summary.update(material=req.material if req.material is not None else src.name, model=src.model,
                       parameters={k: v for k, v in data.items() if k not in ("sources", "lost")})
    return data


def asset_name(job: Job) -> str:
    src = job.source
    name = src.name or (src.material.name if src.material is not None else "ssskit")
    return "".join(ch if ch.isalnum() or ch in "_-" else "_" for ch in name) or "ssskit"


def _json_or(job: Job, data: dict[str, Any]) -> str | None:
    return json.dumps(data, indent=1) + "\n" if job.request.suffix == "json" else None


def _unreal(job: Job) -> str:
    from .unreal import unreal_script

    data = engine_data(job)
    form = job.request.unreal_form or "mfp"
    if job.request.suffix == "json":
        return json.dumps(data, indent=1) + "\n"
    job.summary["unreal_form"] = form
    return unreal_script(data, f"SP_{asset_name(job)}", form)


def _transmission_check(req: ExportSettings, source: Any) -> None:
    """The transmission table's domain (from sigma_t), before the profile's MCML."""
    from ..materials import Material

    if not req.no_transmission and isinstance(source.material, Material):
        from ..profiles.montecarlo.transmission import check_table_request

        check_table_request(source.material)


def _unreal_check(req: ExportSettings, source: Any) -> None:
    _transmission_check(req, source)
    if req.given("unreal_form") and req.suffix != "py":  # the editor script's form: the one unused-option wording
        refuse_unused(["--unreal-form"], "--out", [".py (the editor script)"], f".{req.suffix}")


def _unity(job: Job) -> str:
    from .unity import unity_asset

    data = engine_data(job)
    return _json_or(job, data) or unity_asset(data, asset_name(job))


def _blender(job: Job) -> str:
    from .blender import blender_script

    data = engine_data(job)
    return _json_or(job, data) or blender_script(data, asset_name(job))


def _materialx(job: Job) -> str:
    """OpenPBR's subsurface_color = A and radius = the mean free path 1 / sigma_t ([OPBR24]; module
    :mod:`ssskit.export.materialx`): a layered material (no single medium) is refused."""
    import numpy as np

    from .engines import fit_burley
    from .materialx import materialx_document

    src, req = job.source, job.request
    mat = _medium(src)
    a, _ = fit_burley(src.profile())
    mfp = 1.0 / np.asarray(mat.sigma_t, dtype=float)  # OpenPBR: mu_t = 1 / r ([OPBR24], "Subsurface")
    g = float(np.mean(mat.g))
    job.summary.update(material=req.material if req.material is not None else src.name, model=src.model,
                       parameters={"subsurface_color": a.tolist(), "mfp_mm": mfp.tolist()})
    return materialx_document(a, mfp, src.name or mat.name, g, float(mat.eta), req.standard_surface)


def _medium(src: Any) -> Any:
    """The one homogeneous medium OpenPBR describes: the material, or for artists' terms or an engine file under
    Burley the Monte Carlo inversion's; a layered material has none."""
    from ..materials import homogeneous

    mat = src.material if src.material is not None else (src.physical() if src.physical is not None else None)
    return homogeneous(mat, "--format materialx (OpenPBR's one subsurface medium: export a layer's material)")


def _materialx_check(req: ExportSettings, source: Any) -> None:
    from .materialx import _mx

    _mx()  # the optional package, or one line saying how to install it
    _medium(source)


def _read(engine: str) -> Any:
    def read(path: Any, albedo: Any = None) -> Any:
        from .readers import read_engine_file

        return read_engine_file(path, albedo=albedo)

    read.__doc__ = f"The {engine} file read back (:func:`ssskit.export.readers.read_engine_file`)."
    return read


ENGINE_OPTIONS = ("no_transmission",)
_KERNEL_SUFFIXES = {
    "hlsl": (".hlsl", ".hlsli", ".h", ".fx", ".fxh", ".usf", ".ush"),
    "glsl": (".glsl", ".h", ".comp", ".frag", ".inc"),
    "bn": (".bn",),
    "json": (".json",),
}
for _name, _suffixes in _KERNEL_SUFFIXES.items():  # (bn and json write the tabulated kernel: no tap method)
    _options = ("kernel", "taps") if _name in ("bn", "json") else KERNEL_OPTIONS
    FORMATS.register(_name, Format(_name, _suffixes, "kernel", _options, _kernel, {
        "hlsl": "shader arrays (float4 kernel[N], the 2012 demo layout)", "glsl": "shader arrays (the demo layout)",
        "bn": "the 2015 pre-integrated kernel file", "json": "ssskit's kernel file"}[_name]))
FORMATS.register("unreal", Format("unreal", (".json", ".py"), "engine", ("unreal_form", "no_transmission"), _unreal,
                                  "Unreal SubsurfaceProfile: parameters (.json) or the editor script (.py)",
                                  _read("unreal"), _unreal_check))
FORMATS.register("unity", Format("unity", (".json", ".asset"), "engine", ("no_transmission",), _unity,
                                 "Unity HDRP diffusion profile: parameters (.json) or the .asset", _read("unity"),
                                 _transmission_check))
FORMATS.register("blender", Format("blender", (".json", ".py"), "engine", (), _blender,
                                   "Blender Principled BSDF (Cycles): parameters (.json) or the script (.py)",
                                   _read("blender")))
FORMATS.register("materialx", Format("materialx", (".mtlx",), "engine", ("standard_surface",), _materialx,
                                     "MaterialX .mtlx (OpenPBR, optionally Standard Surface)", _read("materialx"),
                                     _materialx_check))
FORMATS.register("glsl-shader", Format("glsl-shader", (".comp", ".glsl", ".frag"), "shader", SHADER_OPTIONS, _shader,
                                       "the whole separable (or transmittance) compute shader, taps baked in; "
                                       ".frag: its GLSL ES 3.00 fragment form (what ssskit view runs)",
                                       check=_shader_check))
FORMATS.register("hlsl-shader", Format("hlsl-shader", (".hlsl", ".fx", ".usf"), "shader", SHADER_OPTIONS, _shader,
                                       "the whole compute shader in HLSL (glslang + spirv-cross)", check=_shader_check))

def _babylon(job: Job) -> str:
    """Babylon.js's subsurface settings for the job's material (:mod:`ssskit.export.babylon`): an ES module or JSON."""
    from .babylon import babylon_text
    from .engines import fit_burley

    a, d = fit_burley(job.source.profile())
    name = asset_name(job)
    job.summary.update(model=job.source.model)
    return babylon_text([(name, a, d)], job.request.suffix, job.summary)


FORMATS.register("babylon", Format("babylon", (".json", ".js", ".mjs"), "engine", (), _babylon,
                                   "Babylon.js PBRMaterial.subSurface and the scene's diffusion profile: an ES module "
                                   "(.js, .mjs) or .json; several materials of one scene: --material a,b (at most 4)"))

__all__ = ["BN_SUPPORT", "asset_name", "engine_data", "export_kernel"]
