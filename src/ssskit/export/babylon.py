"""Babylon.js: the screen-space subsurface settings of a ``PBRMaterial`` for a material's Burley fit, as an
ES module (``.js``/``.mjs``, with the function that applies it) or JSON.

**What Babylon takes** (``@babylonjs/core`` :data:`BABYLON_VERSION`, the version the client tests render with and
whose files are cited here):

* ``scene.enableSubSurfaceForPrePass()`` makes ``scene.subSurfaceConfiguration``
  (``Rendering/subSurfaceConfiguration.ts``); its constructor adds a default white profile, so a scene holds
  the default and at most :data:`MAX_PROFILES` - 1 more (``addDiffusionProfile``: "We only support 5
  diffusion profiles"; a sixth is refused with ``Logger.Error`` and index 0 returned).
* ``addDiffusionProfile(color)`` stores ``color`` as ``ssDiffusionS`` (the shader's ``diffusionS[i]``, in
  r, g, b order), ``max(r, g, b)`` as ``ssDiffusionD`` (``diffusionD[i]``) and the radius at which Burley's
  CDF with that distance reaches 0.997 as ``ssFilterRadii`` (``getDiffusionProfileParameters``).
* The pass (``Shaders/subSurfaceScattering.fragment.fx``) draws ``n = min(pi (filterRadius
  pixelsPerMm)^2 / 4, 40)`` samples at radii ``r_i = SampleBurleyDiffusionProfile((i + 0.5) / n, d)`` (Burley's
  inverse CDF, scattering distance ``d = diffusionD``, mm), on a golden-angle disk with no rotation, and
  weights each by ``EvalBurleyDiffusionProfile(r, S) / pdf`` with ``S = diffusionS`` read as Burley's *shape*
  ``s = 1 / d`` (1/mm: ``exp(-r S / 3)``), normalised by the sum of the weights. So one colour is a distance
  (mm) when sampling and an inverse distance (1/mm) when weighting; the result converges to Burley's profile
  with ``d_c = 1 / S_c``, cut at the filter radius. ``mmPerUnit = 1000 metersPerUnit`` converts the depth
  buffer's units (``uniform metersPerUnit``, set from ``subSurfaceConfiguration.metersPerUnit``).
* ``PBRMaterial.subSurface`` (``Materials/PBR/pbrSubSurfaceConfiguration.ts``): ``isScatteringEnabled``,
  ``scatteringDiffusionProfile = color`` (calls ``addDiffusionProfile``); ``isTranslucencyEnabled``,
  ``diffusionDistance`` and ``tintColor`` feed ``transmittanceBRDF_Burley`` (``pbrBRDFFunctions.fx``:
  ``tint 0.25 (e^{-t/d} + 3 e^{-t/3d})`` with ``d = diffusionDistance`` in scene units, ``t`` the thickness).
* The pre-pass (``ShadersInclude/pbrBlockPrePass.fx``, ``PREPASS_IRRADIANCE_LEGACY``) writes the diffuse
  lighting over sqrt(albedo), *clamped to [0, 1]*, and the pass multiplies the blurred result by sqrt(albedo)
  again: the plateau is ``albedoColor`` while the lit irradiance stays below sqrt(albedo) (docs/exports.md).

**The export** (Burley's A and d per channel, :func:`ssskit.export.fit_burley`): ``albedoColor = A``
(``metallic 0``, ``metallicF0Factor 0``: no specular layer, so the plateau is A), and two variants of the
profile colour, both with the weighting shape ``d_c`` exact:

* ``"plain"``: ``color_c = 1 / d_c`` (1/mm) and ``metersPerUnit`` = the scene's metres per unit; Babylon then
  samples with the distance ``max(color) = 1 / min(d)`` "mm" and cuts at 16.6 times that.
* ``"documented"``: ``"plain"`` as Babylon's documentation reads (``metersPerUnit`` the scene's); it renders
  1.7-2.6 times too wide (docs/exports.md), because the pass takes a pixel for half its size
  (``cornerPosNDC = vUV + 0.5 texelSize`` with ``viewportSize = tan(fov / 2)``: the UV is used as NDC without
  ``2 uv - 1``). ``"plain"`` and ``"widest"`` multiply ``metersPerUnit`` by :data:`PIXEL_SIZE_FIX` = 2, which
  undoes it (the depth difference of the bilateral weight then counts double: a flat surface does not notice,
  while past a sphere's terminator the narrow channels lose light, e.g. Skin1's blue 0.57x of ssskit's pass at
  0-1 d_max on a sphere of radius 8 d_max: docs/exports.md).
* ``"widest"`` (the default): the same profile shape with the samples spread over the widest channel. With
  ``metersPerUnit' = k metersPerUnit`` and ``color' = color / k`` the weights are unchanged (the pass's "mm"
  are ``k`` true mm) while the sampling distance becomes ``1 / (k^2 min d)`` true mm; ``k = 1 / sqrt(min d
  max d)`` (d in mm) makes it ``max d``, so the filter radius covers the widest channel's tail. ``k`` is
  one per scene: an export of several materials takes min and max over all of them.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from ..errors import SsskitError
from ..quantities import BURLEY_ALBEDO, LENGTH_M, LENGTH_MM, Quantity

#: the npm version the client tests pin (``.ci/run``, ``tests/export/test_babylon_client.py``)
BABYLON_VERSION = "9.37.1"
#: SubSurfaceConfiguration.addDiffusionProfile refuses a profile once ssDiffusionD holds 5 (the default included)
MAX_PROFILES = 5
#: materials of one Babylon scene: its default white takes one of the profiles
SCENE_MATERIALS = Quantity("materials", 1, MAX_PROFILES - 1, "", f"a Babylon.js scene holds {MAX_PROFILES} diffusion "
                           "profiles and its default white takes one (SubSurfaceConfiguration.addDiffusionProfile)",
                           integer=True)
#: getDiffusionProfileParameters: the filter radius is Burley's radius at this CDF value, times max(color)
FILTER_CDF = 0.997
#: the pass's sample budget (_SssSampleBudget) and one sample per this many pixels of the filter's area
SAMPLE_BUDGET = 40
PIXELS_PER_SAMPLE = 4.0
VARIANTS = ("widest", "plain", "documented")
#: the pass takes a pixel for half its size (its NDC is the UV, not 2 UV - 1: docs/engines/babylon-sss-pixel-size.md);
#: a metersPerUnit this many times the scene's undoes it (measured: docs/exports.md)
PIXEL_SIZE_FIX = 2.0
SOURCE = {
    "addDiffusionProfile": "packages/dev/core/src/Rendering/subSurfaceConfiguration.ts: addDiffusionProfile (S = "
                           "color, D = max(r, g, b), filter radius at CDF 0.997; at most 5 profiles, index 0 the "
                           "default white)",
    "metersPerUnit": "subSurfaceConfiguration.ts: metersPerUnit ('ratio real world => scene units'); "
                     "Shaders/subSurfaceScattering.fragment.fx: mmPerUnit = 1000 * metersPerUnit",
    "pass": "Shaders/subSurfaceScattering.fragment.fx: SampleBurleyDiffusionProfile(u, d) with d = diffusionD (mm), "
            "EvalBurleyDiffusionProfile(r, S) with S = diffusionS (1/mm), golden-angle disk, 40-sample budget",
    "subSurface": "packages/dev/core/src/Materials/PBR/pbrSubSurfaceConfiguration.ts: isScatteringEnabled, "
                  "scatteringDiffusionProfile, isTranslucencyEnabled, diffusionDistance, tintColor",
    "translucency": "Shaders/ShadersInclude/pbrBRDFFunctions.fx: transmittanceBRDF_Burley(tint, diffusionDistance, "
                    "thickness) = tint 0.25 (exp(-t/d) + 3 exp(-t/3d))",
    "prepass": "Shaders/ShadersInclude/pbrBlockPrePass.fx: irradiance = finalDiffuse / sqrt(albedo), clamped to "
               "[0, 1], profile index in alpha",
}


def filter_radius(distance: float) -> float:
    """Babylon's ``_sampleBurleyDiffusionProfile(0.997, distance)``: Burley's radius (Xie 2020 Eq. 4's CDF
    ``1 - e^{-x}/4 - 3 e^{-x/3}/4``, inverted in closed form as Golubev [Gol18] does) at CDF
    :data:`FILTER_CDF`, times ``distance``."""
    u = 1.0 - FILTER_CDF
    g = 1.0 + 4.0 * u * (2.0 * u + math.sqrt(1.0 + 4.0 * u * u))
    n = g ** (-1.0 / 3.0)
    p = g * n * n
    c = 1.0 + p + n
    return 3.0 * math.log(c / (4.0 * u)) * distance


def check_babylon(materials: list[tuple[str, np.ndarray, np.ndarray]]) -> None:
    """Every rule of a Babylon export, before any work: at most :data:`MAX_PROFILES` - 1 distinct profiles (the
    scene's default white takes the first of Babylon's 5 slots), finite albedo in (0, 1] and finite d > 0 mm."""
    SCENE_MATERIALS.check(len(materials), "--format babylon: the number of materials")
    for name, a, d in materials:
        BURLEY_ALBEDO.check_rgb(a, f"--format babylon: {name}: albedo")
        LENGTH_MM.check_rgb(d, f"--format babylon: {name}: Burley's d")


def babylon_parameters(materials: list[tuple[str, np.ndarray, np.ndarray]],
                       unit_m: float = 1e-3) -> dict[str, Any]:
    """The Babylon settings for ``materials`` ((name, A (3,), d (3,) mm) each) in a scene whose unit is
    ``unit_m`` metres (1e-3: the scene is in mm, as ssskit's lengths): per variant (:data:`VARIANTS`) the
    scene's ``metersPerUnit`` and each material's profile colour (module docstring), plus each material's
    ``albedoColor`` and translucency ``diffusionDistance`` (d in scene units)."""
    check_babylon(materials)
    LENGTH_M.check(unit_m, "--format babylon: the scene unit")
    dmin = min(float(np.min(d)) for _, _, d in materials)
    dmax = max(float(np.max(d)) for _, _, d in materials)
    k = 1.0 / math.sqrt(dmin * dmax)
    variants: dict[str, Any] = {}
    for variant, scale, fix in (("widest", k, PIXEL_SIZE_FIX), ("plain", 1.0, PIXEL_SIZE_FIX), ("documented", 1.0, 1.0)):
        colors = {name: (1.0 / (scale * np.asarray(d, dtype=float))).tolist() for name, _, d in materials}
        sampling = {name: max(c) / scale for name, c in colors.items()}  # the true mm Babylon samples with
        variants[variant] = {
            "metersPerUnit": unit_m * scale * fix,
            "pixel_size_fix": fix,
            "diffusionProfile": colors,
            "sampling_distance_mm": sampling,
            "filter_radius_mm": {name: filter_radius(s) for name, s in sampling.items()},
        }
    out: dict[str, Any] = {
        "engine": "babylon",
        "babylon_version": BABYLON_VERSION,
        "unit_m": unit_m,
        "default_variant": "widest",
        "variants": variants,
        "materials": {name: {"albedoColor": [float(v) for v in a], "d_mm": [float(v) for v in d],
                             "metallic": 0.0, "roughness": 1.0, "metallicF0Factor": 0.0,
                             "translucency": {"diffusionDistance": (np.asarray(d, dtype=float) * 1e-3 / unit_m).tolist(),
                                              "tintColor": [float(v) for v in a]}}
                      for name, a, d in materials},
        "formula": "color_c = 1 / (k d_c) per mm, metersPerUnit = unit_m k f (k = 1 'plain' and 'documented', "
                   "1 / sqrt(min d max d) 'widest'; f = 2 undoes the pass's half-size pixel, 1 'documented'); "
                   "albedoColor = A; translucency diffusionDistance = d in scene units",
        "sources": SOURCE,
        "notes": ["Babylon reads one colour as the sampling distance d (mm, its maximum) and as the shape S = 1/d "
                  "(1/mm, per channel) when weighting: the weights decide the profile, so the colour is 1/d",
                  "the pre-pass clamps diffuse lighting / sqrt(albedo) to [0, 1]: keep lit irradiance below "
                  "sqrt(albedo) (in Babylon's light units) or the plateau and the edge clip",
                  "translucency (thin parts) is off by default: set isTranslucencyEnabled and a thickness"],
    }
    return out


_MODULE = """// ssskit export for Babylon.js (@babylonjs/core {version}): {title}
// Screen-space subsurface scattering (PBRMaterial.subSurface + scene.subSurfaceConfiguration).
//   import {{ SSSKIT, applySsskit }} from "./THIS.js";
//   const materials = applySsskit(BABYLON, scene);           // one PBRMaterial per name, or pass your own:
//   applySsskit(BABYLON, scene, {{ {first}: myMaterial }}, "widest");   // keys: this file's names ({names})
// metersPerUnit is one per scene: materials that share a scene are exported together (--material a,b,...).
// {formula}
// Sources: {sources}
export const SSSKIT = {params};

export function applySsskit(BABYLON, scene, materials = {{}}, variant = SSSKIT.default_variant) {{
  const v = SSSKIT.variants[variant];
  if (!v) throw new Error(`ssskit: unknown variant ${{variant}} (${{Object.keys(SSSKIT.variants).join(", ")}})`);
  for (const key of Object.keys(materials))
    if (!(key in SSSKIT.materials))
      throw new Error(`ssskit: no material ${{key}} in this file (its names: ${{Object.keys(SSSKIT.materials).join(", ")}})`);
  if (!scene.enableSubSurfaceForPrePass()) throw new Error("ssskit: this engine has no pre-pass renderer (WebGL2 needed)");
  const cfg = scene.subSurfaceConfiguration, prev = cfg._ssskitMetersPerUnit;
  if (prev !== undefined && prev !== v.metersPerUnit)
    throw new Error(`ssskit: this scene's metersPerUnit is ${{prev}}, set by another ssskit export, and this file's is ` +
                    `${{v.metersPerUnit}}: a scene has one, so export the materials it shares together (ssskit export --material a,b)`);
  cfg.metersPerUnit = cfg._ssskitMetersPerUnit = v.metersPerUnit;
  const out = {{}};
  for (const [name, m] of Object.entries(SSSKIT.materials)) {{
    const mat = materials[name] || new BABYLON.PBRMaterial(name, scene);
    mat.albedoColor = new BABYLON.Color3(...m.albedoColor);
    mat.metallic = m.metallic;
    mat.roughness = m.roughness;
    mat.metallicF0Factor = m.metallicF0Factor;
    mat.subSurface.isScatteringEnabled = true;
    const before = scene.subSurfaceConfiguration.ssDiffusionProfileColors.length;
    mat.subSurface.scatteringDiffusionProfile = new BABYLON.Color3(...v.diffusionProfile[name]);
    if (mat.subSurface._scatteringDiffusionProfileIndex === 0 && before >= 5)
      throw new Error(`ssskit: ${{name}}: the scene already holds Babylon's 5 diffusion profiles`);
    mat.subSurface.diffusionDistance = new BABYLON.Color3(...m.translucency.diffusionDistance);
    mat.subSurface.tintColor = new BABYLON.Color3(...m.translucency.tintColor);
    out[name] = mat;
  }}
  return out;
}}
"""


def babylon_module(params: dict[str, Any], title: str) -> str:
    """The ES module: ``SSSKIT`` (the :func:`babylon_parameters` JSON) and ``applySsskit(BABYLON, scene,
    materials, variant)`` that sets the scene's ``metersPerUnit`` and each material's subsurface settings."""
    keep = {k: params[k] for k in ("babylon_version", "unit_m", "default_variant", "variants", "materials")}
    names = list(params["materials"])
    return _MODULE.format(version=params["babylon_version"], title=title, formula=params["formula"],
                          first=json.dumps(names[0]), names=", ".join(names),
                          sources="; ".join(params["sources"].values()), params=json.dumps(keep, indent=1))


def babylon_text(materials: list[tuple[str, np.ndarray, np.ndarray]], suffix: str, summary: dict[str, Any]) -> str:
    """The file of :func:`babylon_parameters` for ``materials``: JSON for a ``json`` suffix, else the ES module;
    fills ``summary`` (the export's)."""
    params = babylon_parameters(materials)
    summary["parameters"] = {k: params[k] for k in ("default_variant", "variants", "materials")}
    if suffix.lstrip(".") == "json":
        return json.dumps(params, indent=1) + "\n"
    return babylon_module(params, ", ".join(n for n, _, _ in materials))


def export_scene(names: list[str], out: str, **options: Any) -> dict[str, Any]:
    """``ssskit export --format babylon --material a,b,...``: one scene's materials in one file. Every check first
    (at most :data:`MAX_PROFILES` - 1 distinct names; each material read as :func:`ssskit.export.export` reads
    one, with the same ``options``), then the profiles, then one atomic write. Returns the export's summary."""
    from ..io import check_distinct, write_text
    from .api import ExportSettings, get_format
    from .engines import fit_burley
    from .readers import material_source

    if len({n.lower() for n in names}) != len(names):
        raise SsskitError(f"--material {','.join(names)}: a name is given twice")
    SCENE_MATERIALS.check(len(names), "--format babylon: the number of materials")
    sources = []
    for name in names:
        req = ExportSettings(format="babylon", out=out, material=name, **options)
        sources.append((name, material_source(req, needs=get_format("babylon").kind)))
        check_distinct(out, name, what="--out")
    # ---- work starts here
    mats = []
    for name, src in sources:
        a, d = fit_burley(src.profile())
        mats.append((name, a, d))
    summary: dict[str, Any] = {"format": "babylon", "out": out, "material": ",".join(names),
                               "model": sources[0][1].model}
    write_text(out, babylon_text(mats, req.suffix, summary))
    summary["notes"] = [n for _, src in sources for n in src.notes]
    return summary


__all__ = ["BABYLON_VERSION", "babylon_text", "export_scene", "MAX_PROFILES", "VARIANTS", "babylon_module", "babylon_parameters", "check_babylon",
           "filter_radius"]
