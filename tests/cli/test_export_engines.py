"""``ssskit export`` to each engine's own file and back: engine files as --material, artists' terms, the
round trip engine parameters -> material -> Monte Carlo profile -> export -> the same parameters, and bad
input (one line, exit status 2, nothing written)."""

import importlib.util
import json

import numpy as np
import pytest

from .test_bad_input import one_error_line, workdir  # noqa: F401  (the fixture)


HAVE_MX = importlib.util.find_spec("MaterialX") is not None
MX = pytest.mark.skipif(not HAVE_MX, reason="the materialx package is not installed (pip install materialx)")


def _ok(run, *args):
    code, out, err = run(*args)
    assert code == 0, err
    return out


@pytest.mark.parametrize("fmt,out", [("blender", "s.py"), ("unreal", "s.py"), ("unity", "S.asset"),
                                     pytest.param("materialx", "s.mtlx", marks=MX), ("unreal", "s.json")])
def test_engine_files_are_written(run, tmp_path, fmt, out):
    _ok(run, "export", "--material", "skin1", "--format", fmt, "--out", tmp_path / out)
    assert (tmp_path / out).stat().st_size > 200


def test_engine_json_reads_back_into_another_engine(run, tmp_path):
    _ok(run, "export", "--material", "skin1", "--format", "unreal", "--out", tmp_path / "u.json")
    _ok(run, "export", "--material", tmp_path / "u.json", "--format", "blender", "--out", tmp_path / "b.json")
    _ok(run, "export", "--material", "skin1", "--format", "blender", "--out", tmp_path / "b0.json")
    b, b0 = (json.loads((tmp_path / f).read_text()) for f in ("b.json", "b0.json"))
    # the same Burley (A, d) through Unreal's encoding (float32, the 0.6 magic number and back)
    np.testing.assert_allclose(b["base_color"], b0["base_color"], rtol=1e-6)
    np.testing.assert_allclose(np.array(b["subsurface_radius"]) * b["subsurface_scale"],
                               np.array(b0["subsurface_radius"]) * b0["subsurface_scale"], rtol=1e-5)


@pytest.mark.parametrize("fmt,suffix", [("unreal", "json"), ("unity", "json"), ("blender", "json"),
                                        pytest.param("materialx", "mtlx", marks=MX)])
def test_round_trip_through_monte_carlo(run, tmp_path, fmt, suffix):
    """Engine parameters -> material (Monte Carlo inversion) -> MCML profile -> Burley fit -> export: the
    albedo within 1 % and each channel's length within 5 % of the start (MCML noise at 100k photons and the
    table's interpolation)."""
    from ssskit.export.readers import read_engine_file

    first = tmp_path / f"a.{suffix}"
    again = tmp_path / f"b.{suffix}"
    _ok(run, "export", "--material", "skin1", "--format", fmt, "--out", first)
    _ok(run, "export", "--material", first, "--model", "montecarlo", "--photons", "100000", "--format", fmt,
        "--out", again, *(("--no-transmission",) if fmt in ("unreal", "unity") else ()))
    a, b = read_engine_file(first), read_engine_file(again)
    np.testing.assert_allclose(b.albedo, a.albedo, rtol=0.01)
    np.testing.assert_allclose(b.d_mm, a.d_mm, rtol=0.05)


def test_transmission_fields_need_a_physical_material(run, tmp_path):
    """A preset's export carries the fitted transmission fields; artists' terms through the Burley inversion (no
    coefficients, no MCML table) and --no-transmission say why they are left out."""
    _ok(run, "export", "--material", "skin1", "--format", "unreal", "--out", tmp_path / "u.json")
    tr = json.loads((tmp_path / "u.json").read_text())["transmission"]
    assert {"ExtinctionScale", "TransmissionTintColor", "DistanceScale", "max_rel_error"} <= set(tr)
    for fmt in ("unity", "unreal"):  # the fields left out silently: one note on stderr says why, exit 0
        code, out, err = run("export", "--albedo", "0.8,0.5,0.3", "--mfp", "1,0.5,0.2", "--format", fmt,
                             "--out", tmp_path / "a.json")
        assert code == 0 and out.startswith("# wrote"), err
        assert json.loads((tmp_path / "a.json").read_text())["transmission"]["available"] is False
        assert err.count("\n") == 1 and err.startswith(f"ssskit: note: --format {fmt}: the transmission fields are "
                                                      "left out, the engine's defaults stay: artists' terms"), err
        assert "no slab transmittance" in err and "give --material" in err
    code, _, err = run("export", "--material", "skin1", "--format", "unity", "--no-transmission",
                       "--out", tmp_path / "n.json")
    assert code == 0 and err == ""  # asked to leave them out: no note
    assert "--no-transmission" in json.loads((tmp_path / "n.json").read_text())["transmission"]["why"]


def test_unity_asset_reads_back_with_an_albedo(run, tmp_path):
    _ok(run, "export", "--material", "skin1", "--format", "unity", "--out", tmp_path / "S.asset")
    _ok(run, "export", "--material", tmp_path / "S.asset", "--albedo", "0.43,0.22,0.12", "--format", "blender",
        "--out", tmp_path / "b.json")
    b = json.loads((tmp_path / "b.json").read_text())
    np.testing.assert_allclose(b["base_color"], [0.43, 0.22, 0.12])


def test_artists_terms(run, tmp_path):
    _ok(run, "export", "--albedo", "0.44,0.22,0.12", "--dmfp", "4.9,2.4,1.4", "--format", "blender",
        "--out", tmp_path / "b.json")
    b = json.loads((tmp_path / "b.json").read_text())
    a = np.array([0.44, 0.22, 0.12])
    d = np.array([4.9, 2.4, 1.4]) / (3.5 + 100 * (a - 0.33) ** 4)  # the Burley-fit inversion (Xie Eq. 5)
    np.testing.assert_allclose(np.array(b["subsurface_radius"]) * b["subsurface_scale"] * 1e3 / (4 * np.pi), d,
                               rtol=1e-6)


BAD_EXPORT = [
    (["--albedo", "1.2,0.5,0.3", "--dmfp", "1", "--format", "blender", "--out", "o.json"], "must lie in (0, 1]"),
    (["--albedo", "0,0.5,0.3", "--mfp", "1", "--format", "unity", "--out", "o.json"], "must lie in (0, 1]"),
    # an engine without a cited clamp: its albedo outside Burley's (0, 1] was clamped silently to 1
    # (the file's values are out of their domain, not missing: not "lacks the parameters ssskit writes")
    (["--material", "alb2_blender.json", "--format", "unity", "--out", "o.json"],
     "error: 'alb2_blender.json': Burley albedo A must lie in (0, 1]"),
    (["--material", "alb0_unity.json", "--format", "blender", "--out", "o.json"],
     "error: 'alb0_unity.json': Burley albedo A must lie in (0, 1]"),
    (["--material", "negd_blender.json", "--format", "unity", "--out", "o.json"],
     "error: 'negd_blender.json': Burley length d must lie in (0, inf) mm"),
    # an HDRP .asset takes --albedo; its distances came from the file and --dmfp was ignored silently
    (["--material", "good.asset", "--albedo", "0.5", "--dmfp", "1", "--format", "blender", "--out", "o.json"],
     "--dmfp does not apply to an engine file"),
    (["--material", "good.asset", "--albedo", "0.5", "--g", "0.5", "--format", "blender", "--out", "o.json"],
     "--g does not apply to an engine file"),
    (["--albedo", "0.5", "--dmfp", "0,1,1", "--format", "blender", "--out", "o.json"], "must lie in [1e-06, 1e+06] mm"),
    (["--albedo", "0.5", "--mfp", "1,-1,1", "--format", "unreal", "--out", "o.json"], "must lie in [1e-06, 1e+06] mm"),
    (["--albedo", "0.5", "--format", "unreal", "--out", "o.json"], "need --albedo and one of --mfp"),
    (["--albedo", "0.5", "--mfp", "1", "--dmfp", "1", "--format", "unreal", "--out", "o.json"], "one of --mfp"),
    (["--material", "skin1", "--albedo", "0.5", "--mfp", "1", "--format", "unreal", "--out", "o.json"],
     "give the material once"),
    (["--material", "skin1", "--eta", "1.4", "--format", "unreal", "--out", "o.json"], "--eta does not apply to a material without artists' terms"),
    (["--material", "skin1", "--format", "godot", "--out", "o.json"], "unknown export format 'godot'"),
    (["--material", "skin1", "--format", "unity", "--out", "o.py"], "--out for --format unity"),
    (["--material", "other.json", "--format", "unity", "--out", "o.json"], "the engine of an export must be one of unreal, unity, blender, got 'godot'"),
    (["--material", "other.asset", "--albedo", "0.5", "--format", "blender", "--out", "o.json"],
     "not HDRP's DiffusionProfileSettings"),
    (["--material", "cut.asset", "--albedo", "0.5", "--format", "blender", "--out", "o.json"], "truncated"),
    pytest.param(["--material", "cut.mtlx", "--format", "blender", "--out", "o.json"],
                 "not a readable MaterialX document", marks=MX),
    (["--material", "good.asset", "--format", "blender", "--out", "o.json"], "holds no albedo"),
    (["--material", "skin1", "--unreal-form", "dmfp", "--format", "unreal", "--out", "o.json"], "--unreal-form"),
    (["--material", "skin1", "--standard-surface", "--format", "unity", "--out", "o.json"], "--standard-surface"),
    (["--material", "skin1", "--no-transmission", "--format", "blender", "--out", "o.json"], "--no-transmission"),
    (["--material", "skin1", "--model", "dipole", "--grid-fraction", "0.999", "--format", "unity", "--out", "o.json"],
     "--grid-fraction does not apply"),
]


@pytest.fixture
def engine_files(workdir):  # noqa: F811
    from ssskit.export import engine_parameters
    from ssskit.export.unity import unity_asset
    from ssskit.materials import get_material
    from ssskit.profiles import profile_for_material

    prof = profile_for_material("skin1", "dipole")
    asset = unity_asset(engine_parameters(prof, "unity", get_material("skin1")), "Skin1")
    (workdir / "good.asset").write_text(asset)
    (workdir / "cut.asset").write_text(asset[: asset.index("  profile:") + 40])
    (workdir / "other.asset").write_text(asset.replace("b2686e09ec7aef44bad2843e4416f057",
                                                       "0123456789abcdef0123456789abcdef"))
    (workdir / "other.json").write_text(json.dumps({"engine": "godot", "albedo": [0.5, 0.5, 0.5]}))
    for engine, a in (("blender", 2.0), ("unity", 0.0)):
        params = engine_parameters(prof, engine, get_material("skin1"))
        (workdir / f"alb{a:g}_{engine}.json").write_text(json.dumps(params | {"base_color": [a, 0.5, 0.5]}))
    params = engine_parameters(prof, "blender", get_material("skin1"))
    radius = [-1.0, *params["subsurface_radius"][1:]]
    (workdir / "negd_blender.json").write_text(json.dumps(params | {"subsurface_radius": radius}))
    if HAVE_MX:
        from ssskit.export.materialx import materialx_document

        mtlx = materialx_document(np.array([0.4, 0.2, 0.1]), np.array([1.0, 0.5, 0.3]), "x")
        (workdir / "cut.mtlx").write_text(mtlx[: len(mtlx) // 2])
    return workdir


@pytest.mark.parametrize("args,fragment", BAD_EXPORT)
def test_bad_export_input(run, engine_files, args, fragment):
    one_error_line(run, engine_files, ["export", *args], fragment)


def test_grid_fraction_widens_the_monte_carlo_grid(run, tmp_path):
    """export --model montecarlo --grid-fraction: the supplement's 32-MFP grid drops Marble's red overflow;
    a grid holding 99.9 % of the light gives the larger, complete albedo."""
    common = ["export", "--material", "marble", "--model", "montecarlo", "--photons", "20000", "--format", "blender"]
    _ok(run, *common, "--out", tmp_path / "a.json")
    _ok(run, *common, "--grid-fraction", "0.999", "--out", tmp_path / "b.json")
    a, b = (json.loads((tmp_path / f).read_text())["base_color"] for f in ("a.json", "b.json"))
    assert b[0] > a[0] * 1.01  # the issue measured 2.3 % in red


def test_an_unreal_albedo_past_the_engines_clamp_is_read_as_ue_reads_it(run, tmp_path):
    """UE clamps SurfaceAlbedo to [0.009, 1] (SubsurfaceProfile.cpp CreateTexture): an albedo of 2 reads as 1,
    as the engine would render it, and stderr says which clamps fired (it was silent)."""
    _ok(run, "export", "--material", "marble", "--model", "dipole", "--format", "unreal", "--out", tmp_path / "u.json")
    data = json.loads((tmp_path / "u.json").read_text())
    data["mfp"]["SurfaceAlbedo"] = [2.0, 0.5, 0.004]
    (tmp_path / "alb2.json").write_text(json.dumps(data))
    code, out, err = run("export", "--material", tmp_path / "alb2.json", "--format", "blender", "--out", tmp_path / "b.json")
    assert code == 0, err
    assert "SurfaceAlbedo[R] 2 -> 1 (UE clamps to [0.009, 1])" in err
    assert "SurfaceAlbedo[B] 0.004 -> 0.009 (UE clamps to [0.009, 1])" in err
    assert "SurfaceAlbedo[G]" not in err
    np.testing.assert_allclose(json.loads((tmp_path / "b.json").read_text())["base_color"], [1.0, 0.5, 0.009], rtol=1e-6)


@pytest.mark.parametrize("fmt", ["unreal", "unity", "blender"])
def test_an_engine_name_in_any_case_reads_as_the_engine(run, tmp_path, fmt):
    """Issue 34: a JSON export whose "engine" is "UNITY" or "Unreal" recursed forever (looked up case-insensitively
    in FORMATS, checked case-sensitively); the engine name is checked once, case-insensitively, and the file reads
    as the lower-case one does."""
    from ssskit.export.readers import read_engine_file

    _ok(run, "export", "--material", "skin1", "--format", fmt, "--out", tmp_path / "a.json")
    data = json.loads((tmp_path / "a.json").read_text())
    (tmp_path / "b.json").write_text(json.dumps({**data, "engine": fmt.upper()}))
    a, b = read_engine_file(tmp_path / "a.json"), read_engine_file(tmp_path / "b.json")
    assert b.engine == a.engine == fmt
    np.testing.assert_array_equal(b.albedo, a.albedo)
    np.testing.assert_array_equal(b.d_mm, a.d_mm)
