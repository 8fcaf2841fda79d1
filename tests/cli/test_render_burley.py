"""``ssskit render --method burley``: the Burley Monte Carlo pass from the command line (small sizes), and
its bad inputs (one line, exit status 2, nothing written)."""

import json

import numpy as np
import pytest

from tests.cli.test_bad_input import one_error_line, workdir  # noqa: F401  (fixture)


def render_json(run, *args):
    code, out, err = run("render", "--pass", "burley", *args, "--json")
    assert code == 0, err
    return json.loads(out)


def test_burley_render_on_a_gbuffer_file(run, gbuffer_file, tmp_path):
    import OpenEXR

    exr = tmp_path / "b.exr"
    data = render_json(run, "--scene", gbuffer_file, "--spp", "64", "--sampler", "exact", "--out", exr, "--no-mips")
    assert data["pass"] == "burley" and data["burley"]["spp"] == 64 and data["burley"]["sampler"] == "exact"
    assert data["burley"]["mips"] is False
    assert data["size"] == [32, 24]
    assert data["metrics"]["exact_2d"]["psnr"] > 30
    with OpenEXR.File(str(exr)) as f:
        assert {"RGB", "sss", "exact"} <= set(f.channels())


def test_sampler_c_and_params_reach_the_pass(run, gbuffer_file):
    a = render_json(run, "--scene", gbuffer_file, "--sampler", "xie", "--c", "2.6", "--spp", "8", "--backend", "numpy",
                    "--albedo", "0.8,0.6,0.4", "--dmfp", "4,2,1", "--no-perceptual")
    assert a["burley"]["c"] == 2.6 and a["burley"]["sampler"] == "xie" and a["burley"]["backend"] == "numpy"
    from ssskit.screenspace import BurleyParams

    np.testing.assert_allclose(a["burley_params"]["d_mm"], BurleyParams.from_dmfp((0.8, 0.6, 0.4), (4, 2, 1)).d_mm)
    # more samples: closer to the exact convolution (the same G-buffer and parameters)
    assert a["burley"]["mips"] is True  # on by default (Xie 2020)
    b = render_json(run, "--scene", gbuffer_file, "--spp", "512", "--albedo", "0.8,0.6,0.4", "--dmfp", "4,2,1",
                    "--no-perceptual", "--no-mips")
    c = render_json(run, "--scene", gbuffer_file, "--spp", "4", "--albedo", "0.8,0.6,0.4", "--dmfp", "4,2,1",
                    "--no-perceptual", "--no-mips")
    assert b["metrics"]["exact_2d"]["rmse"] < c["metrics"]["exact_2d"]["rmse"]


def test_text_output(run, gbuffer_file):
    code, out, err = run("render", "--pass", "burley", "--scene", gbuffer_file, "--spp", "4", "--no-perceptual")
    assert code == 0, err
    assert "Burley d =" in out and "exact sampler, 4 spp, mips" in out and "vs exact_2d" in out


BAD = [
    (["--spp", "0"], "--spp: spp must lie in [1, 65536], got 0"),
    (["--spp", "-4"], "--spp: spp must lie in"),
    (["--sampler", "sobol"], "Invalid value for '--sampler'"),
    (["--c", "3.5"], "--c: c must lie in (2, 3), got 3.5"),
    (["--c", "2"], "--c: c must lie in (2, 3), got 2"),
    (["--c", "2.6"], "--c: c applies to sampler xie, not sampler exact"),
    (["--sampler", "golubev", "--c", "2.6"], "--c: c applies to sampler xie, not sampler golubev"),
    (["--albedo", "-0.2", "--dmfp", "1"], "--albedo/--dmfp: albedo must lie in (0, 1], got"),
    # A = 0 (R(r) = 0) was rendered while export --albedo refused it
    (["--albedo", "0", "--dmfp", "1"], "--albedo/--dmfp: albedo must lie in (0, 1], got"),
    (["--albedo", "0.5", "--dmfp", "1,-2,3"], "--albedo/--dmfp: dmfp_mm must lie in [1e-06, 1e+06] mm, got (1, -2, 3)"),
    # 1e12 mm (d = 2.79e11 mm) and 1e-9 mm rendered: the mean free paths every model takes
    (["--albedo", "0.5", "--dmfp", "1e12"], "dmfp_mm must lie in [1e-06, 1e+06] mm, got"),
    (["--albedo", "0.5", "--dmfp", "1,1,1e-9"], "dmfp_mm must lie in [1e-06, 1e+06] mm, got"),
    (["--albedo", "0.5,0.5", "--dmfp", "1"], "give one number or three"),
    (["--albedo", "0.5"], "--albedo and --dmfp go together"),
    (["--taps", "5"], "--taps applies to --pass separable"),
    (["--kernel", "svd:2"], "--kernel applies to --pass separable"),
    (["--jitter", "0.3"], "--jitter applies to --pass separable"),
    (["--out", "x.exr"], "x.exr"),
]


@pytest.mark.parametrize("args,fragment", BAD)
def test_bad_burley_input(run, workdir, args, fragment):  # noqa: F811
    one_error_line(run, workdir, ["render", "--scene", "slab", "--pass", "burley", "--size", "24x16", *args],
                   fragment)


@pytest.mark.parametrize("args,fragment", [(["--sampler", "xie"], "--sampler applies to --pass burley"),
                                           (["--c", "2.6"], "--c applies to --pass burley"),
                                           (["--no-mips"], "--no-mips applies to --pass burley")])
def test_burley_options_refused_for_the_separable_pass(run, workdir, args, fragment):  # noqa: F811
    one_error_line(run, workdir, ["render", "--scene", "slab", *args], fragment)


def test_count_image_of_the_wrong_shape_is_one_error(tmp_path):
    """The library side of the Must-show: an (H, W) count image of another shape is a PassError naming both."""
    from ssskit.errors import PassError
    from ssskit.screenspace import BurleyParams, Camera, GBuffer, burley_sss

    gb = GBuffer(diffuse=np.zeros((8, 10, 3), np.float32), albedo=np.zeros((8, 10, 3), np.float32),
                 depth=np.full((8, 10), 100.0, np.float32), profile_id=np.ones((8, 10), np.uint32),
                 camera=Camera(10, 8, 50.0, 50.0, 5, 4))
    with pytest.raises(PassError, match=r"shape \(8, 10\), got shape \(10, 8\)"):
        burley_sss(gb, BurleyParams.from_dmfp(0.5, 1.0), counts=np.ones((10, 8), np.int64))


def test_settings_file_holds_the_burley_settings(run, gbuffer_file, tmp_path):
    """A settings file with a [burley] table runs the Burley pass without --pass; options given on the
    command line override it; --pass separable wins over the file's pass."""
    from ssskit.pipeline import BurleyPass, RenderSettings

    s = RenderSettings(perceptual=False, seed=4, backend="numpy",
                       pass_=BurleyPass(sampler="xie", spp=8, c=2.6, mips=False))
    path = tmp_path / "burley.toml"
    s.save(path)
    code, out, err = run("render", "--scene", gbuffer_file, "--settings", path, "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["pass"] == "burley" and data["burley"] == s.burley_settings().to_dict()
    # the settings the frame ran with: the G-buffer's own size (32x24)
    assert data["settings"] == s.replace(width=32, height=24).to_dict()
    assert "burley" in data["settings"] and "separable" not in data["settings"]
    data = render_json(run, "--scene", gbuffer_file, "--settings", path, "--spp", "16", "--sampler", "exact")
    want = s.replace(pass_=BurleyPass(sampler="exact", spp=16, mips=False))  # c goes with the xie sampler
    assert data["burley"] == want.burley_settings().to_dict()  # seed, mips, backend: the file's
    code, out, err = run("render", "--scene", gbuffer_file, "--settings", path, "--pass", "separable",
                         "--backend", "numpy", "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["pass"] == "separable" and "separable" in data["settings"] and "taps" in data


def test_adaptive_takes_the_burley_settings_from_the_file(run, gbuffer_file, tmp_path):
    """--pass burley-adaptive --settings FILE runs the pass with the file's [burley] sampler (sampler, c,
    mips; spp is the adaptive budget's business) and its seed and backend; options on the command line
    override them."""
    from ssskit.pipeline import BurleyPass, RenderSettings

    s = RenderSettings(perceptual=False, seed=4, backend="numpy",
                       pass_=BurleyPass(sampler="xie", spp=8, c=2.6, mips=False))
    path = tmp_path / "burley.toml"
    s.save(path)
    want = {k: v for k, v in s.burley_settings().to_dict().items() if k != "spp"}
    code, out, err = run("render", "--pass", "burley-adaptive", "--scene", gbuffer_file, "--settings", path,
                         "--frames", "2", "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["pass"] == "burley-adaptive" and data["burley"] == want
    assert {k: data["settings"]["adaptive"][k] for k in ("sampler", "c", "mips")} == {"sampler": "xie", "c": 2.6,
                                                                                     "mips": False}
    code, out, err = run("render", "--pass", "burley-adaptive", "--scene", gbuffer_file, "--settings", path,
                         "--frames", "2", "--sampler", "exact", "--c", "2.5715", "--seed", "9", "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["burley"] == {**want, "sampler": "exact", "c": 2.5715, "seed": 9}  # mips, backend: the file's
    # the file's seed reaches the samples: another seed, another frame
    code, out, err = run("render", "--pass", "burley-adaptive", "--scene", gbuffer_file, "--settings", path,
                         "--frames", "2", "--seed", "5", "--json")
    assert code == 0, err
    other = json.loads(out)
    code, out, err = run("render", "--pass", "burley-adaptive", "--scene", gbuffer_file, "--settings", path,
                         "--frames", "2", "--json")
    same = json.loads(out)
    assert same["metrics"]["exact_2d"] != other["metrics"]["exact_2d"]
