"""MaterialX: an ``.mtlx`` document with an OpenPBR ``open_pbr_surface`` (and, where asked, an Autodesk
``standard_surface``) carrying the subsurface settings, validated by MaterialX itself.

OpenPBR Surface 1.1 (the ``open_pbr_surface`` nodedef of MaterialX 1.39; the specification
[OPBR24], section "Subsurface") describes subsurface scattering by ``subsurface_color`` C, "the
observed RGB reflection albedo colour taking into account all orders of multiple scattering",
``subsurface_radius`` x ``subsurface_radius_scale`` = r, "the mean free path (MFP) per RGB channel, i.e. the
average distance that a ray of light travels through the medium before being absorbed or scattered", with
"the extinction coefficient simply given by the reciprocal of the MFP per channel: mu_t = 1 / r", and
``subsurface_scatter_anisotropy`` g. (MaterialX's nodegraph ``NG_open_pbr_surface_surfaceshader`` multiplies
the two into the ``radius`` of its ``subsurface_bsdf``.) Standard Surface 1.0.1 has the same three as
``subsurface_color``, ``subsurface_radius`` (colour) x ``subsurface_scale`` and ``subsurface_anisotropy``.

ssskit's conversion: ``subsurface_color`` = the profile's total diffuse reflectance A (Burley's albedo, the
observed multiple-scattering albedo); r = 1 / sigma_t per channel of the material (sigma_t = sigma_a +
sigma_s, in mm, written with MaterialX's distance unit ``unit="millimeter"``); ``specular_ior`` = eta;
the anisotropy g. Read back, the file is the artists' terms (C, r = 1 / mu_t, eta, g) of
:mod:`ssskit.profiles.artist` with ``kind="mfp"``: the physical material has sigma_t = 1 / r and the
single-scattering albedo whose multiple-scattering reflectance is C (the spec leaves the alpha(C) mapping
open and asks for the one closest to its constraint; ssskit's accounts for the dielectric boundary), and
Burley's d = r / (1.85 - C + 7 |C - 0.8|^3) (Christensen-Burley's searchlight fit, Xie 2020 Eq. 5
Theta_1). The document is written without the standard libraries (validated against them by reference,
``setDataLibrary``), so it names no path of the machine that wrote it and reads anywhere.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SsskitError
from ..quantities import BURLEY_ALBEDO, LENGTH_MM, check_finite


def searchlight_scaling(a: Any) -> np.ndarray:
    """s(A) = 1.85 - A + 7 |A - 0.8|^3 (Xie 2020 Eq. 5 Theta_1, searchlight: d = l / s(A), l the volume mean free
    path)."""
    a = np.asarray(a, dtype=float)
    return 1.85 - a + 7.0 * np.abs(a - 0.8) ** 3


def _mx() -> Any:
    """The MaterialX module, or one SsskitError saying how to install it (an optional dependency)."""
    try:
        import MaterialX as mx
    except ImportError:
        raise SsskitError('reading or writing a MaterialX .mtlx needs the optional MaterialX package: '
                          'pip install ".[materialx]" (materialx>=1.39,<1.40)') from None
    return mx


def _libraries() -> Any:
    mx = _mx()
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    return lib


def materialx_document(a: np.ndarray, mfp_mm: np.ndarray, name: str, g: float = 0.0, eta: float | None = None,
                       standard_surface: bool = False) -> str:
    """The .mtlx text (module docstring): an ``open_pbr_surface`` and its material, plus a ``standard_surface``
    and its material if ``standard_surface``. ``a`` (3,): ``subsurface_color`` (the observed multiple-scattering
    albedo); ``mfp_mm`` (3,): the mean free path r = 1 / sigma_t per channel, mm (OpenPBR: mu_t = 1 / r,
    [OPBR24] "Subsurface"). Raises if MaterialX finds it invalid."""
    mx = _mx()
    ell = np.array(LENGTH_MM.check_rgb(mfp_mm, "the mean free path"))
    scale = float(np.max(ell))
    rel = ell / scale
    safe = "".join(ch if ch.isalnum() or ch == "_" else "_" for ch in name) or "ssskit"
    if safe[0].isdigit():
        safe = "m_" + safe
    doc = mx.createDocument()
    doc.setDocString(f"ssskit export of {name}: subsurface_color = the observed albedo A; subsurface_radius x "
                     "subsurface_radius_scale = the mean free path 1 / sigma_t (OpenPBR 1.1: mu_t = 1 / r), in mm")
    sh = doc.addNode("open_pbr_surface", f"SR_{safe}_openpbr", "surfaceshader")
    sh.setInputValue("base_weight", 1.0)
    sh.setInputValue("base_color", mx.Color3(*[float(v) for v in a]))
    sh.setInputValue("subsurface_weight", 1.0)
    sh.setInputValue("subsurface_color", mx.Color3(*[float(v) for v in a]))
    r = sh.setInputValue("subsurface_radius", scale)
    r.setUnitType("distance")
    r.setUnit("millimeter")
    sh.setInputValue("subsurface_radius_scale", mx.Color3(*[float(v) for v in rel]))
    sh.setInputValue("subsurface_scatter_anisotropy", float(g))
    if eta is not None:
        sh.setInputValue("specular_ior", float(eta))
    doc.addMaterialNode(f"M_{safe}_openpbr", sh)
    if standard_surface:
        ss = doc.addNode("standard_surface", f"SR_{safe}_standard", "surfaceshader")
        ss.setInputValue("subsurface", 1.0)
        ss.setInputValue("subsurface_color", mx.Color3(*[float(v) for v in a]))
        sr = ss.setInputValue("subsurface_radius", mx.Color3(*[float(v) for v in rel]))
        sr.setUnitType("distance")
        sr.setUnit("millimeter")
        sc = ss.setInputValue("subsurface_scale", scale)
        sc.setUnitType("distance")
        sc.setUnit("millimeter")
        ss.setInputValue("subsurface_anisotropy", float(g))
        if eta is not None:
            ss.setInputValue("specular_IOR", float(eta))
        doc.addMaterialNode(f"M_{safe}_standard", ss)
    check_document(doc)
    return mx.writeToXmlString(doc)


def check_document(doc: Any, what: str = "the document") -> None:
    """MaterialX's own validation against the standard libraries (nodedefs, types, units), which the document
    references (``setDataLibrary``) and does not import: written afterwards, it holds no ``xi:include`` of this
    machine's library paths."""
    doc.setDataLibrary(_libraries())
    ok, why = doc.validate()
    if not ok:
        raise SsskitError(f"MaterialX rejects {what}: {why.strip().splitlines()[0] if why else 'invalid'}")


def read_materialx(path: str | Path) -> dict[str, Any]:
    """The subsurface settings of an ``.mtlx`` with an ``open_pbr_surface`` or ``standard_surface`` (the first
    found): {"albedo": C (3,), "mfp_mm": r (3,), "d_mm": Burley's d (3,) = r / s(C) (Christensen-Burley's
    searchlight fit), "eta" (or None), "g", "name", "shader"}: the inverse of :func:`materialx_document`.
    Raises :class:`SsskitError` for a truncated or invalid document, one without a subsurface shader, or a
    value outside the model's domain (naming the input)."""
    mx = _mx()
    doc = mx.createDocument()
    try:
        mx.readFromXmlFile(doc, str(path))
    except Exception as exc:  # MaterialX raises its own ExceptionParseError / ExceptionFileMissing
        raise SsskitError(f"{str(path)!r} is not a readable MaterialX document: {str(exc).splitlines()[0]}") from None
    check_document(doc, repr(str(path)))
    unit = {"millimeter": 1.0, "centimeter": 10.0, "meter": 1000.0, "inch": 25.4, "foot": 304.8, "": 1.0}

    def length(inp: Any) -> float:
        u = inp.getUnit() if inp.hasUnit() else ""
        if u not in unit:
            raise SsskitError(f"{str(path)!r}: unknown distance unit {u!r} on {inp.getName()}")
        return unit[u]

    for node in doc.getNodes():
        cat = node.getCategory()
        if cat not in ("open_pbr_surface", "standard_surface"):
            continue
        col_name, rad_name, scl_name = (("subsurface_color", "subsurface_radius", "subsurface_radius_scale")
                                        if cat == "open_pbr_surface" else
                                        ("subsurface_color", "subsurface_scale", "subsurface_radius"))
        inputs = {n: node.getInput(n) for n in (col_name, rad_name, scl_name)}
        missing = [n for n, i in inputs.items() if i is None]
        if missing:
            raise SsskitError(f"{str(path)!r}: the {cat} {node.getName()!r} lacks {', '.join(missing)}")
        a = np.array(list(inputs[col_name].getValue()), dtype=float)
        radius = float(inputs[rad_name].getValue()) * length(inputs[rad_name])
        rel = np.array(list(inputs[scl_name].getValue()), dtype=float) * length(inputs[scl_name])
        ior_in = node.getInput("specular_ior" if cat == "open_pbr_surface" else "specular_IOR")
        aniso_in = node.getInput("subsurface_scatter_anisotropy" if cat == "open_pbr_surface" else "subsurface_anisotropy")
        eta = float(ior_in.getValue()) if ior_in is not None else None
        g = float(aniso_in.getValue()) if aniso_in is not None else 0.0
        for field, v in ((col_name, a), (rad_name, radius), (scl_name, rel), ("specular_ior", eta), ("anisotropy", g)):
            check_finite(0.0 if v is None else v, f"{str(path)!r}: {cat} {field}", SsskitError)
        ell = radius * rel
        BURLEY_ALBEDO.check_array(a, f"{str(path)!r}: the {cat} subsurface_color (the observed albedo)", SsskitError,
                                  "channels")
        LENGTH_MM.check_array(ell, f"{str(path)!r}: the {cat} mean free path (subsurface radius x scale)", SsskitError,
                              "channels")
        return {"albedo": a, "mfp_mm": ell, "d_mm": ell / searchlight_scaling(a), "eta": eta, "g": g,
                "name": node.getName(), "shader": cat}
    raise SsskitError(f"{str(path)!r} has no open_pbr_surface or standard_surface node")


def glsl_source(mtlx_text: str) -> dict[str, str]:
    """MaterialX's GLSL shader generator on the document's first material: {"pixel": ..., "vertex": ...}."""
    mx = _mx()
    import MaterialX.PyMaterialXGenGlsl as mx_glsl
    import MaterialX.PyMaterialXGenShader as mx_gen

    doc = mx.createDocument()
    mx.readFromXmlString(doc, mtlx_text)
    doc.setDataLibrary(_libraries())
    material = next(n for n in doc.getNodes() if n.getType() == "material")
    gen = mx_glsl.GlslShaderGenerator.create()
    ctx = mx_gen.GenContext(gen)
    ctx.registerSourceCodeSearchPath(mx.getDefaultDataSearchPath())
    shader = gen.generate(material.getName(), material, ctx)
    return {"pixel": shader.getSourceCode("pixel"), "vertex": shader.getSourceCode("vertex")}


__all__ = ["check_document", "glsl_source", "materialx_document", "read_materialx", "searchlight_scaling"]
