"""Unity HDRP: the ``DiffusionProfileSettings`` asset (YAML) and its colours as stored and as shown.

Field names, types and serialisation from HDRP's own source (Unity-Technologies/Graphics,
``Runtime/Material/DiffusionProfile/DiffusionProfileSettings.cs``, ``DiffusionProfileSettings.Migration.cs``)
and the assets HDRP ships (``Runtime/RenderPipelineResources/defaultDiffusionProfile.asset``, the
MaterialSamples diffusion profiles, whose ``m_Script`` names the script GUID below):

* a ``MonoBehaviour`` (``--- !u!114 &11400000``) with ``m_Script: {fileID: 11500000, guid: SCRIPT_GUID,
  type: 3}``, ``profile`` (the serialised ``DiffusionProfile``) and ``m_Version`` 2
  (``Version.SplitScatteringDistance``: LDR colour + multiplier);
* ``profile``: ``scatteringDistance`` (Color, ``[ColorUsage(false, false)]``: an LDR colour, stored
  linear), ``scatteringDistanceMultiplier``, ``transmissionTint``, ``texturingMode``,
  ``smoothnessMultipliers``, ``lobeMix``, ``diffuseShadingPower``, ``transmissionMode``,
  ``thicknessRemap``, ``worldScale``, ``ior``, ``hash``;
* transmission: ``transmissionMode`` 0 (``TransmissionMode.Regular``, shown as "Thick Object": the shadow-map
  thickness), ``transmissionTint`` (``[ColorUsage(false, true)]``: an HDR colour, stored linear) and
  ``thicknessRemap`` (x = min, y = max, mm) fitted to the material's MCML T(t) when the parameters carry them
  (:func:`ssskit.export.transmission.hdrp_transmission`), else HDRP's defaults (white, (0, 5)).

The shape: ``UpdateKernel``: S = 1 / (scatteringDistance x scatteringDistanceMultiplier) and
R(r) = S (e^{-Sr} + e^{-Sr/3}) / (8 pi r): Burley (Xie 2020 Eq. 4) with d = scatteringDistance x
multiplier, in mm at worldScale 1 (HDRP's diffusion-profile reference: "when the world scale is 1, this
value is in millimeters"). ``hash`` is written 0: HDRP's editor gives the profile a unique hash
(``DiffusionProfileHashTable``, called from ``OnEnable``). Not loaded in Unity here: the file is checked
with a YAML parser against the field list above.

Colours: the asset stores linear values; with a project in linear colour space the inspector's colour
picker shows them sRGB-encoded (IEC 61966-2-1 transfer function), so both are given.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import SsskitError
from ..quantities import check_keys

#: the m_Script GUID of DiffusionProfileSettings.cs (HDRP's own .asset files name it)
SCRIPT_GUID = "b2686e09ec7aef44bad2843e4416f057"
#: DiffusionProfileSettings.Migration.cs: Version.SplitScatteringDistance
ASSET_VERSION = 2
#: the serialised fields of DiffusionProfile (DiffusionProfileSettings.cs), in declaration order
PROFILE_FIELDS = ("scatteringDistance", "scatteringDistanceMultiplier", "transmissionTint", "texturingMode",
                  "smoothnessMultipliers", "lobeMix", "diffuseShadingPower", "transmissionMode", "thicknessRemap",
                  "worldScale", "ior", "hash")
MONOBEHAVIOUR_FIELDS = ("m_ObjectHideFlags", "m_CorrespondingSourceObject", "m_PrefabInstance", "m_PrefabAsset",
                        "m_GameObject", "m_Enabled", "m_EditorHideFlags", "m_Script", "m_Name",
                        "m_EditorClassIdentifier", "profile", "m_Version")


def srgb_encode(linear: Any) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1): 12.92 c for c <= 0.0031308, else 1.055 c^(1/2.4) - 0.055."""
    c = np.clip(np.asarray(linear, dtype=float), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1.0 / 2.4) - 0.055)


def srgb_decode(encoded: Any) -> np.ndarray:
    """The inverse of :func:`srgb_encode`."""
    e = np.clip(np.asarray(encoded, dtype=float), 0.0, 1.0)
    return np.where(e <= 0.04045, e / 12.92, ((e + 0.055) / 1.055) ** 2.4)


def _g(v: float) -> str:
    return f"{float(v):.9g}"


def unity_asset(params: dict[str, Any], name: str) -> str:
    """The ``DiffusionProfileSettings`` .asset text for the parameters of ``engine_parameters(..., "unity")``."""
    sd = params["scatteringDistance"]
    tr = params.get("transmission") or {}
    tint = tr.get("transmissionTint", (1.0, 1.0, 1.0))  # HDRP's defaults without the MCML fit (ResetToDefault)
    remap = tr.get("thicknessRemap", (0.0, 5.0))  # (name: ssskit.export.formats.asset_name's letters, digits, _ and -)
    return "\n".join([
        "%YAML 1.1",
        "%TAG !u! tag:unity3d.com,2011:",
        "--- !u!114 &11400000",
        "MonoBehaviour:",
        "  m_ObjectHideFlags: 0",
        "  m_CorrespondingSourceObject: {fileID: 0}",
        "  m_PrefabInstance: {fileID: 0}",
        "  m_PrefabAsset: {fileID: 0}",
        "  m_GameObject: {fileID: 0}",
        "  m_Enabled: 1",
        "  m_EditorHideFlags: 0",
        f"  m_Script: {{fileID: 11500000, guid: {SCRIPT_GUID}, type: 3}}",
        f"  m_Name: {name.strip()}",
        "  m_EditorClassIdentifier: ",
        "  profile:",
        f"    scatteringDistance: {{r: {_g(sd[0])}, g: {_g(sd[1])}, b: {_g(sd[2])}, a: 1}}",
        f"    scatteringDistanceMultiplier: {_g(params['scatteringDistanceMultiplier'])}",
        f"    transmissionTint: {{r: {_g(tint[0])}, g: {_g(tint[1])}, b: {_g(tint[2])}, a: 1}}",
        "    texturingMode: 0",
        "    smoothnessMultipliers: {x: 1, y: 1}",
        "    lobeMix: 0.5",
        "    diffuseShadingPower: 1",
        "    transmissionMode: 0",
        f"    thicknessRemap: {{x: {_g(remap[0])}, y: {_g(remap[1])}}}",
        f"    worldScale: {_g(params['worldScale'])}",
        f"    ior: {_g(params['ior'])}",
        "    hash: 0",
        f"  m_Version: {ASSET_VERSION}",
        "",
    ])


def _unity_loader() -> Any:
    import yaml  # PyYAML

    class Loader(yaml.SafeLoader):
        pass

    # Unity's "--- !u!114 &11400000" document tag: read the mapping under it as plain data
    Loader.add_multi_constructor("tag:unity3d.com,2011:", lambda loader, suffix, node: loader.construct_mapping(node, deep=True))
    return Loader


def read_unity_asset(text: str, what: str = "the .asset file") -> dict[str, Any]:
    """Parse a ``DiffusionProfileSettings`` .asset (YAML) and check it against HDRP's field list and script
    GUID; returns {"name", "scatteringDistance" (3,), "scatteringDistanceMultiplier", "worldScale", "ior"}.
    Raises :class:`SsskitError` naming what is wrong (a truncated file, another script, a missing field)."""
    import yaml

    try:
        doc = yaml.load(text, Loader=_unity_loader())
    except yaml.YAMLError as exc:
        raise SsskitError(f"{what} is not valid YAML (truncated?): {str(exc).splitlines()[0]}") from None
    if not isinstance(doc, dict) or "MonoBehaviour" not in doc or not isinstance(doc["MonoBehaviour"], dict):
        raise SsskitError(f"{what} holds no Unity MonoBehaviour (not a DiffusionProfileSettings asset)")
    mb = doc["MonoBehaviour"]
    guid = (mb.get("m_Script") or {}).get("guid") if isinstance(mb.get("m_Script"), dict) else None
    if guid != SCRIPT_GUID:
        raise SsskitError(f"{what} is a MonoBehaviour of script {guid!r}, not HDRP's DiffusionProfileSettings "
                          f"({SCRIPT_GUID})")
    prof = check_keys(mb.get("profile"), f"{what}: the profile block (truncated?)", None,
                      ("scatteringDistance", "scatteringDistanceMultiplier", "worldScale", "ior"))
    sd = prof["scatteringDistance"]
    try:
        colour = [float(sd[k]) for k in ("r", "g", "b")]
        mult, ws, ior = (float(prof[k]) for k in ("scatteringDistanceMultiplier", "worldScale", "ior"))
    except (TypeError, KeyError, ValueError):
        raise SsskitError(f"{what}: scatteringDistance, its multiplier, worldScale and ior must be numbers") from None
    # (their values: ssskit.export.readers, the one reader of engine files, checks them finite, worldScale 1 and d > 0)
    return {"name": str(mb.get("m_Name", "unity")), "scatteringDistance": colour,
            "scatteringDistanceMultiplier": mult, "worldScale": ws, "ior": ior}


__all__ = ["ASSET_VERSION", "MONOBEHAVIOUR_FIELDS", "PROFILE_FIELDS", "SCRIPT_GUID", "read_unity_asset",
           "srgb_decode", "srgb_encode", "unity_asset"]
