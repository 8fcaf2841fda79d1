"""``ssskit export``: files engines load, written atomically; every bad input one line and exit 2."""

import json

import numpy as np
import pytest

from ssskit.export import load_bn, parse_shader_arrays, reimport

from ..export.demo_tables import TABLES
from . import test_bad_input as bad

workdir = bad.workdir  # the fixture: an empty current folder with a few files in it


def test_jimenez2012_hlsl(run, tmp_path):
    out = tmp_path / "SeparableSSS_kernel.hlsl"
    code, stdout, err = run("export", "--kernel", "jimenez2012", "--taps", "11", "--format", "hlsl", "--out", out,
                            "--json")
    assert code == 0, err
    assert json.loads(stdout) == {"format": "hlsl", "out": str(out), "material": None, "model": None,
                                  "kernel": "jimenez2012", "rank": 1, "taps": 11}
    (arr,) = parse_shader_arrays(out.read_text())
    np.testing.assert_allclose(arr.weights[0], TABLES[11][0][:3], atol=5e-7)
    assert arr.offsets_mm.tolist() == pytest.approx([t[3] for t in TABLES[11]])


def test_spec_and_taps_agree(run, tmp_path):
    out = tmp_path / "k.glsl"
    code, _, err = run("export", "--kernel", "jimenez2012:25", "--taps", "25", "--format", "glsl", "--out", out)
    assert code == 0, err
    assert len(parse_shader_arrays(out.read_text())[0].offsets_mm) == 25


def test_tabulated_kernel_glsl_and_bn(run, tmp_path):
    glsl, bn = tmp_path / "k.glsl", tmp_path / "k.bn"
    code, _, err = run("export", "--material", "skin1", "--kernel", "preintegrated", "--taps", "9",
                       "--tap-method", "uniform", "--format", "glsl", "--out", glsl)
    assert code == 0, err
    (arr,) = parse_shader_arrays(glsl.read_text())
    assert arr.offsets_mm.size == 9 and "uniform taps" in glsl.read_text()
    code, _, err = run("export", "--material", "skin1", "--kernel", "preintegrated", "--format", "bn", "--out", bn)
    assert code == 0, err
    k = load_bn(bn)
    # the 201-cell grid cropped to 99.9 % of each channel's mass (the loaders tap the file's whole extent)
    assert k.rank == 1 and k.n % 2 == 1 and 3 <= k.n < 201


@pytest.mark.parametrize("engine", ["unreal", "unity", "blender"])
def test_engine_parameters(run, tmp_path, engine):
    out = tmp_path / f"{engine}.json"
    code, stdout, err = run("export", "--material", "marble", "--model", "burley", "--format", engine, "--out", out)
    assert code == 0, err
    assert stdout.startswith("# wrote")
    params = json.loads(out.read_text())
    assert params["engine"] == engine and params["source_profile"] == {"model": "burley", "name": "Marble"}
    back = reimport(params, "burley")
    assert back.model == "burley"


BAD = [
    (["export", "--format", "hlsl", "--out", "k.hlsl"], "--format hlsl needs --kernel"),
    (["export", "--format", "unity", "--out", "u.json", "--material", "skin1", "--kernel", "svd"],
     "--kernel applies to --format hlsl or glsl or bn or json or glsl-shader or hlsl-shader, not --format unity"),
    (["export", "--format", "unity", "--out", "u.json"], "--format unity needs --material (or artists' terms"),
    (["export", "--format", "unreal", "--out", "u.json", "--material", "skin1", "--taps", "7"],
     "--taps applies to --format hlsl or glsl or bn or json or glsl-shader or hlsl-shader, not --format unreal"),
    (["export", "--format", "bn", "--out", "k.bn", "--kernel", "jimenez2012"], "is a list of taps"),
    (["export", "--format", "bn", "--out", "k.bn", "--kernel", "svd:2", "--material", "skin1"], "has rank 2"),
    (["export", "--format", "hlsl", "--out", "k.glsl", "--kernel", "jimenez2012"], "must end in"),
    (["export", "--format", "bn", "--out", "k.json", "--kernel", "preintegrated", "--material", "skin1"],
     "must end in .bn"),
    (["export", "--format", "json", "--out", "k.json", "--kernel", "preintegrated", "--material", "skin1",
      "--taps", "9"], "--taps does not apply to --format json"),
    (["export", "--format", "hlsl", "--out", "k.hlsl", "--kernel", "jimenez2012:17", "--taps", "11"], "disagree"),
    (["export", "--format", "hlsl", "--out", "k.hlsl", "--kernel", "jimenez2012", "--taps", "10"], "taps must be an odd integer, got 10"),
    # the header named 'jimenez2012 kernel of Skin1 (montecarlo)' though the taps ignore the material
    (["export", "--material", "skin1", "--kernel", "jimenez2012", "--taps", "9", "--format", "glsl", "--out", "k.glsl"],
     "--material applies to --kernel svd or svd_l1 or gaussians or preintegrated or preintegrated_svd or artist or guided or burley_fit, not --kernel jimenez2012"),
    (["export", "--format", "hlsl", "--out", "k.hlsl", "--kernel", "jimenez2012:10"], "odd"),
    (["export", "--format", "hlsl", "--out", "k.hlsl", "--kernel", "preintegrated"], "--kernel preintegrated needs --material"),
    (["export", "--format", "hlsl", "--out", "k.hlsl", "--kernel", "jimenez2012", "--tap-method", "uniform"],
     "ships its own taps"),
    (["export", "--format", "bn", "--out", "k.bn", "--kernel", "preintegrated", "--material", "skin1",
      "--tap-method", "uniform"], "--tap-method applies to --format hlsl or glsl or glsl-shader or hlsl-shader, not --format bn"),
    (["export", "--format", "hlsl", "--out", "k.hlsl", "--kernel", "jimenez2012", "--model", "burley"],
     "--model applies to --kernel svd or svd_l1 or gaussians or preintegrated or preintegrated_svd or artist or guided or burley_fit, not --kernel jimenez2012"),
    (["export", "--format", "hlsl", "--out", "f.txt/k.hlsl", "--kernel", "jimenez2012"], "'f.txt' is not a folder"),
    (["export", "--format", "unity", "--out", "m.json", "--material", "m.json"], "would overwrite the input"),
    (["export", "--format", "unity", "--out", "u.json", "--material", "nosuch"], "nosuch"),
    (["export", "--format", "metal", "--out", "k.hlsl", "--kernel", "jimenez2012"], "--format"),
    (["export", "--format", "unity", "--out", "u.json", "--material", "skin1", "--model", "dipole",
      "--photons", "5000"], "--photons does not apply to --model dipole"),
    (["export", "--format", "hlsl", "--out", "k.hlsl", "--kernel", "nosuch"], "nosuch"),
    (["export", "--format", "hlsl", "--out", "k.hlsl", "--kernel", "jimenez2012", "--jitter", "0.2"],
     "--jitter applies to --format glsl-shader or hlsl-shader, not --format hlsl"),
    (["export", "--format", "bn", "--out", "k.bn", "--kernel", "preintegrated", "--material", "skin1",
      "--depth-mode", "none"], "--depth-mode applies to --format glsl-shader or hlsl-shader, not --format bn"),
    (["export", "--format", "glsl-shader", "--out", "k.comp", "--kernel", "jimenez2012", "--jitter", "1.5"],
     "--jitter"),
    (["export", "--format", "glsl-shader", "--out", "k.hlsl", "--kernel", "jimenez2012"], "must end in"),
    (["export", "--format", "glsl-shader", "--pass", "transmission", "--material", "skin1", "--kernel",
      "jimenez2012", "--out", "t.comp"], "--kernel applies to --pass separable, not --pass transmission (the shader bakes"),
    (["export", "--format", "glsl-shader", "--pass", "transmission", "--out", "t.comp"],
     "--transmission-model mcml needs --material"),
    (["export", "--format", "glsl-shader", "--pass", "transmission", "--transmission-model", "jimenez2010",
      "--material", "skin1", "--out", "t.comp"], "--material applies to --transmission-model mcml or unreal, not --transmission-model jimenez2010 (Jimenez et al. 2010"),
    (["export", "--format", "glsl-shader", "--pass", "transmission", "--transmission-model", "unreal",
      "--albedo", "0.5", "--mfp", "1", "--out", "t.comp"], "needs one homogeneous medium, not Burley parameters without coefficients"),
    # artists' terms under the Burley-fit inversion (their default) simulate nothing: --photons was silently ignored
    (["export", "--format", "unreal", "--albedo", "0.5", "--mfp", "1", "--photons", "10000", "--out", "x.json"],
     "--photons does not apply to --model burley (the Burley fit simulates nothing)"),
    (["export", "--format", "unity", "--albedo", "0.5", "--dmfp", "1", "--grid-fraction", "0.5", "--out", "x.json"],
     "--grid-fraction does not apply to --model burley"),
    (["export", "--format", "glsl-shader", "--pass", "transmission", "--material", "skin1", "--model", "dipole",
      "--out", "t.comp"], "--model dipole applies to --pass separable, not --pass transmission, which takes --model montecarlo only"),
    (["export", "--format", "glsl-shader", "--pass", "transmission", "--transmission-model", "jimenez2010",
      "--model", "burley", "--out", "t.comp"], "--model burley applies to --pass separable, not --pass transmission, which takes --model montecarlo only"),
    (["export", "--format", "glsl-shader", "--pass", "transmission", "--albedo", "0.8,0.5,0.3", "--mfp",
      "1,0.5,0.2", "--model", "dipole", "--out", "t.comp"], "--model dipole applies to --pass separable, not --pass transmission, which takes --model montecarlo only"),
    (["export", "--format", "unity", "--pass", "transmission", "--material", "skin1", "--out", "u.json"],
     "--pass applies to --format glsl-shader or hlsl-shader, not --format unity"),
    (["export", "--format", "glsl-shader", "--transmission-model", "unreal", "--kernel", "jimenez2012",
      "--out", "k.comp"], "--transmission-model applies to --pass transmission"),
    (["export", "--format", "glsl-shader", "--pass", "transmission", "--material", "skin1", "--out", "t.hlsl"],
     "must end in"),
    (["export", "--format", "glsl-shader", "--pass", "bogus", "--material", "skin1", "--out", "t.comp"],
     "Invalid value for '--pass'"),
]


def test_whole_shader_export(run, tmp_path):
    """``--format glsl-shader``: the gl backend's shader with the taps baked in (one file, each pass
    compiled with VERTICAL / TERM); the same taps as ``--format glsl`` exports as arrays."""
    out = tmp_path / "sss.comp"
    code, stdout, err = run("export", "--kernel", "jimenez2012", "--taps", "11", "--format", "glsl-shader",
                            "--out", out, "--jitter", "0.2", "--depth-mode", "follow", "--json")
    assert code == 0, err
    summary = json.loads(stdout)
    assert summary["taps"] == 11 and summary["jitter"] == 0.2 and summary["depth_mode"] == "follow"
    text = out.read_text()
    assert "#version 430" in text and "#ifndef VERTICAL" in text and "#define DEPTH_MODE 1  // follow" in text
    assert "ROW_PLUS[10]" in text  # 11 taps: 5 mirror pairs per slot (slot 0, no SSS, and the one id)


def test_transmission_shader_export(run, tmp_path):
    """``--pass transmission``: the transmittance shader with the material's model baked in (the gl backend's
    source for that plan), jimenez2010 without a material."""
    from ssskit.backends.gl.transmission import transmission_export_source
    from ssskit.materials import get_material
    from ssskit.screenspace.transmission import mcml_model, transmission_plan

    out = tmp_path / "t.comp"
    code, stdout, err = run("export", "--material", "skin1", "--format", "glsl-shader", "--pass", "transmission",
                            "--out", out, "--json")
    assert code == 0, err
    assert json.loads(stdout)["transmission_model"] == "mcml" and json.loads(stdout)["material"] == "Skin1"
    text = out.read_text()
    assert text.split("\n", 1)[1] == transmission_export_source(transmission_plan({1: mcml_model(get_material("skin1"))}))
    code, _, err = run("export", "--format", "glsl-shader", "--pass", "transmission", "--transmission-model",
                       "jimenez2010", "--out", tmp_path / "j.comp")
    assert code == 0 and "COEF_C" in (tmp_path / "j.comp").read_text(), err


@pytest.mark.parametrize("args, fragment", BAD, ids=[" ".join(a[1:]) for a, _ in BAD])
def test_bad_input(run, workdir, args, fragment):
    bad.one_error_line(run, workdir, args, fragment)
