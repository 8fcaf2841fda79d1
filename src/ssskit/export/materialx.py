"""MaterialX: an ``.mtlx`` document with an OpenPBR ``open_pbr_surface`` (and, where asked, an Autodesk
``standard_surface``) carrying the subsurface settings, validated by MaterialX itself.

OpenPBR Surface 1.1 (the ``open_pbr_surface`` nodedef of MaterialX 1.39) describes subsurface scattering
by ``subsurface_color`` (the albedo the medium shows, its multiple-scattering reflectance),
``subsurface_radius`` x ``subsurface_radius_scale`` (the mean free path per channel, a length in scene
units) and ``subsurface_scatter_anisotropy`` (g). Standard Surface 1.0.1 has the same three as
``subsurface_color``, ``subsurface_radius`` (colour) x ``subsurface_scale`` and ``subsurface_anisotropy``.

ssskit's conversion from Burley's (A, d): subsurface_color = A; the mean free path is the volume mean free
path that Christensen-Burley's searchlight fit assigns to (A, d), l = d (1.85 - A + 7 |A - 0.8|^3)
(Xie 2020 Eq. 5 Theta_1), written in mm with MaterialX's distance unit (``unit="millimeter"``);
read back, d = l / (1.85 - A + 7 |A - 0.8|^3). How a renderer turns (colour, mean free path) into its
coefficients is the renderer's choice (OpenPBR leaves it open), so the document fixes the (A, l) pair,
not a rendered look.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SsskitError


def searchlight_scaling(a: Any) -> np.ndarray:
    """s(A) = 1.85 - A + 7 |A - 0.8|^3 (Xie 2020 Eq. 5 Theta_1, searchlight: l the volume mean free path)."""
    a = np.asarray(a, dtype=float)
    return 1.85 - a + 7.0 * np.abs(a - 0.8) ** 3


def _libraries() -> Any:
    import MaterialX as mx

    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    return lib


def materialx_document(a: np.ndarray, d_mm: np.ndarray, name: str, g: float = 0.0, eta: float | None = None,
                       standard_surface: bool = False) -> str:
    """The .mtlx text (module docstring): an ``open_pbr_surface`` and its material, plus a
    ``standard_surface`` and its material if ``standard_surface``. Raises if MaterialX finds it invalid."""
    import MaterialX as mx

    ell = np.asarray(d_mm, dtype=float) * searchlight_scaling(a)
    scale = float(np.max(ell))
    rel = ell / scale
    safe = "".join(ch if ch.isalnum() or ch == "_" else "_" for ch in name) or "ssskit"
    if safe[0].isdigit():
        safe = "m_" + safe
    doc = mx.createDocument()
    doc.setDocString(f"ssskit export of {name}: subsurface colour = Burley albedo A; mean free path "
                     f"l = d (1.85 - A + 7 |A - 0.8|^3) (Xie 2020 Eq. 5, searchlight), in mm")
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


def check_document(doc: Any) -> None:
    """MaterialX's own validation, against the standard libraries (nodedefs, types, units)."""
    lib = _libraries()
    doc.importLibrary(lib)
    ok, why = doc.validate()
    if not ok:
        raise SsskitError(f"MaterialX rejects the document: {why.strip().splitlines()[0] if why else 'invalid'}")


def read_materialx(path: str | Path) -> dict[str, Any]:
    """(A (3,), d (3,) mm, name) from an ``.mtlx`` with an ``open_pbr_surface`` or ``standard_surface``
    (the first found), the inverse of :func:`materialx_document`. Raises :class:`SsskitError` for a
    truncated or invalid document or one without a subsurface shader."""
    import MaterialX as mx

    doc = mx.createDocument()
    try:
        mx.readFromXmlFile(doc, str(path))
    except Exception as exc:  # MaterialX raises its own ExceptionParseError / ExceptionFileMissing
        raise SsskitError(f"{str(path)!r} is not a readable MaterialX document: {str(exc).splitlines()[0]}") from None
    lib = _libraries()
    doc.importLibrary(lib)
    ok, why = doc.validate()
    if not ok:
        raise SsskitError(f"{str(path)!r}: MaterialX rejects the document: {why.strip().splitlines()[0]}")
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
        ell = radius * rel
        if np.any(~np.isfinite(ell)) or np.any(ell <= 0) or np.any(~np.isfinite(a)) or np.any(a <= 0) or np.any(a > 1):
            raise SsskitError(f"{str(path)!r}: the {cat} needs 0 < subsurface_color <= 1 (Burley's albedo A) and a "
                              "positive radius")
        return {"albedo": a, "d_mm": ell / searchlight_scaling(a), "name": node.getName(), "shader": cat}
    raise SsskitError(f"{str(path)!r} has no open_pbr_surface or standard_surface node")


def glsl_source(mtlx_text: str) -> dict[str, str]:
    """MaterialX's GLSL shader generator on the document's first material: {"pixel": ..., "vertex": ...}."""
    import MaterialX as mx
    import MaterialX.PyMaterialXGenGlsl as mx_glsl
    import MaterialX.PyMaterialXGenShader as mx_gen

    doc = mx.createDocument()
    mx.readFromXmlString(doc, mtlx_text)
    doc.importLibrary(_libraries())
    material = next(n for n in doc.getNodes() if n.getType() == "material")
    gen = mx_glsl.GlslShaderGenerator.create()
    ctx = mx_gen.GenContext(gen)
    ctx.registerSourceCodeSearchPath(mx.getDefaultDataSearchPath())
    shader = gen.generate(material.getName(), material, ctx)
    return {"pixel": shader.getSourceCode("pixel"), "vertex": shader.getSourceCode("vertex")}


__all__ = ["check_document", "glsl_source", "materialx_document", "read_materialx", "searchlight_scaling"]
