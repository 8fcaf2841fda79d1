"""Unreal Engine: the ``SubsurfaceProfile`` settings in both of Unreal's Burley forms, the clamps the engine
applies, an editor script that creates the asset and the details-panel text.

From UE's ``Engine/Source/Runtime/Engine/Private/SubsurfaceProfile.cpp`` (UE 5) and
``Rendering/BurleyNormalizedSSS.h`` (field names: ``Classes/Engine/SubsurfaceProfile.h``,
``FSubsurfaceProfileStruct``):

* **MFP form** (UE 5, ``bEnableMeanFreePath`` = true): ``CreateTexture`` takes
  DMFP (mm) = GetDiffuseMeanFreePathFromMeanFreePath(A, MeanFreePathColor x MeanFreePathDistance) x 10 / 0.6
  with GetDiffuseMeanFreePathFromMeanFreePath(A, l) = l s_sl(A) / s_perp(A), s_sl = 3.5 + 100 (A - 0.33)^4
  (``GetSearchLightDiffuseScalingFactor``), s_perp = 1.85 - A + 7 |A - 0.8|^3
  (``GetPerpendicularScalingFactor``), 0.6 the ``Dmfp2MfpMagicNumber``; the shader's Burley d =
  DMFP / s_sl(A) (``BurleyNormalizedSSSCommon.ush``; Xie 2020 Eq. 5 Theta_3). Together:
  d (mm) = 10 MFP (cm) / (0.6 s_perp(A)), so MFP_c (cm) = 0.06 s_perp(A_c) d_c.
* **DMFP form** (UE 4.25-4.27, ``bEnableMeanFreePath`` = false): DMFP (mm) = MeanFreePathColor x
  MeanFreePathDistance x 10 and d = DMFP / s_sl(A). UE 5 upgrades such an asset on load
  (``UpgradeDiffuseMeanFreePathToMeanFreePath``: the same DMFP, but WorldUnitScale divided by 0.3), so
  this form is for UE 4 only.
* **Clamps** (``CreateTexture``): SurfaceAlbedo and MeanFreePathColor to >= 0.009 (``Bias``), DMFP to
  <= 500 mm (``DEC_UNIT_TO_DIFFUSEMEANFREEPATH_IN_MM``); and the editor's: ``MeanFreePathDistance`` has
  ``ClampMin = "0.1"`` (cm; its UPROPERTY in ``Classes/Engine/SubsurfaceProfile.h``), so a smaller distance is
  folded into the colour the way UE's own ``UpgradeDiffuseMeanFreePathToMeanFreePath`` does ("Support mfp <
  0.1f": MeanFreePathColor x= distance / 0.1, distance = 0.1; the same MFP). ssskit applies them and reports
  each one that fires.
* The legacy separable profile (``bEnableBurley`` = false) is converted by UE 5 on load
  (``UpgradeSeparableToBurley``) and never rendered as written: it is exported for UE 4 only.

Not run in Unreal here: the editor script is checked with Python's ``ast`` against the field list.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

#: FSubsurfaceProfileStruct's fields (Classes/Engine/SubsurfaceProfile.h, UE 5; DistanceScale from UE 5.8)
SETTINGS_FIELDS = ("SurfaceAlbedo", "MeanFreePathColor", "MeanFreePathDistance", "WorldUnitScale", "bEnableBurley",
                   "bEnableMeanFreePath", "Tint", "ScatterRadius", "SubsurfaceColor", "FalloffColor",
                   "BoundaryColorBleed", "Implementation", "ExtinctionScale", "NormalScale", "ScatteringDistribution",
                   "IOR", "Roughness0", "Roughness1", "LobeMix", "TransmissionTintColor", "DistanceScale")
#: the transmission fields the editor script sets when the export carries them (UE 5.8; DistanceScale is new there)
TRANSMISSION_FIELDS = ("ExtinctionScale", "NormalScale", "ScatteringDistribution", "TransmissionTintColor",
                       "DistanceScale")
#: SubsurfaceProfile.cpp CreateTexture: the Bias clamp of colours and albedo
COLOR_BIAS = 0.009
#: SubsurfaceProfile.h: MeanFreePathDistance's ClampMin (cm)
MIN_MFP_DISTANCE_CM = 0.1
#: SubsurfaceProfile.cpp: Dmfp2MfpMagicNumber
DMFP_TO_MFP = 0.6
#: SubsurfaceProfile.cpp: DEC_UNIT_TO_DIFFUSEMEANFREEPATH_IN_MM (1 / (0.01 * 0.2))
MAX_DMFP_MM = 500.0
DEFAULT_WORLD_UNIT_SCALE = 0.1


def scaling_searchlight(a: Any) -> np.ndarray:
    """s_sl(A) = 3.5 + 100 (A - 0.33)^4 (UE GetSearchLightDiffuseScalingFactor; Xie 2020 Eq. 5 Theta_3)."""
    return 3.5 + 100.0 * (np.asarray(a, dtype=float) - 0.33) ** 4


def scaling_perpendicular(a: Any) -> np.ndarray:
    """s_perp(A) = 1.85 - A + 7 |A - 0.8|^3 (UE GetPerpendicularScalingFactor; Xie 2020 Eq. 5 Theta_1)."""
    a = np.asarray(a, dtype=float)
    return 1.85 - a + 7.0 * np.abs(a - 0.8) ** 3


def _colour(v: np.ndarray, label: str, clamps: list[str]) -> tuple[np.ndarray, float]:
    """(MeanFreePathColor, MeanFreePathDistance) of a length (3,) cm: the colour with max 1 and the distance, a
    distance below UE's ClampMin folded into the colour as UE's upgrade does (module docstring), and reported."""
    m = float(np.max(v))
    if m < MIN_MFP_DISTANCE_CM:
        clamps.append(f"{label} MeanFreePathDistance {m:.4g} -> {MIN_MFP_DISTANCE_CM:g} cm (UE's ClampMin), folded into "
                      f"MeanFreePathColor x {m / MIN_MFP_DISTANCE_CM:.4g} as UE's upgrade does (the same mean free path)")
        return v / MIN_MFP_DISTANCE_CM, MIN_MFP_DISTANCE_CM
    return v / m, m


def unreal_parameters(a: np.ndarray, d_mm: np.ndarray, eta: float | None) -> dict[str, Any]:
    """Both Burley forms of (A (3,), d (3,) mm), with every engine clamp applied and reported."""
    clamps: list[str] = []
    a = np.asarray(a, dtype=float)
    a_eng = np.clip(a, COLOR_BIAS, 1.0)
    for c in np.nonzero(a_eng != a)[0]:
        clamps.append(f"SurfaceAlbedo[{'RGB'[c]}] {a[c]:.4g} -> {a_eng[c]:.4g} (UE clamps to [0.009, 1])")
    d = np.asarray(d_mm, dtype=float)
    dmfp = d * scaling_searchlight(a_eng)
    if np.any(dmfp > MAX_DMFP_MM):
        clamps.append(f"DMFP above {MAX_DMFP_MM} mm is clamped by UE")
    # the engine reads d = DMFP / s_sl(A_eng): with A clamped, d keeps its value because DMFP is built from A_eng
    mfp_cm = d * DMFP_TO_MFP * scaling_perpendicular(a_eng) / 10.0
    mfp_col, mfp_dist = _colour(mfp_cm, "MFP", clamps)
    dmfp_col, dmfp_dist = _colour(dmfp / 10.0, "DMFP", clamps)
    for label, col in (("MFP", mfp_col), ("DMFP", dmfp_col)):
        low = np.nonzero(col < COLOR_BIAS)[0]
        for c in low:
            clamps.append(f"{label} MeanFreePathColor[{'RGB'[c]}] {col[c]:.4g} -> 0.009 (UE clamp): that channel "
                          f"renders {COLOR_BIAS / col[c]:.3g}x wider")
    ior = float(eta) if eta is not None else 1.4
    return {
        "engine": "unreal",
        "asset": "SubsurfaceProfile",
        "mfp": {
            "unreal_versions": "UE 5.0 and later",
            "bEnableBurley": True,
            "bEnableMeanFreePath": True,
            "SurfaceAlbedo": a_eng.tolist(),
            "MeanFreePathColor": mfp_col.tolist(),
            "MeanFreePathDistance": mfp_dist,
            "WorldUnitScale": DEFAULT_WORLD_UNIT_SCALE,
            "IOR": ior,
            "units": "MeanFreePathDistance in cm (Unreal units)",
            "formula": "MFP_c (cm) = 0.6 s_perp(A_c) d_c (mm) / 10, s_perp = 1.85 - A + 7 |A - 0.8|^3 (the engine: "
                       "DMFP = MFP s_sl / s_perp * 10 / 0.6, d = DMFP / s_sl)",
        },
        "dmfp": {
            "unreal_versions": "UE 4.25 - 4.27 (UE 5 upgrades it on load, dividing WorldUnitScale by 0.3)",
            "bEnableBurley": True,
            "bEnableMeanFreePath": False,
            "SurfaceAlbedo": a_eng.tolist(),
            "MeanFreePathColor": dmfp_col.tolist(),
            "MeanFreePathDistance": dmfp_dist,
            "WorldUnitScale": DEFAULT_WORLD_UNIT_SCALE,
            "IOR": ior,
            "units": "MeanFreePathDistance in cm; DiffuseMeanFreePath (mm) = MeanFreePathColor * MeanFreePathDistance * 10",
            "formula": "DMFP_c = d_c (3.5 + 100 (A_c - 0.33)^4)",
        },
        "clamps": clamps,
        "base_color": a.tolist(),
    }


def unreal_d_mm(block: dict[str, Any]) -> np.ndarray:
    """Burley's d (mm) the way UE reads one block (``mfp`` or ``dmfp``), clamps and float32 included."""
    f32 = lambda v: np.asarray(v, dtype=np.float32).astype(float)  # noqa: E731
    a = np.clip(f32(block["SurfaceAlbedo"]), COLOR_BIAS, 1.0)
    length = np.maximum(f32(block["MeanFreePathColor"]), COLOR_BIAS) * float(f32(block["MeanFreePathDistance"]))
    if block.get("bEnableMeanFreePath", True):
        dmfp = length * scaling_searchlight(a) / scaling_perpendicular(a) * 10.0 / DMFP_TO_MFP
    else:
        dmfp = length * 10.0
    return np.minimum(dmfp, MAX_DMFP_MM) / scaling_searchlight(a)


def _snake(field: str) -> str:
    """UE Python's property name: bool 'b' prefix dropped, CamelCase to snake_case (IOR -> ior)."""
    name = field[1:] if field.startswith("b") and field[1:2].isupper() else field
    out = ""
    for i, ch in enumerate(name):
        if ch.isupper() and i and (not name[i - 1].isupper() or (i + 1 < len(name) and name[i + 1].islower())):
            out += "_"
        out += ch.lower()
    return out


def details_text(block: dict[str, Any], transmission: dict[str, Any] | None = None) -> str:
    """The Settings struct as Unreal's details panel copies and pastes it (right-click > Paste on Settings), with
    the fitted transmission fields when given."""
    col = lambda v: f"(R={v[0]:.6f},G={v[1]:.6f},B={v[2]:.6f},A=1.000000)"  # noqa: E731
    parts = [f"SurfaceAlbedo={col(block['SurfaceAlbedo'])}", f"MeanFreePathColor={col(block['MeanFreePathColor'])}",
             f"MeanFreePathDistance={block['MeanFreePathDistance']:.6f}", f"WorldUnitScale={block['WorldUnitScale']:.6f}",
             f"bEnableBurley={block['bEnableBurley']}", f"bEnableMeanFreePath={block['bEnableMeanFreePath']}",
             f"IOR={block['IOR']:.6f}"]
    for k in TRANSMISSION_FIELDS if transmission else ():
        v = transmission[k]  # type: ignore[index]
        parts.append(f"{k}={col(v)}" if isinstance(v, list) else f"{k}={float(v):.6f}")
    return "(" + ",".join(parts) + ")"


_SCRIPT = '''"""ssskit export for Unreal Engine ({versions}): the SubsurfaceProfile {name!r}.

Run in the Unreal Editor (Python Editor Script Plugin enabled): Tools > Execute Python Script, or
`py "THIS.py"` in the Output Log. Creates (or updates) {package}/{name} and saves it.
Not run in Unreal by ssskit: checked with Python's ast against FSubsurfaceProfileStruct's fields.
{clamps}"""

import unreal

PACKAGE = {package!r}
NAME = {name!r}
SETTINGS = {settings}
TRANSMISSION = {transmission}
PROPERTY = {properties}


def _colour(v):
    return unreal.LinearColor(float(v[0]), float(v[1]), float(v[2]), 1.0)


def main():
    path = PACKAGE + "/" + NAME
    if unreal.EditorAssetLibrary.does_asset_exist(path):
        asset = unreal.EditorAssetLibrary.load_asset(path)
    else:
        tools = unreal.AssetToolsHelpers.get_asset_tools()
        asset = tools.create_asset(NAME, PACKAGE, unreal.SubsurfaceProfile, unreal.SubsurfaceProfileFactory())
    settings = asset.get_editor_property("settings")
    settings.set_editor_property("surface_albedo", _colour(SETTINGS["SurfaceAlbedo"]))
    settings.set_editor_property("mean_free_path_color", _colour(SETTINGS["MeanFreePathColor"]))
    settings.set_editor_property("mean_free_path_distance", float(SETTINGS["MeanFreePathDistance"]))
    settings.set_editor_property("world_unit_scale", float(SETTINGS["WorldUnitScale"]))
    settings.set_editor_property("enable_burley", bool(SETTINGS["bEnableBurley"]))
    settings.set_editor_property("enable_mean_free_path", bool(SETTINGS["bEnableMeanFreePath"]))
    settings.set_editor_property("ior", float(SETTINGS["IOR"]))
    for field, value in TRANSMISSION.items():  # fitted to the material's Monte Carlo transmittance (ssskit)
        prop = PROPERTY[field]
        try:
            settings.set_editor_property(prop, _colour(value) if isinstance(value, list) else float(value))
        except Exception as exc:  # DistanceScale exists from UE 5.8 on
            unreal.log_warning("ssskit: " + prop + " not set (" + str(exc) + ")")
    asset.set_editor_property("settings", settings)
    unreal.EditorAssetLibrary.save_loaded_asset(asset)
    unreal.log("ssskit: wrote " + path)


main()
'''

#: the FSubsurfaceProfileStruct fields the editor script sets
SCRIPT_FIELDS = ("SurfaceAlbedo", "MeanFreePathColor", "MeanFreePathDistance", "WorldUnitScale", "bEnableBurley",
                 "bEnableMeanFreePath", "IOR")


def unreal_script(params: dict[str, Any], name: str, form: str = "mfp", package: str = "/Game/SSS") -> str:
    """The Unreal editor Python script that creates or updates the SubsurfaceProfile (``form``: mfp or dmfp)."""
    block = params[form]
    settings = {k: block[k] for k in SCRIPT_FIELDS}
    clamps = "".join(f"Clamp: {c}\n" for c in params.get("clamps", []))
    tr = params.get("transmission") or {}
    transmission = {k: tr[k] for k in TRANSMISSION_FIELDS if k in tr}
    return _SCRIPT.format(versions=block["unreal_versions"], name=name, package=package,
                          settings=json.dumps(settings, indent=4).replace("true", "True").replace("false", "False"),
                          transmission=json.dumps(transmission, indent=4),
                          properties=json.dumps({k: _snake(k) for k in TRANSMISSION_FIELDS}, indent=4), clamps=clamps)


__all__ = ["COLOR_BIAS", "SCRIPT_FIELDS", "SETTINGS_FIELDS", "TRANSMISSION_FIELDS", "details_text", "scaling_perpendicular",
           "scaling_searchlight", "unreal_d_mm", "unreal_parameters", "unreal_script", "_snake"]
