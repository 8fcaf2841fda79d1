"""``ssskit export --format babylon``: the ES module or JSON of ssskit.export.babylon, one scene's materials,
and bad input (one line, exit status 2, nothing written). The renders that judge the numbers are in
tests/export/test_babylon_client.py (Babylon.js itself)."""

import json
import shutil
import subprocess

import numpy as np
import pytest

from ssskit.export import fit_burley
from ssskit.export.babylon import MAX_PROFILES, babylon_parameters, filter_radius
from ssskit.materials import get_material
from ssskit.profiles import profile_for_material

from .test_bad_input import one_error_line, workdir  # noqa: F401  (the fixture)


def _ok(run, *args):
    code, out, err = run(*args)
    assert code == 0, err
    return out


def test_json_holds_the_profile_the_pass_weights_with(run, tmp_path):
    """The colour is 1/d (Babylon weights with exp(-r S / 3), S = colour): with the scene's metersPerUnit
    ('plain') and scaled by k with metersPerUnit x k ('widest'), both give the weights d in true mm."""
    out = tmp_path / "s.json"
    _ok(run, "export", "--material", "skin1,ketchup", "--format", "babylon", "--model", "dipole", "--out", out)
    data = json.loads(out.read_text())
    for name in ("skin1", "ketchup"):
        a, d = fit_burley(profile_for_material(get_material(name), "dipole"))
        m = data["materials"][name]
        np.testing.assert_allclose(m["albedoColor"], a, rtol=1e-12)
        np.testing.assert_allclose(m["translucency"]["diffusionDistance"], d, rtol=1e-12)  # scene in mm
        for v in data["variants"].values():
            k = v["metersPerUnit"] / data["unit_m"] / v["pixel_size_fix"]
            # the pass's "mm" are k true mm: weights exp(-(k r) colour / 3) = exp(-r / (3 d))
            np.testing.assert_allclose(1.0 / (k * np.array(v["diffusionProfile"][name])), d, rtol=1e-12)
    w = data["variants"]["widest"]
    dmax = max(max(m["d_mm"]) for m in data["materials"].values())
    # the widest variant samples the material holding the scene's narrowest d with the widest d, the others closer
    assert max(w["sampling_distance_mm"].values()) == pytest.approx(dmax, rel=1e-12)
    assert all(s <= dmax * (1 + 1e-12) for s in w["sampling_distance_mm"].values())


def test_filter_radius_is_babylons_closed_form():
    """getDiffusionProfileParameters: Burley's CDF 1 - e^{-x}/4 - 3 e^{-x/3}/4 at the radius is 0.997."""
    x = filter_radius(1.0)
    assert 1 - np.exp(-x) / 4 - 3 * np.exp(-x / 3) / 4 == pytest.approx(0.997, abs=1e-12)


#: stand-ins for what applySsskit touches of Babylon's API (Color3, PBRMaterial, the scene's subsurface
#: configuration with its default white profile), for node
STAND_INS = (
    "class Color3 { constructor(r, g, b) { Object.assign(this, {r, g, b}); } }\n"
    "const cfg = { metersPerUnit: 1, ssDiffusionProfileColors: [new Color3(1, 1, 1)] };\n"
    "class PBRMaterial { constructor(n) { this.name = n; this.subSurface = {\n"
    "  set scatteringDiffusionProfile(c) { cfg.ssDiffusionProfileColors.push(c); this._c = c; },\n"
    "  get scatteringDiffusionProfile() { return this._c; } }; } }\n"
    "const scene = { subSurfaceConfiguration: cfg, enableSubSurfaceForPrePass() { return true; } };\n"
)


def _node(folder, imports: str, body: str) -> dict:
    """Run ``imports`` + the stand-ins + ``body`` as an ES module in ``folder`` under node: the JSON it prints last."""
    probe = folder / "probe.mjs"
    probe.write_text(imports + STAND_INS + body)
    res = subprocess.run(["node", str(probe)], capture_output=True, text=True, timeout=60, cwd=folder)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
def test_module_imports_and_applies(run, tmp_path):
    """node imports the ES module and applySsskit sets what Babylon's API takes on stand-in objects."""
    out = tmp_path / "s.mjs"
    _ok(run, "export", "--material", "marble", "--format", "babylon", "--model", "dipole", "--out", out)
    got = _node(tmp_path, "import { SSSKIT, applySsskit } from './s.mjs';\n",
                "const m = Object.values(applySsskit({ Color3, PBRMaterial }, scene, {}, 'plain'))[0];\n"
                "console.log(JSON.stringify({ mpu: cfg.metersPerUnit, color: m.subSurface.scatteringDiffusionProfile,\n"
                "  on: m.subSurface.isScatteringEnabled, albedo: m.albedoColor, f0: m.metallicF0Factor }));\n")
    a, d = fit_burley(profile_for_material(get_material("marble"), "dipole"))
    assert got["mpu"] == pytest.approx(2e-3) and got["on"] is True and got["f0"] == 0
    np.testing.assert_allclose([got["color"][c] for c in "rgb"], 1.0 / d, rtol=1e-12)
    np.testing.assert_allclose([got["albedo"][c] for c in "rgb"], a, rtol=1e-12)


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
def test_a_second_export_into_one_scene_and_a_key_of_no_material_are_errors(run, tmp_path):
    """A new user's trial: two files exported apart set the scene-wide metersPerUnit in turn (Skin1 rendered 1.66x
    off after Marble's), and ``{ skin1: myMaterial }`` (the comment's key in lower case) was ignored silently, the
    user's material left without subsurface scattering. Both now throw, naming what to do; the file's comment
    names its own keys; one file applied twice to a scene is fine."""
    for name in ("skin1", "marble"):
        _ok(run, "export", "--material", name, "--format", "babylon", "--out", tmp_path / f"{name}.mjs")
    assert '{ "Skin1": myMaterial }' in (tmp_path / "skin1.mjs").read_text()
    got = _node(tmp_path, "import * as skin from './skin1.mjs';\nimport * as marble from './marble.mjs';\n",
                "const B = { Color3, PBRMaterial }, out = {};\n"
                "try { skin.applySsskit(B, scene, { skin1: new PBRMaterial('mine') }); } catch (e) { out.key = e.message; }\n"
                "skin.applySsskit(B, scene); skin.applySsskit(B, scene);\n"
                "try { marble.applySsskit(B, scene); } catch (e) { out.second = e.message; }\n"
                "console.log(JSON.stringify(out));\n")
    assert "no material skin1 in this file (its names: Skin1)" in got["key"]
    assert "set by another ssskit export" in got["second"] and "--material a,b" in got["second"]


BAD = [
    (["--material", "skin1,skin2,marble,ketchup,apple"], "a Babylon.js scene holds 5 diffusion profiles"),
    (["--material", "skin1,skin1"], "given twice"),
    (["--albedo", "nan,0.5,0.5", "--dmfp", "1"], "got (nan, 0.5, 0.5)"),
    (["--albedo", "0.5", "--dmfp", "1,inf,1"], "got (1, inf, 1)"),
    (["--material", "skin1,marble", "--albedo", "0.5"], "albedo"),
    (["--albedo", "0.5", "--dmfp", "1", "--eta", "nan"], "eta"),
    (["--material", "skin1", "--kernel", "svd:1"], "not --format babylon"),
    (["--material", "skin1,marble", "--kernel", "svd:1"], "not --format babylon"),
]


@pytest.mark.parametrize("args,fragment", BAD)
def test_bad_input_is_one_line(run, workdir, args, fragment):  # noqa: F811 (the fixture)
    one_error_line(run, workdir, ["export", "--format", "babylon", "--out", "s.js", *args], fragment)


@pytest.mark.parametrize("out", ["s.ts", "s.txt", "s"])
def test_wrong_suffix_is_one_line(run, workdir, out):  # noqa: F811
    one_error_line(run, workdir, ["export", "--format", "babylon", "--material", "skin1", "--out", out], "must end in")


def test_several_materials_only_for_babylon(run, workdir):  # noqa: F811
    one_error_line(run, workdir, ["export", "--format", "unity", "--material", "skin1,marble", "--out", "s.json"],
                   "applies to --format babylon, not --format unity")


def test_parameters_check_the_profile_count_and_values():
    a, d = np.full(3, 0.5), np.ones(3)
    with pytest.raises(Exception, match=r"the number of materials must lie in \[1, 4\], got 5"):
        babylon_parameters([(f"m{i}", a, d) for i in range(MAX_PROFILES)])
    with pytest.raises(Exception, match=r"m: Burley's d must lie in \(0, inf\) mm, got \(1, nan, 1\)"):
        babylon_parameters([("m", a, np.array([1.0, np.nan, 1.0]))])


def test_scene_export_honours_photons_and_grid_fraction(run, tmp_path):
    """--material a,b (one scene) reads each material as the one-material export reads it, --photons and
    --grid-fraction included: the scene's Marble equals the one-material export's at the same options, and the
    99.9 % grid gives the larger, complete red albedo (the supplement's 32-MFP grid drops Marble's red overflow),
    so neither option is dropped on the way."""
    mc = ["--model", "montecarlo", "--photons", "20000", "--format", "babylon"]
    _ok(run, "export", "--material", "marble,ketchup", *mc, "--grid-fraction", "0.999", "--out", tmp_path / "s.json")
    _ok(run, "export", "--material", "marble", *mc, "--grid-fraction", "0.999", "--out", tmp_path / "one.json")
    _ok(run, "export", "--material", "marble,ketchup", *mc, "--out", tmp_path / "narrow.json")
    (one,) = json.loads((tmp_path / "one.json").read_text())["materials"].values()  # named as the asset
    scene, narrow = (json.loads((tmp_path / f).read_text())["materials"]["marble"] for f in ("s.json", "narrow.json"))
    np.testing.assert_allclose(scene["albedoColor"], one["albedoColor"], rtol=1e-12)
    np.testing.assert_allclose(scene["d_mm"], one["d_mm"], rtol=1e-12)
    assert scene["albedoColor"][0] > narrow["albedoColor"][0] * 1.01
    a_default, _ = fit_burley(profile_for_material(get_material("marble"), "montecarlo"))  # 10^7 photons, shipped
    assert not np.allclose(narrow["albedoColor"], a_default, rtol=1e-6)  # 2*10^4 photons: another estimate
