"""Blender: the Principled BSDF's subsurface settings for Cycles, the script that applies them, and the
Cycles slab that proves them.

**The radius mapping** (Cycles X, Blender 3.0 through 4.2 and later; checked in Cycles by
:func:`render_slab`). Cycles ``kernel/closure/bssrdf.h`` ``bssrdf_setup_radius`` multiplies the
node's radius (``Subsurface Radius`` x ``Subsurface Scale``, scene units) by 0.25 / pi for the
Christensen-Burley method (``CLOSURE_BSSRDF_BURLEY_ID``; in 4.x also for ``RANDOM_WALK``) and uses
the result as Burley's d directly in ``bssrdf_burley_eval`` (Xie 2020 Eq. 4 as 2 pi r R(r) / A),
truncated at 16 d and renormalised by its CDF there (``BURLEY_TRUNCATE``, ``BURLEY_TRUNCATE_CDF`` =
0.99638). So radius x scale = 4 pi d. (``bssrdf_burley_setup``, which divided further by
1.9 - A + 3.5 (A - 0.8)^2, has not been called since Cycles X; an export that follows it is too wide
by that factor.) The plateau is the base colour: the BSSRDF's weight is the base colour and the
profile is normalised (``bssrdf_burley_pdf``).

**Random Walk** (the node's default in 4.x) reads the same radius as a mean free path
(``subsurface_random_walk.h``: sigma_t' = 1 / (radius / 4 pi), the single-scattering albedo from the
base colour by van de Hulst's inversion); its plateau and width differ from the Burley numbers
(measured by ``benchmarks/blender_cycles.py``, docs/exports.md). The exported script sets BURLEY.

:func:`blender_script` writes a script that runs inside Blender (or on ``bpy``): it creates or updates a
material with a Principled BSDF set for Christensen-Burley, looking sockets up by identifier and skipping
those a version lacks (``node.inputs["Subsurface IOR"]`` is hidden and absent from lookups in some
versions).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SsskitError

#: Cycles bssrdf_setup_radius: radius x scale (scene units) = 4 pi d (Burley's d, same units)
RADIUS_PER_D = 4.0 * math.pi
#: Cycles BURLEY_TRUNCATE and BURLEY_TRUNCATE_CDF (bssrdf.h): the profile stops at 16 d, renormalised
CYCLES_TRUNCATE = 16.0
CYCLES_TRUNCATE_CDF = 0.9963790093708328
EEVEE_SOURCE = ("Blender source/blender/draw/engines/eevee_next/shaders/eevee_subsurface_convolve_comp.glsl (4.2): "
                "d = burley_setup(clamped_sss_radius, albedo) with burley_setup = radius / (4 pi s(A / max A)) "
                "(eevee_subsurface_lib.glsl); 16 samples (eevee_subsurface.cc: sample_len = 16 whatever sss_samples)")
#: the Blender versions whose Cycles has this mapping (bssrdf_setup_radius since Cycles X)
BLENDER_VERSIONS = ">= 3.0 (Cycles X) through 4.2 (tested with the bpy 4.2.0 wheel)"
SOURCE = ("Blender Cycles intern/cycles/kernel/closure/bssrdf.h, bssrdf_setup_radius (Blender 3.0 - 4.2): "
          "radius *= 0.25 * M_1_PI_F for CLOSURE_BSSRDF_BURLEY_ID, then bssrdf_burley_eval with d = radius, "
          "truncated at BURLEY_TRUNCATE = 16 d; the BSSRDF weight is the base colour")


def blender_parameters(a: np.ndarray, d_mm: np.ndarray, eta: float | None = None, g: float | None = None,
                       unit_m: float = 1.0) -> dict[str, Any]:
    """The Principled BSDF settings for Burley (A (3,), d (3,) mm): ``base_color`` = A,
    ``subsurface_radius`` x ``subsurface_scale`` = 4 pi d in scene units (Cycles bssrdf_setup_radius,
    module docstring); the radius is the colour with max 1, the scale its maximum."""
    radius_units = np.asarray(d_mm, dtype=float) * RADIUS_PER_D * 1e-3 / unit_m
    scale = float(np.max(radius_units))
    out: dict[str, Any] = {
        "engine": "blender",
        "node": "Principled BSDF",
        "renderer": "Cycles",
        "blender_versions": BLENDER_VERSIONS,
        "subsurface_method": "BURLEY",
        "base_color": [float(v) for v in a],
        "subsurface_weight": 1.0,
        "subsurface_radius": (radius_units / scale).tolist(),
        "subsurface_scale": scale,
        "specular_ior_level": 0.0,
        "unit_scale": unit_m,
        "units": "subsurface_radius * subsurface_scale in scene units (metres per unit: unit_scale)",
        "formula": "radius_c * scale = 4 pi d_c (Cycles bssrdf_setup_radius: d = radius / (4 pi)), mm -> scene "
                   "units; base_color = A",
        "notes": ["specular_ior_level 0: the plateau is then base_color; a specular layer takes its share",
                  "the numbers are for subsurface_method BURLEY (Christensen-Burley); RANDOM_WALK reads the "
                  "radius as a mean free path and renders another plateau and width (docs/exports.md)"],
    }
    eevee = radius_units * eevee_radius_scale(np.asarray(a, dtype=float))
    out["eevee"] = {"subsurface_radius": (eevee / float(np.max(eevee))).tolist(),
                    "subsurface_scale": float(np.max(eevee)),
                    "formula": "radius_c * scale = 4 pi d_c s(A'_c), A' = A / max A, s = 1.9 - A' + 3.5 (A' - 0.8)^2 "
                               "(EEVEE Next burley_setup); for EEVEE only: Cycles renders it s(A') times too wide",
                    "source": EEVEE_SOURCE}
    if eta is not None:
        out["ior"] = float(eta)
    if g is not None:
        out["subsurface_anisotropy"] = float(g)
    return out


def eevee_radius_scale(a: np.ndarray) -> np.ndarray:
    """EEVEE Next's per-channel narrowing: its subsurface gather (``eevee_subsurface_convolve_comp.glsl``) weights
    with d = radius / (4 pi s(A')), ``burley_setup``'s s(A') = 1.9 - A' + 3.5 (A' - 0.8)^2 of the albedo scaled to
    max 1 (A' = A / max A; the searchlight fit of Christensen and Burley 2015 [CB15], which Cycles dropped with Cycles X), where Cycles reads
    d = radius / (4 pi). Multiplying the exported radius by s(A') gives EEVEE's weights Cycles' d (and makes
    Cycles s(A') times too wide: the ``eevee`` variant is for EEVEE only)."""
    ap = np.asarray(a, dtype=float) / max(float(np.max(a)), 1e-6)
    return 1.9 - ap + 3.5 * (ap - 0.8) ** 2


def blender_d_mm(params: dict[str, Any]) -> np.ndarray:
    """Burley's d (mm) the way Cycles reads the settings: radius x scale x unit / (4 pi) (float32, as stored)."""
    f32 = lambda v: np.asarray(v, dtype=np.float32).astype(float)  # noqa: E731
    r = f32(params["subsurface_radius"]) * f32(params["subsurface_scale"]) * float(params.get("unit_scale", 1.0))
    return r * 1e3 / RADIUS_PER_D


_SCRIPT = '''"""ssskit export for Blender (Cycles): {title}.

Run inside Blender (Scripting tab, or `blender --python THIS.py`) or with the bpy module
(`python THIS.py -- [--eevee] [--blend OUT.blend]`). It creates the material {name!r}, or updates it if it
exists, and assigns it to the selected mesh objects.

Mapping: {formula}
Valid for Blender {versions}: {source}.
The numbers are for Cycles; `--eevee` (or ssskit_material(variant="eevee")) sets the radius EEVEE Next's
screen-space gather needs for the same profile (docs/exports.md). They are for subsurface_method BURLEY; set_method(material, "RANDOM_WALK") switches the method
but then the radius is read as a mean free path and the plateau and width change (docs/exports.md).
"""

import sys

import bpy

PARAMS = {params}


def _socket(node, *names):
    """The first input socket with one of these identifiers or names (None if this version has none)."""
    for s in node.inputs:
        if s.identifier in names or s.name in names:
            return s
    return None


def _set(node, value, *names):
    s = _socket(node, *names)
    if s is not None:
        s.default_value = value
    return s is not None


def set_method(material, method):
    for node in material.node_tree.nodes:
        if node.type == "BSDF_PRINCIPLED":
            node.subsurface_method = method


def ssskit_material(name=None, variant="cycles"):
    """Create or update the material and return it. variant "eevee": the radius EEVEE Next's gather needs
    for the same profile (PARAMS["eevee"]; Cycles renders that one too wide)."""
    name = name or PARAMS["name"]
    radius, scale = PARAMS["subsurface_radius"], PARAMS["subsurface_scale"]
    if variant == "eevee":
        radius, scale = PARAMS["eevee"]["subsurface_radius"], PARAMS["eevee"]["subsurface_scale"]
    elif variant != "cycles":
        raise ValueError(f"variant must be 'cycles' or 'eevee', not {{variant!r}}")
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    node = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
    if node is None:
        node = nodes.new("ShaderNodeBsdfPrincipled")
        out = next((n for n in nodes if n.type == "OUTPUT_MATERIAL"), None) or nodes.new("ShaderNodeOutputMaterial")
        mat.node_tree.links.new(node.outputs[0], out.inputs["Surface"])
    node.subsurface_method = PARAMS["subsurface_method"]
    a = PARAMS["base_color"]
    _set(node, (a[0], a[1], a[2], 1.0), "Base Color")
    _set(node, (a[0], a[1], a[2], 1.0), "Subsurface Color")  # Blender < 4.0
    if not _set(node, PARAMS["subsurface_weight"], "Subsurface Weight"):
        _set(node, PARAMS["subsurface_weight"], "Subsurface")  # Blender < 4.0
    _set(node, tuple(radius), "Subsurface Radius")
    _set(node, scale, "Subsurface Scale")
    if "ior" in PARAMS:
        _set(node, PARAMS["ior"], "IOR")
        _set(node, PARAMS["ior"], "Subsurface IOR")
    if "subsurface_anisotropy" in PARAMS:
        _set(node, PARAMS["subsurface_anisotropy"], "Subsurface Anisotropy")
    if not _set(node, PARAMS["specular_ior_level"], "Specular IOR Level"):
        _set(node, PARAMS["specular_ior_level"], "Specular")  # Blender < 4.0
    _set(node, 0.0, "Metallic")
    for weight in ("Coat Weight", "Sheen Weight", "Transmission Weight", "Emission Strength"):
        _set(node, 0.0, weight)
    return mat


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    material = ssskit_material(variant="eevee" if "--eevee" in argv else "cycles")
    for obj in getattr(bpy.context, "selected_objects", None) or []:
        if obj.type == "MESH":
            obj.data.materials.clear()
            obj.data.materials.append(material)
    if "--blend" in argv:
        bpy.ops.wm.save_as_mainfile(filepath=argv[argv.index("--blend") + 1])
'''


def blender_script(params: dict[str, Any], name: str) -> str:
    """The Python script (Blender or bpy) that creates or updates material ``name`` with ``params``
    (:func:`blender_parameters`); the parameters are embedded as a Python literal."""
    keep: dict[str, Any] = {k: params[k] for k in ("subsurface_method", "base_color", "subsurface_weight", "subsurface_radius",
                                   "subsurface_scale", "specular_ior_level", "ior", "subsurface_anisotropy", "eevee")
            if k in params}
    keep["name"] = name
    text = json.dumps(keep, indent=4)
    return _SCRIPT.format(title=name, name=name, formula=params["formula"], versions=BLENDER_VERSIONS,
                          source=SOURCE, params=text)


# ------------------------------------------------------------------------------ the client: Cycles


def find_blender_python() -> tuple[str | None, str]:
    """(a Python that imports bpy, why not): ``SSSKIT_BLENDER_PYTHON`` if set, else this interpreter when
    it has the bpy module (``pip install bpy==4.2.0``, Python 3.11)."""
    env = os.environ.get("SSSKIT_BLENDER_PYTHON")
    if env:
        if shutil.which(env) or Path(env).is_file():
            return env, ""
        return None, f"SSSKIT_BLENDER_PYTHON={env!r} is not an executable"
    import importlib.util

    if importlib.util.find_spec("bpy") is not None:
        return sys.executable, ""
    return None, "the bpy module is not installed (pip install bpy==4.2.0 on Python 3.11, or set SSSKIT_BLENDER_PYTHON)"


def slab_extent_mm(d_mm: float, level: float = 0.01, margin: float = 1.6) -> float:
    """Half-width (mm) of the slab view for one channel: ``margin`` times the distance at which the
    normalised edge falls to ``level``."""
    return margin * float(edge_distances(d_mm, (level,))[0])


def render_slab(script: str | Path, channels_d_mm: list[float], width: int = 160, height: int = 12,
                samples: int = 32, seed: int = 1, method: str | None = None, unit_m: float = 1.0,
                timeout: float = 600.0, python: str | None = None, engine: str = "CYCLES",
                eevee: dict[str, Any] | None = None, variant: str | None = None) -> dict[str, Any]:
    """Render the Cycles slab (``cycles_slab.py``) once per channel, each view sized to that channel's
    edge (``channels_d_mm``: the d ssskit predicts), with the material of the exported ``script``, plus a
    white Lambertian reference per view. ``engine``: "CYCLES", or "BLENDER_EEVEE_NEXT" (``samples`` are
    then its TAA render samples, ``eevee`` its other settings: ``sss_samples``, ``light``; the edge is a
    spot cone's rim, ``cycles_slab._spot_edge``). Returns {"images": [(H, W, 3)] per channel, "white": [...],
    "extent_mm": [...], "seconds": ..., "blender": version}."""
    here = Path(__file__).with_name("cycles_slab.py")
    renders = []
    extents = []
    for c, d in enumerate(channels_d_mm):
        ext_mm = slab_extent_mm(d)
        extents.append(ext_mm)
        common = {"extent_m": ext_mm * 1e-3 / unit_m, "width": width, "height": height, "seed": seed + c,
                  "engine": engine, **(eevee or {})}
        renders.append({**common, "key": f"c{c}", "script": str(script), "samples": samples, "method": method,
                        "variant": variant})
        renders.append({**common, "key": f"w{c}", "white": True, "samples": 1 if engine == "CYCLES" else samples})
    data, meta = run_bpy_job(here, {"renders": renders}, f"the {engine} slab render", timeout, python)
    n = len(channels_d_mm)
    return {"images": [data[f"c{c}"] for c in range(n)], "white": [data[f"w{c}"] for c in range(n)],
            "extent_mm": extents, "seconds": meta["seconds"], "blender": meta["blender"],
            "width": width, "height": height, "samples": samples, "engine": engine}


def run_bpy_job(script: Path, config: dict[str, Any], what: str, timeout: float, python: str | None = None,
                arrays: dict[str, dict[str, Any]] | None = None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Run a bpy scene script (``cycles_slab.py``, ``head_scene.py``: ``python SCRIPT CONFIG OUT``) in a folder of
    its own: ``config`` (plus ``threads``, and per entry of ``arrays`` the path of that .npz, written first) as
    its JSON, the images it saves to OUT read back with OUT.json's metadata. A failed or interrupted render is an
    :class:`~ssskit.errors.SsskitError` naming ``what``, and nothing of it is kept. ``python``: Blender's Python (by
    default :func:`find_blender_python`'s, an error saying how to get one where there is none)."""
    exe = python or find_blender_python()[0]
    if exe is None:
        raise SsskitError(find_blender_python()[1])
    with tempfile.TemporaryDirectory() as tmp:
        cfg = dict(config, threads=os.cpu_count() or 1)
        for name, arrs in (arrays or {}).items():
            cfg[name] = str(Path(tmp) / f"{name}.npz")
            np.savez(cfg[name], **arrs)
        (Path(tmp) / "config.json").write_text(json.dumps(cfg))
        out = Path(tmp) / "out.npz"
        proc = subprocess.run([exe, str(script), str(Path(tmp) / "config.json"), str(out)], capture_output=True,
                              text=True, timeout=timeout)
        if proc.returncode != 0 or not out.is_file():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-5:]
            raise SsskitError(f"{what} failed (exit {proc.returncode}): {' | '.join(tail)}")
        with np.load(out) as data:
            images = {k: np.array(data[k]) for k in data.files}
        return images, json.loads(Path(str(out) + ".json").read_text())


# ------------------------------------------------------------------------- ssskit's own prediction


def _truncated_radial_pdf(r: np.ndarray, d: float) -> np.ndarray:
    """Cycles' Burley radius density: (e^{-r/d} + e^{-r/3d}) / (4 d) / 0.99638 for r < 16 d, else 0
    (bssrdf_burley_eval / bssrdf_burley_pdf; Xie 2020 Eq. 4 as 2 pi r R(r) / A)."""
    p = (np.exp(-r / d) + np.exp(-r / (3.0 * d))) / (4.0 * d) / CYCLES_TRUNCATE_CDF
    return np.where(r < CYCLES_TRUNCATE * d, p, 0.0)


def edge_response(x_mm: np.ndarray, d_mm: float, truncated: bool = True) -> np.ndarray:
    """The normalised radiance at signed distance x from a sharp shadow edge (x < 0 in shadow, x > 0
    lit) under a Burley profile with length d: S(x) = 1 - F(|x|) for x > 0 and F(|x|) for x <= 0, where
    F(u) = int_u^inf p(r) arccos(u / r) / pi dr is the share of a point's light that lands beyond a line
    at distance u (the 2D profile integrated over a half plane; p = 2 pi r R(r) / A the radius density,
    Xie 2020 Eq. 4; Cycles' truncation at 16 d when ``truncated``)."""
    x = np.atleast_1d(np.asarray(x_mm, dtype=float))
    u = np.abs(x)
    r_max = (CYCLES_TRUNCATE if truncated else 60.0) * d_mm
    t = np.linspace(0.0, 1.0, 4001)
    out = np.empty_like(u)
    for i, ui in enumerate(u):
        if ui >= r_max:
            out[i] = 0.0
            continue
        # r = ui + (r_max - ui) s^2 clusters nodes at the lower end (arccos's sqrt singularity)
        r = ui + (r_max - ui) * t**2
        dr = 2.0 * (r_max - ui) * t
        pdf = _truncated_radial_pdf(r, d_mm) if truncated else \
            (np.exp(-r / d_mm) + np.exp(-r / (3.0 * d_mm))) / (4.0 * d_mm)
        with np.errstate(invalid="ignore", divide="ignore"):
            ac = np.arccos(np.clip(np.where(r > 0, ui / r, 1.0), -1.0, 1.0))
        out[i] = float(np.trapezoid(pdf * ac / np.pi * dr, t))
    return np.where(x > 0, 1.0 - out, out)


def edge_distances(d_mm: float, levels: tuple[float, ...] = (0.25, 0.10, 0.03, 0.01), truncated: bool = True) -> np.ndarray:
    """The distances (mm) into the shadow at which :func:`edge_response` falls to each level."""
    from scipy.optimize import brentq

    out = []
    for lev in levels:
        f = lambda u, lev=lev: float(edge_response(np.array([-u]), d_mm, truncated)[0]) - lev  # noqa: E731
        out.append(brentq(f, 1e-9 * d_mm, 15.9 * d_mm, xtol=1e-7 * d_mm))
    return np.array(out)


LEVELS = (0.25, 0.10, 0.03, 0.01)


def _monotone(y: np.ndarray) -> np.ndarray:
    """The non-decreasing least-squares fit to y (pool-adjacent-violators): the edge rises from the
    shadow into the light, so its noise cannot make it cross a level twice."""
    vals: list[float] = []
    counts: list[int] = []
    for v in y:
        vals.append(float(v))
        counts.append(1)
        while len(vals) > 1 and vals[-2] > vals[-1]:
            n = counts[-2] + counts[-1]
            vals[-2] = (vals[-2] * counts[-2] + vals[-1] * counts[-1]) / n
            counts[-2] = n
            vals.pop()
            counts.pop()
    return np.repeat(vals, counts)


def _crossing(x: np.ndarray, norm: np.ndarray, level: float) -> float | None:
    """The distance into the shadow (x < 0) at which the monotone fit of ``norm`` falls to ``level``."""
    m = _monotone(norm)
    k = np.nonzero(m >= level)[0]
    if k.size == 0 or k[0] == 0 or x[k[0]] > 0:
        return None
    i1, i0 = int(k[0]), int(k[0]) - 1  # m[i0] < level <= m[i1]
    t = (level - m[i0]) / (m[i1] - m[i0]) if m[i1] > m[i0] else 0.5
    return float(-(x[i0] + t * (x[i1] - x[i0])))


def compare_slab(render: dict[str, Any], a: np.ndarray, d_mm: np.ndarray,
                 levels: tuple[float, ...] = LEVELS, groups: int = 8, trim: float = 0.0) -> dict[str, Any]:
    """Rendered slab against ssskit's prediction, per channel.

    ``plateau_ratio``: the lit side beyond the 1 % distance, in units of the white reference's lit
    half (E / pi), over the predicted level there (A (1 - F)): rendered over exported albedo, with its
    standard error from the rows' scatter. ``distances``: where the row-averaged edge, normalised by
    the measured plateau and fitted monotone (pool-adjacent-violators), falls to each level going into
    the shadow, against :func:`edge_distances`; the noise ``se_mm`` is the scatter of the same distance
    measured in ``groups`` disjoint groups of rows, over sqrt(groups); ``tolerance`` = max(5 %, 3 se / x).
    ``mean_abs_edge_error``: mean |normalised edge - prediction| over the view. ``trim`` > 0: each column's
    mean over rows leaves out that share of rows at each end (EEVEE's gather leaves sparse bright rows).
    """
    from scipy.stats import trim_mean

    def row_mean(block: np.ndarray) -> np.ndarray:
        return np.asarray(trim_mean(block, trim, axis=0)) if trim > 0 else block.mean(axis=0)

    out: dict[str, Any] = {"channels": []}
    for c, (img, white, ext) in enumerate(zip(render["images"], render["white"], render["extent_mm"])):
        h, w = img.shape[:2]
        x = (np.arange(w) + 0.5) / w * 2.0 * ext - ext  # pixel centres, mm (box filter: pixel means)
        rows = img[:, :, c].astype(float)
        wref = float(np.mean(white[:, x > 0, c]))
        x_fine = x[:, None] + (np.arange(8) + 0.5)[None, :] / 8.0 * (2.0 * ext / w) - ext / w
        pred = edge_response(x_fine.ravel(), float(d_mm[c])).reshape(x_fine.shape).mean(axis=1)
        lit = x > edge_distances(float(d_mm[c]), (0.01,))[0]

        def measure(sel: np.ndarray) -> tuple[float, list[float | None]]:
            col = row_mean(rows[sel]) / wref
            lev = float(np.mean(col[lit])) / float(np.mean(pred[lit]))
            return lev, [_crossing(x, col / lev, q) for q in levels]

        level, xs = measure(np.ones(h, dtype=bool))
        parts = [measure(np.arange(h) % groups == k) for k in range(groups)]
        level_se = float(np.std([p[0] for p in parts], ddof=1) / math.sqrt(groups))
        norm = row_mean(rows) / wref / level
        dist = []
        for j, (lev, xp) in enumerate(zip(levels, edge_distances(float(d_mm[c]), levels))):
            xm = xs[j]
            got = [v for p in parts if (v := p[1][j]) is not None]
            se = float(np.std(got, ddof=1) / math.sqrt(len(got))) if len(got) > 2 else float("inf")
            if xm is None:
                dist.append({"level": lev, "predicted_mm": float(xp), "measured_mm": None, "ok": False})
                continue
            rel = xm / xp - 1.0
            tol = max(0.05, 3.0 * se / xp)
            dist.append({"level": lev, "predicted_mm": float(xp), "measured_mm": xm, "relative_error": rel,
                         "se_mm": se, "tolerance": tol, "ok": bool(abs(rel) <= tol)})
        out["channels"].append({"albedo": float(a[c]), "d_mm": float(d_mm[c]), "extent_mm": ext,
                                "plateau_ratio": level / float(a[c]), "plateau_se": level_se / float(a[c]),
                                "mean_abs_edge_error": float(np.mean(np.abs(norm - pred))), "distances": dist})
    return out


def distance_cells(channel: dict[str, Any], form: str = "error") -> list[str]:
    """The table cells of one channel of :func:`compare_slab` (the benchmarks' markdown): per level
    ``"error"``: measured / predicted - 1 +- the noise, or ``"ratio"``: measured / predicted +- the noise."""
    cells = []
    for q in channel["distances"]:
        if q.get("measured_mm") is None:
            cells.append("not reached")
            continue
        se = q["se_mm"] / q["predicted_mm"] if math.isfinite(q["se_mm"]) else 0.0
        if form == "ratio":
            cells.append(f"{q['measured_mm'] / q['predicted_mm']:.2f} ± {se:.2f}")
        else:
            cells.append(f"{q['relative_error']:+.1%} ± {se:.1%}")
    return cells


__all__ = ["BLENDER_VERSIONS", "distance_cells", "LEVELS", "RADIUS_PER_D", "blender_d_mm", "eevee_radius_scale", "blender_parameters", "blender_script",
           "compare_slab", "edge_distances", "edge_response", "find_blender_python", "render_slab"]
