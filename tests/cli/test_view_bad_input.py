"""``ssskit view``'s bad input: one stderr line ``ssskit: error: ...``, exit status 2, nothing on stdout, nothing
written, no traceback, and every check before any work (the scene is not read, no kernel is built); and the
viewer's Burley shader as ``ssskit export --pass burley`` writes it (its bad input, the page's text, the compute
form)."""

import pytest

from tests.cli.test_bad_input import one_error_line, workdir  # noqa: F401 - the fixture

#: the artists' terms' valid domain: albedo in (0, 1], mean free path in ssskit.profiles.domain.MFP_RANGE_MM
AL, MFP = "0.8,0.6,0.5", "3.7,1.4,0.7"
BAD = [
    (["--scene", "nosuch"], "scene 'nosuch'"),
    (["--scene", "f.txt"], "scene 'f.txt'"),
    (["--scene", "missing.obj"], "missing.obj"),
    (["--material", "nosuch"], "nosuch"),
    (["--material", ""], "the material name is empty"),
    (["--material", "missing.json"], "missing.json"),
    (["--albedo", AL], "artists' terms need albedo and mfp together"),
    (["--mfp", MFP], "artists' terms need albedo and mfp together"),
    (["--material", "skin1", "--albedo", AL, "--mfp", MFP], "give the material once"),
    (["--albedo", "0.8,0.6", "--mfp", MFP], "give one number or three (R,G,B)"),
    (["--albedo", "a,b,c", "--mfp", MFP], "is not a number or three comma-separated numbers"),
    (["--albedo", "nan,0.6,0.5", "--mfp", MFP], "albedo must lie in (0, 1]"),
    (["--albedo", "-0.1,0.6,0.5", "--mfp", MFP], "albedo must lie in (0, 1]"),
    (["--albedo", "0,0.6,0.5", "--mfp", MFP], "albedo must lie in (0, 1]"),
    (["--albedo", "1.5,0.6,0.5", "--mfp", MFP], "albedo must lie in (0, 1]"),
    (["--albedo", "inf,0.6,0.5", "--mfp", MFP], "albedo must lie in (0, 1]"),
    (["--albedo", AL, "--mfp", "nan,1.4,0.7"], "mfp must lie in"),
    (["--albedo", AL, "--mfp", "-3.7,1.4,0.7"], "mfp must lie in"),
    (["--albedo", AL, "--mfp", "0,1.4,0.7"], "mfp must lie in"),
    (["--albedo", AL, "--mfp", "1e9,1.4,0.7"], "mfp must lie in"),
    (["--port", "70000", "--no-open"], "--port"),
    (["--port", "-1", "--no-open"], "--port"),
    (["--port", "http", "--no-open"], "--port"),
    (["--presets", "skin1", "--no-open"], "--presets applies to a static folder (--out), not a served page"),
    (["--out", "site", "--presets", "skin1,nosuch", "--no-open"], "--presets must be one of"),
    (["--out", "f.txt", "--no-open"], "f.txt"),
    (["--out", "f.txt/site", "--no-open"], "f.txt"),
    (["--out", "full", "--no-open"], "holding other files"),
]


@pytest.mark.parametrize("args, fragment", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_view_bad_input(run, workdir, monkeypatch, args, fragment):  # noqa: F811 - the fixture
    """Every refusal comes before the scene is read or a kernel built: both are replaced by a failure here."""
    import ssskit.view.site as site

    def no_work(*_a, **_k):
        raise AssertionError("work started before the input was checked")

    monkeypatch.setattr(site, "scene_payload", no_work)
    monkeypatch.setattr(site, "material_payload", no_work)
    (workdir / "full").mkdir()
    (workdir / "full" / "keep.txt").write_text("a user's file")
    one_error_line(run, workdir, ["view", *args], fragment)


#: ``ssskit export --pass burley`` (the viewer's Burley shader): GLSL only, a homogeneous material, no kernel options
EXPORT_BAD = [
    (["--material", "skin1", "--pass", "burley", "--format", "hlsl-shader", "--out", "b.hlsl"], "--pass burley applies to --format glsl-shader, not --format hlsl-shader"),
    (["--pass", "burley", "--format", "glsl-shader", "--out", "b.frag"], "needs --material"),
    (["--material", "skin1", "--pass", "burley", "--taps", "7", "--format", "glsl-shader", "--out", "b.frag"],
     "--taps applies to --pass separable, not --pass burley (the shader bakes"),
    (["--material", "skin1", "--pass", "burley", "--model", "dipole", "--format", "glsl-shader", "--out", "b.frag"],
     "--model applies to --pass separable or transmission, not --pass burley"),
    (["--material", "skin1", "--pass", "burley", "--transmission-model", "mcml", "--format", "glsl-shader",
      "--out", "b.frag"], "--transmission-model applies to --pass transmission"),
    (["--albedo", "nan,0.6,0.5", "--mfp", MFP, "--pass", "burley", "--format", "glsl-shader", "--out", "b.frag"],
     "albedo must lie in (0, 1]"),
]


@pytest.mark.parametrize("args, fragment", EXPORT_BAD, ids=[" ".join(a) for a, _ in EXPORT_BAD])
def test_export_burley_pass_bad_input(run, workdir, args, fragment):  # noqa: F811 - the fixture
    one_error_line(run, workdir, ["export", *args], fragment)


def test_export_burley_pass_writes_the_viewers_shader(run, workdir):  # noqa: F811 - the fixture
    """``--pass burley`` to a .frag writes the Burley shader the viewer's data hold for the material (the page's
    text: tests/view/test_view.py checks it in the browser), less the comment line after #version."""
    from ssskit.view.site import MaterialRequest, material_payload

    code, out, err = run("export", "--material", "skin1", "--pass", "burley", "--format", "glsl-shader", "--out",
                         "b.frag")
    assert code == 0, err
    lines = (workdir / "b.frag").read_text().splitlines(keepends=True)
    assert "".join(lines[:1] + lines[2:]) == material_payload(MaterialRequest("skin1"))["burley"]["shader"]


def test_export_burley_pass_compute_form_compiles(run, workdir):  # noqa: F811 - the fixture
    """``--pass burley`` to a .comp writes the gl backend's source for the material's plan (which runs against the
    oracle in tests/backends), and glslangValidator compiles it (where installed)."""
    from ssskit.backends.burley_plan import build_burley_plan
    from ssskit.backends.gl.burley import burley_export_source
    from ssskit.export.shaders import glsl_to_spirv, tools_available
    from ssskit.screenspace.burley import burley_params_for_material

    code, out, err = run("export", "--material", "skin1", "--pass", "burley", "--format", "glsl-shader", "--out",
                         "b.comp")
    assert code == 0, err
    text = (workdir / "b.comp").read_text()
    comment, _, rest = text.partition("\n")
    assert comment.startswith("// ssskit export: the Burley pass")
    assert rest == burley_export_source(build_burley_plan({1: burley_params_for_material("skin1")}, 1.0, 1.0))
    ok, why = tools_available()
    if ok:
        assert glsl_to_spirv(text)[:4] == b"\x03\x02\x23\x07"  # the SPIR-V magic number
