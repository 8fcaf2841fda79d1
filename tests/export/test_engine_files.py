"""The importable engine files, each parsed by a real parser: the Unity HDRP .asset by a YAML parser against
the field list of HDRP's DiffusionProfileSettings.cs, the Unreal editor script by Python's ast against
FSubsurfaceProfileStruct (SubsurfaceProfile.h), the MaterialX document by MaterialX's own validate() (and its
GLSL by glslangValidator). None of them was loaded in the engine itself."""

import ast
import importlib.util
import shutil
import subprocess

import numpy as np
import pytest
import yaml

from ssskit.errors import SsskitError
from ssskit.export import engine_parameters, fit_burley
from ssskit.export.unity import read_unity_asset, srgb_decode, srgb_encode, unity_asset
from ssskit.export.unreal import unreal_script
from ssskit.materials import get_material
from ssskit.profiles import profile_for_material

# Written out from HDRP's source (Unity-Technologies/Graphics, DiffusionProfileSettings.cs, class
# DiffusionProfile's serialised fields in declaration order; the script GUID from the m_Script of HDRP's own
# defaultDiffusionProfile.asset; m_Version 2 = Version.SplitScatteringDistance in the .Migration.cs)
HDRP_PROFILE_FIELDS = ["scatteringDistance", "scatteringDistanceMultiplier", "transmissionTint", "texturingMode",
                       "smoothnessMultipliers", "lobeMix", "diffuseShadingPower", "transmissionMode", "thicknessRemap",
                       "worldScale", "ior", "hash"]
HDRP_SCRIPT_GUID = "b2686e09ec7aef44bad2843e4416f057"
# Written out from UE 5's Engine/Classes/Engine/SubsurfaceProfile.h, struct FSubsurfaceProfileStruct (DistanceScale:
# UE 5.8's)
UE_SETTINGS_FIELDS = ["SurfaceAlbedo", "MeanFreePathColor", "MeanFreePathDistance", "WorldUnitScale", "bEnableBurley",
                      "bEnableMeanFreePath", "Tint", "ScatterRadius", "SubsurfaceColor", "FalloffColor",
                      "BoundaryColorBleed", "Implementation", "ExtinctionScale", "NormalScale", "DistanceScale",
                      "ScatteringDistribution", "IOR", "Roughness0", "Roughness1", "LobeMix", "TransmissionTintColor"]


needs_mx = pytest.mark.skipif(importlib.util.find_spec("MaterialX") is None,
                              reason="the materialx package is not installed (pip install 'materialx>=1.39,<1.40')")


@pytest.fixture(scope="module")
def skin1():
    m = get_material("skin1")
    return m, profile_for_material(m, "dipole")


class _Unity(yaml.SafeLoader):
    pass


_Unity.add_multi_constructor("tag:unity3d.com,2011:", lambda l, s, n: l.construct_mapping(n, deep=True))


def test_unity_asset_has_hdrp_fields(skin1, tmp_path):
    m, prof = skin1
    p = engine_parameters(prof, "unity", m)
    text = unity_asset(p, "Skin1")
    assert text.startswith("%YAML 1.1\n%TAG !u! tag:unity3d.com,2011:\n--- !u!114 &11400000\n")
    doc = yaml.load(text, Loader=_Unity)
    mb = doc["MonoBehaviour"]
    assert mb["m_Script"] == {"fileID": 11500000, "guid": HDRP_SCRIPT_GUID, "type": 3}
    assert mb["m_Version"] == 2 and mb["m_Name"] == "Skin1"
    assert list(mb["profile"]) == HDRP_PROFILE_FIELDS
    sd = mb["profile"]["scatteringDistance"]
    d = np.array([sd["r"], sd["g"], sd["b"]]) * mb["profile"]["scatteringDistanceMultiplier"]
    np.testing.assert_allclose(d, fit_burley(prof)[1], rtol=1e-7)
    assert mb["profile"]["ior"] == pytest.approx(m.eta)
    back = read_unity_asset(text)
    np.testing.assert_allclose(np.array(back["scatteringDistance"]) * back["scatteringDistanceMultiplier"], d)


def test_unity_inspector_colours():
    # IEC 61966-2-1: linear 0.5 shows as 0.7354; linear 0.0031308 is the knee (0.04045 encoded)
    assert float(srgb_encode(0.5)) == pytest.approx(0.735357, abs=1e-6)
    assert float(srgb_encode(0.0031308)) == pytest.approx(0.04045, abs=1e-6)
    x = np.linspace(0, 1, 11)
    np.testing.assert_allclose(srgb_decode(srgb_encode(x)), x, atol=1e-12)


def test_unity_parameters_give_both_colours(skin1):
    m, prof = skin1
    p = engine_parameters(prof, "unity", m)
    np.testing.assert_allclose(p["scatteringDistance_inspector_srgb"], srgb_encode(p["scatteringDistance"]))


@pytest.mark.parametrize("cut", [60, 200, 400, -40])
def test_truncated_unity_asset_is_refused(skin1, cut):
    m, prof = skin1
    text = unity_asset(engine_parameters(prof, "unity", m), "Skin1")
    with pytest.raises(SsskitError):
        read_unity_asset(text[:cut])


def _calls(tree):
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            yield (ast.unparse(f), node)


@pytest.mark.parametrize("form", ["mfp", "dmfp"])
def test_unreal_script_parses_and_sets_struct_fields(skin1, form):
    m, prof = skin1
    p = engine_parameters(prof, "unreal", m)
    tree = ast.parse(unreal_script(p, "SP_Skin1", form))
    calls = list(_calls(tree))
    names = [c for c, _ in calls]
    assert "unreal.AssetToolsHelpers.get_asset_tools" in names
    create = next(n for c, n in calls if c.endswith(".create_asset"))
    assert ast.unparse(create.args[2]) == "unreal.SubsurfaceProfile"
    assert "unreal.EditorAssetLibrary.save_loaded_asset" in names
    set_props = [n.args[0].value for c, n in calls  # (the transmission fields go through a loop: tested below)
                 if c == "settings.set_editor_property" and isinstance(n.args[0], ast.Constant)]
    # UE Python names a UPROPERTY in snake_case, dropping a bool's 'b' prefix
    ue_python = {}
    for f in UE_SETTINGS_FIELDS:
        base = f[1:] if f.startswith("b") and f[1].isupper() else f
        snake = "".join("_" + ch.lower() if ch.isupper() and i and not base[i - 1].isupper() else ch.lower()
                        for i, ch in enumerate(base))
        ue_python[snake] = f
    assert set(set_props) <= set(ue_python), set(set_props) - set(ue_python)
    assert "enable_mean_free_path" in set_props and "enable_burley" in set_props
    settings = next(ast.literal_eval(n.value) for n in ast.walk(tree)
                    if isinstance(n, ast.Assign) and getattr(n.targets[0], "id", "") == "SETTINGS")
    assert set(settings) <= set(UE_SETTINGS_FIELDS)
    assert settings["bEnableMeanFreePath"] is (form == "mfp")
    for k, v in settings.items():
        assert v == p[form][k]


def _ue_python_name(field):
    base = field[1:] if field.startswith("b") and field[1].isupper() else field
    return "".join("_" + ch.lower() if ch.isupper() and i and not base[i - 1].isupper() else ch.lower()
                   for i, ch in enumerate(base))


def test_unreal_script_and_asset_carry_the_transmission_fit(skin1):
    """With the material's MCML table the editor script sets UE's transmission fields (names from
    FSubsurfaceProfileStruct, UE Python's snake_case), the details-panel text carries them, and the HDRP .asset
    writes transmissionTint, transmissionMode 0 (Thick Object) and thicknessRemap as the YAML parser reads them."""
    from ssskit.export.unity import _unity_loader
    from ssskit.profiles.montecarlo.transmission import transmission_table

    m, prof = skin1
    table = transmission_table(m)
    p = engine_parameters(prof, "unreal", m, table)
    tree = ast.parse(unreal_script(p, "SP_Skin1"))
    consts = {n.targets[0].id: ast.literal_eval(n.value) for n in ast.walk(tree)
              if isinstance(n, ast.Assign) and getattr(n.targets[0], "id", "") in ("TRANSMISSION", "PROPERTY")}
    tr = consts["TRANSMISSION"]
    assert set(tr) == {"ExtinctionScale", "NormalScale", "ScatteringDistribution", "TransmissionTintColor",
                       "DistanceScale"} and set(tr) <= set(UE_SETTINGS_FIELDS)
    assert all(consts["PROPERTY"][k] == _ue_python_name(k) for k in tr)
    assert all(tr[k] == p["transmission"][k] for k in tr)
    assert f"ExtinctionScale={tr['ExtinctionScale']:.6f}" in p["details_panel"]["mfp"]
    u = engine_parameters(prof, "unity", m, table)
    doc = yaml.load(unity_asset(u, "Skin1"), Loader=_unity_loader())["MonoBehaviour"]["profile"]
    assert set(doc) == set(HDRP_PROFILE_FIELDS)
    np.testing.assert_allclose([doc["transmissionTint"][k] for k in "rgb"], u["transmission"]["transmissionTint"],
                               rtol=1e-8)
    assert doc["transmissionMode"] == 0
    assert [doc["thicknessRemap"]["x"], doc["thicknessRemap"]["y"]] == u["transmission"]["thicknessRemap"]


@needs_mx
def test_materialx_document_validates(skin1, tmp_path):
    import MaterialX as mx

    from ssskit.export.materialx import materialx_document, read_materialx

    m, prof = skin1
    a, _ = fit_burley(prof)
    mfp = 1.0 / np.asarray(m.sigma_t)
    text = materialx_document(a, mfp, "Skin1", standard_surface=True)
    doc = mx.createDocument()
    mx.readFromXmlString(doc, text)
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    doc.importLibrary(lib)
    assert doc.validate() == (True, "")
    cats = sorted(n.getCategory() for n in doc.getNodes())
    assert cats == ["open_pbr_surface", "standard_surface", "surfacematerial", "surfacematerial"]
    opbr = next(n for n in doc.getNodes() if n.getCategory() == "open_pbr_surface")
    np.testing.assert_allclose(list(opbr.getInputValue("subsurface_color")), a, rtol=1e-5)  # float32 text
    assert opbr.getInput("subsurface_radius").getUnit() == "millimeter"
    path = tmp_path / "s.mtlx"
    path.write_text(text)
    back = read_materialx(path)
    np.testing.assert_allclose(back["mfp_mm"], mfp, rtol=1e-5)
    np.testing.assert_allclose(back["albedo"], a, rtol=1e-5)


@needs_mx
@pytest.mark.parametrize("cut", [100, 600, -30])
def test_truncated_mtlx_is_refused(skin1, tmp_path, cut):
    from ssskit.export.materialx import materialx_document, read_materialx

    a, _ = fit_burley(skin1[1])
    d = 1.0 / np.asarray(skin1[0].sigma_t)
    path = tmp_path / "t.mtlx"
    path.write_text(materialx_document(a, d, "Skin1")[:cut])
    with pytest.raises(SsskitError):
        read_materialx(path)


@pytest.mark.skipif(shutil.which("glslangValidator") is None, reason="glslangValidator is not installed")
@needs_mx
def test_materialx_glsl_compiles(skin1, tmp_path):
    from ssskit.export.materialx import glsl_source, materialx_document

    a, d = fit_burley(skin1[1])
    src = glsl_source(materialx_document(a, d, "Skin1"))
    assert "subsurface" in src["pixel"]
    for stage, ext in (("pixel", "frag"), ("vertex", "vert")):
        f = tmp_path / f"s.{ext}"
        f.write_text(src[stage])
        r = subprocess.run(["glslangValidator", str(f)], capture_output=True, text=True)
        assert r.returncode == 0, r.stdout[-2000:]
