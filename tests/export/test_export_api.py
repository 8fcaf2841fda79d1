"""ssskit.export.export(ExportSettings) and the export defects of issue 34, each judged by a real client where one
runs here (MaterialX, Python's ast) or by the source the number comes from (the preset's coefficients, UE's
ClampMin)."""

import importlib.util
import json
import shutil
import sys
import warnings

import numpy as np
import pytest

from ssskit.cli import main
from ssskit.errors import SsskitError
from ssskit.export import ExportSettings, export
from ssskit.materials import get_material

needs_mx = pytest.mark.skipif(importlib.util.find_spec("MaterialX") is None,
                              reason="the materialx package is not installed (pip install 'materialx>=1.39,<1.40')")


@pytest.fixture
def run(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)

    def go(*args):
        code = main([str(a) for a in args])
        out, err = capsys.readouterr()
        return code, out, err

    return go


def _one_error(run, tmp_path, *args):
    before = sorted(p.name for p in tmp_path.iterdir())
    code, out, err = run(*args)
    assert code == 2 and out == "" and err.count("\n") == 1 and err.startswith("ssskit: error: "), err
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written
    return err


def test_the_python_api_writes_what_the_cli_writes(tmp_path, run):
    summary = export(ExportSettings(format="unreal", out=str(tmp_path / "api.json"), material="skin1",
                                    no_transmission=True))
    assert summary["format"] == "unreal" and summary["material"] == "skin1" and summary["notes"] == []
    assert run("export", "--material", "skin1", "--format", "unreal", "--no-transmission",
               "--out", tmp_path / "cli.json")[0] == 0
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("api.json", "cli.json"))
    assert a["mfp"] == b["mfp"]


def test_an_option_that_does_not_apply_is_refused_once_before_any_work(tmp_path):
    with pytest.raises(SsskitError, match=r"^--standard-surface applies to --format materialx, not --format unity$"):
        ExportSettings(format="unity", out=str(tmp_path / "u.json"), material="skin1", standard_surface=True)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("pass_, kw, message", [
    ("burley", {"taps": 7, "kernel": "svd:2"}, "--kernel, --taps apply to --pass separable, not --pass burley (the "
     "shader bakes the material's Burley parameters"),
    ("burley", {"model": "dipole"}, "--model applies to --pass separable or transmission, not --pass burley"),
    ("transmission", {"photons": 10_000}, "--photons applies to --pass separable, not --pass transmission (the "
     "shader bakes the material's transmittance model)"),
    (None, {"transmission_model": "unreal"}, "--transmission-model applies to --pass transmission, not --pass "
     "separable"),
    ("transmission", {"transmission_model": "jimenez2010"}, "--material applies to --transmission-model mcml or "
     "unreal, not --transmission-model jimenez2010 (Jimenez et al. 2010's skin Gaussians: no material)"),
])
def test_an_option_the_shaders_pass_does_not_take_is_refused_when_the_request_is_made(tmp_path, pass_, kw, message):
    """The pass's and the transmittance model's options are declared once (PASS_OPTIONS) and refused by the request
    itself, as the format's are: before the material is read."""
    with pytest.raises(SsskitError) as info:
        ExportSettings(format="glsl-shader", out=str(tmp_path / "s.comp"), material="no such material",
                       shader_pass=pass_, **kw)
    assert message in str(info.value)


@pytest.mark.parametrize("fmt,field", [("unity", ("ior",)), ("unreal", ("mfp", "IOR")), ("blender", ("ior",))])
def test_eta_of_artists_terms_is_the_engines_ior(run, tmp_path, fmt, field):
    """--eta was ignored for Unity and Unreal (IOR 1.4 written whatever was given) while the help said 1.3."""
    def ior(*extra):
        out = tmp_path / f"{fmt}.json"
        code, _, err = run("export", "--albedo", "0.8,0.5,0.3", "--mfp", "1,0.5,0.2", *extra, "--format", fmt,
                           "--out", out)
        assert code == 0, err
        value = json.loads(out.read_text())
        for key in field:
            value = value[key]
        return value

    assert ior("--eta", "1.45") == pytest.approx(1.45)
    assert ior() == pytest.approx(1.3)  # the default the help states


def test_nan_ior_in_an_hdrp_asset_is_refused_naming_the_field(run, tmp_path):
    assert run("export", "--material", "skin1", "--format", "unity", "--no-transmission", "--out",
               tmp_path / "S.asset")[0] == 0
    text = (tmp_path / "S.asset").read_text()
    (tmp_path / "S.asset").write_text("\n".join("    ior: .nan" if ln.startswith("    ior:") else ln
                                                for ln in text.splitlines()) + "\n")
    err = _one_error(run, tmp_path, "export", "--material", "S.asset", "--albedo", "0.5", "--format", "blender",
                     "--out", "b.json")
    assert "ior must lie in [-3.40282e+38, 3.40282e+38], got nan (a finite float32" in err


def test_an_overflowing_length_in_an_engine_file_is_one_line_and_no_warning(run, tmp_path):
    assert run("export", "--material", "skin1", "--format", "unreal", "--no-transmission", "--out",
               tmp_path / "u.json")[0] == 0
    data = json.loads((tmp_path / "u.json").read_text())
    data["mfp"]["MeanFreePathDistance"] = 1e308
    (tmp_path / "u.json").write_text(json.dumps(data))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning (float32 overflow) fails the test
        err = _one_error(run, tmp_path, "export", "--material", "u.json", "--format", "blender", "--out", "b.json")
    assert "mfp.MeanFreePathDistance must lie in [-3.40282e+38, 3.40282e+38], got 1e+308 (a finite float32" in err


def test_an_mtlx_without_materialx_says_how_to_install_it(run, tmp_path, monkeypatch):
    (tmp_path / "x.mtlx").write_text("<?xml version=\"1.0\"?>\n<materialx version=\"1.39\"/>\n")
    monkeypatch.setitem(sys.modules, "MaterialX", None)  # import MaterialX raises ModuleNotFoundError
    for args in (("--material", "x.mtlx", "--format", "blender", "--out", "b.json"),
                 ("--material", "skin1", "--format", "materialx", "--out", "s.mtlx")):
        err = _one_error(run, tmp_path, "export", *args)
        assert 'pip install ".[materialx]"' in err


@pytest.mark.parametrize("fmt", ["blender", "unreal"])
def test_the_editor_scripts_ssskit_writes_are_read_back(run, tmp_path, fmt):
    """`export --material x_blender.py` was refused although it is what ssskit writes; the script's literal is read
    with ast (never run) into the same Burley (A, d) as its JSON."""
    from ssskit.export.readers import read_engine_file

    for suffix in ("py", "json"):
        assert run("export", "--material", "skin1", "--format", fmt, "--no-transmission" if fmt == "unreal" else
                   "--json", "--out", tmp_path / f"s.{suffix}")[0] == 0
    py, js = read_engine_file(tmp_path / "s.py"), read_engine_file(tmp_path / "s.json")
    np.testing.assert_allclose(py.albedo, js.albedo, rtol=1e-6)
    np.testing.assert_allclose(py.d_mm, js.d_mm, rtol=1e-6)
    code, _, err = run("export", "--material", "s.py", "--format", "unity", "--out", "back.json")
    assert code == 0, err


@needs_mx
def test_the_mtlx_is_portable_and_reads_back_from_another_folder(run, tmp_path):
    """The document held ~56 xi:includes of the exporting venv's library files; written now without them, moved
    elsewhere it is read and validated by MaterialX (against its own libraries) and by ssskit."""
    import MaterialX as mx

    assert run("export", "--material", "skin1", "--format", "materialx", "--standard-surface", "--out",
               tmp_path / "s.mtlx")[0] == 0
    text = (tmp_path / "s.mtlx").read_text()
    assert "xi:include" not in text and sys.prefix not in text
    moved = tmp_path / "elsewhere" / "moved.mtlx"
    moved.parent.mkdir()
    shutil.move(tmp_path / "s.mtlx", moved)
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, str(moved))
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    doc.setDataLibrary(lib)
    assert doc.validate() == (True, "")
    assert run("export", "--material", moved, "--format", "blender", "--out", tmp_path / "b.json")[0] == 0


@needs_mx
@pytest.mark.parametrize("name", ["skin1", "marble", "ketchup"])
def test_openpbr_radius_is_the_mean_free_path_of_the_spec(run, tmp_path, name):
    """OpenPBR 1.1, "Subsurface": subsurface_radius x subsurface_radius_scale is the mean free path r and
    mu_t = 1 / r. Read with MaterialX, 1 / r must be the preset's own sigma_a + sigma_s (the paper's table), not
    Burley's searchlight length (0.64-2.56x that before)."""
    import MaterialX as mx

    assert run("export", "--material", name, "--format", "materialx", "--out", tmp_path / "m.mtlx")[0] == 0
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, str(tmp_path / "m.mtlx"))
    node = next(n for n in doc.getNodes() if n.getCategory() == "open_pbr_surface")
    assert node.getInput("subsurface_radius").getUnit() == "millimeter"
    r = node.getInputValue("subsurface_radius") * np.array(list(node.getInputValue("subsurface_radius_scale")))
    mat = get_material(name)
    np.testing.assert_allclose(1.0 / r, np.asarray(mat.sigma_a) + np.asarray(mat.sigma_s), rtol=1e-5)
    assert node.getInputValue("specular_ior") == pytest.approx(mat.eta)


def test_unreal_mean_free_path_distance_respects_its_clampmin(run, tmp_path):
    """SubsurfaceProfile.h: MeanFreePathDistance has ClampMin 0.1 (cm); Marble's 0.070 cm was written as is. Folded
    into the colour (as UE's own upgrade does), the engine reads the same d, and the clamp is reported."""
    from ssskit.export import fit_burley, reimport
    from ssskit.profiles import profile_for_material

    assert run("export", "--material", "marble", "--format", "unreal", "--no-transmission", "--out",
               tmp_path / "m.json")[0] == 0
    data = json.loads((tmp_path / "m.json").read_text())
    for form in ("mfp", "dmfp"):
        assert data[form]["MeanFreePathDistance"] >= 0.1
    assert any("ClampMin" in c and c.startswith("MFP MeanFreePathDistance 0.07") for c in data["clamps"])
    _, d = fit_burley(profile_for_material("marble", "montecarlo"))
    back = reimport(data, "burley")
    np.testing.assert_allclose([ch.d for ch in back.channels], d, rtol=1e-5)


ENGINE_FILES = [("blender", "b.py"), ("unreal", "u.py"), ("blender", "b.json"), ("unreal", "u.json"),
                ("unity", "s.json"), pytest.param("materialx", "m.mtlx", marks=needs_mx)]


@pytest.mark.parametrize("fmt,name", ENGINE_FILES)
def test_every_engine_file_is_a_material_of_every_command(run, tmp_path, fmt, name):
    """render and profile said "must end in .toml or .json"; now every command reads an engine file ssskit wrote
    through get_material (the one entry point), as the physical material of the Monte Carlo inversion."""
    extra = ("--no-transmission",) if fmt in ("unreal", "unity") else ()
    assert run("export", "--material", "skin1", "--format", fmt, *extra, "--out", name)[0] == 0
    for args in (("profile", "--model", "dipole", "--json"), ("kernel", "--model", "dipole", "--method", "svd:2"),
                 ("evaluate", "--model", "dipole", "--methods", "svd:1", "--json")):
        code, _, err = run(*args, "--material", name)
        assert code == 0, (args, err)
    if name == "b.py":  # one render (the others share its material option and RenderSettings' loader)
        code, out, err = run("render", "--scene", "slab", "--material", name, "--model", "dipole", "--size", "32x24",
                             "--spp", "1", "--backend", "numpy", "--no-exact", "--no-perceptual", "--json")
        assert code == 0, err
        assert json.loads(out)["material"] == "Skin1"  # the name the script carries


def test_an_hdrp_asset_alone_is_no_material(run, tmp_path):
    assert run("export", "--material", "skin1", "--format", "unity", "--no-transmission", "--out", "S.asset")[0] == 0
    err = _one_error(run, tmp_path, "profile", "--material", "S.asset", "--model", "dipole")
    assert "holds no albedo" in err
