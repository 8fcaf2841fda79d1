"""``ssskit render --pass burley-adaptive``: the Burley pass with variance-guided sample counts (Xie 2020
Sec. 4.1) over frames on a static camera, and its bad parameters (one line, exit status 2, nothing written)."""

import json
import math

import pytest

from tests.cli.test_bad_input import one_error_line, workdir  # noqa: F401  (fixture)


def adaptive_json(run, *args):
    code, out, err = run("render", "--pass", "burley-adaptive", *args, "--json")
    assert code == 0, err
    return json.loads(out)


def test_adaptive_render_on_a_gbuffer_file(run, gbuffer_file, tmp_path):
    import OpenEXR

    exr = tmp_path / "a.exr"
    data = adaptive_json(run, "--scene", gbuffer_file, "--frames", "12", "--sigma0", "0.01", "--kappa", "0.6",
                         "--budget", "4:32", "--no-mips", "--no-perceptual", "--out", exr)
    a = data["adaptive"]
    assert data["pass"] == "burley-adaptive" and a["frames"] == 12
    assert data["settings"]["adaptive"]["frames"] == 12  # the run's own pass, not the separable default
    assert a["sigma0_sq"] == pytest.approx(1e-4) and a["sigma0"] == pytest.approx(0.01)
    assert (a["kappa"], a["b_min"], a["b_max"], a["alpha"], a["correction"]) == (0.6, 4, 32, 0.2, "variance")
    rows = data["frames"]
    assert [r["frame"] for r in rows] == list(range(12))
    assert rows[0]["mean_spp"] == 4  # no history on the first frame: b_min (Eqs. 16-17)
    assert all(4 <= r["mean_spp"] <= 32 and r["ms"] >= 0 and r["ms_update"] >= 0 for r in rows)
    assert max(r["mean_spp"] for r in rows) > 4  # the counts adapt
    assert data["mean_spp"] == pytest.approx(sum(r["mean_spp"] for r in rows) / 12)
    assert all(math.isfinite(r["psnr"]) for r in rows)
    assert data["fixed"]["spp"] == 32 and data["fixed"]["metrics"]["exact_2d"]["psnr"] > 30
    # the average of the frames is closer to the pass's limit than one frame
    assert data["metrics"]["average_exact_2d"]["psnr"] > data["metrics"]["exact_2d"]["psnr"]
    with OpenEXR.File(str(exr)) as f:
        assert {"RGB", "sss", "exact"} <= set(f.channels())


def test_text_output(run, gbuffer_file, tmp_path):
    code, out, err = run("render", "--pass", "burley-adaptive", "--scene", gbuffer_file, "--frames", "3",
                         "--no-perceptual", "--frames-dir", tmp_path / "fd")
    assert code == 0, err
    assert "Burley adaptive, sigma0 0.03162 (sigma0^2 0.001), kappa 0.2, budget 8:64, 3 frames" in out
    assert "backend, TAA on" in out  # as the moving run's header says
    assert f"# wrote frames and sample-count heatmaps to {tmp_path / 'fd'}" in out
    assert {f"counts_{f:04d}.png" for f in range(3)} <= {p.name for p in (tmp_path / "fd").iterdir()}
    assert "mean spp per frame: first 8.0" in out and "fixed 64 spp vs exact_2d" in out


BAD = [
    (["--sigma0", "0"], "--sigma0: sigma0 must lie in [1e-150, 1e+150], got 0 (the target standard deviation"),
    (["--sigma0", "-0.1"], "--sigma0: sigma0 must lie in [1e-150, 1e+150], got -0.1"),
    (["--sigma0", "nan"], "--sigma0"),
    (["--kappa", "1.5"], "--kappa: kappa must lie in [0, 1], got 1.5"),
    (["--kappa", "-0.2"], "--kappa: kappa must lie in [0, 1], got -0.2"),
    (["--budget", "64:8"], "--budget: the sample budget needs b_min <= b_max, got b_min=64 > b_max=8"),
    (["--budget", "0:8"], "--budget: b_min must lie in [1, 65536], got 0"),
    (["--budget", "8-64"], "must look like 8:64"),
    (["--alpha", "0"], "--alpha: alpha must lie in (0, 1], got 0 (an EMA weight)"),
    (["--alpha", "1.5"], "--alpha: alpha must lie in (0, 1], got 1.5"),
    (["--frames", "0"], "--frames: frames must lie in [1, 100000], got 0"),
    (["--correction", "stddev"], "Invalid value for '--correction'"),
    (["--spp", "32"], "--spp: the adaptive pass chooses its samples per pixel"),
    (["--taps", "5"], "--taps applies to --pass separable"),
    (["--c", "3.5"], "--c: c must lie in (2, 3), got 3.5"),
    (["--out", "x.exr"], "x.exr"),
    # sigma0 is fine but its square is not a usable float64: the error says so, not "sigma0_sq ... got 0.0"
    (["--sigma0", "1e-200"], "--sigma0: sigma0 must lie in [1e-150, 1e+150], got 1e-200 (the target standard "
                             "deviation of a frame's luminance; its square must be a positive float64)"),
    (["--sigma0", "1e200"], "--sigma0: sigma0 must lie in [1e-150, 1e+150], got 1e+200"),
    # --frames-dir may be neither another output nor the folder of another output's name
    (["--static", "--out", "f.png", "--frames-dir", "f.png"], "--frames-dir 'f.png' is also the --out file"),
    (["--static", "--save-gbuffer", "new.exr", "--frames-dir", "new.exr"],
     "--frames-dir 'new.exr' is also the --save-gbuffer file"),
    (["--static", "--out", "fd/frame_0001.png", "--frames-dir", "fd"],
     "--out 'fd/frame_0001.png' is one of the frame files --frames-dir writes"),
    (["--static", "--out", "fd/counts_0000.png", "--frames-dir", "fd"], "is one of the frame files --frames-dir"),
]


@pytest.mark.parametrize("args,fragment", BAD)
def test_bad_adaptive_input(run, workdir, args, fragment):  # noqa: F811
    one_error_line(run, workdir, ["render", "--scene", "slab", "--pass", "burley-adaptive", "--size", "24x16",
                                  *args], fragment)


@pytest.mark.parametrize("method", [[], ["--pass", "burley"]])
@pytest.mark.parametrize("args,flag", [(["--kappa", "0.5"], "--kappa"), (["--frames", "8"], "--frames"),
                                       (["--budget", "8:32"], "--budget"), (["--sigma0", "0.01"], "--sigma0")])
def test_adaptive_options_refused_elsewhere(run, workdir, method, args, flag):  # noqa: F811
    one_error_line(run, workdir, ["render", "--scene", "slab", *method, *args],
                   f"{flag} applies to --pass burley-adaptive")


TIMES = ("ms", "ms_update", "ms_frame", "median_ms", "median_ms_update", "median_ms_frame", "total_ms_frame")


def _untimed(value):
    """The JSON without its wall-clock times (the only values that differ between two identical runs)."""
    if isinstance(value, dict):
        return {k: _untimed(v) for k, v in value.items() if k not in TIMES}
    if isinstance(value, list):
        return [_untimed(v) for v in value]
    return value


@pytest.mark.parametrize("moving", [False, True])
def test_an_adaptive_table_reproduces_the_options_bit_for_bit(run, gbuffer_file, tmp_path, moving):
    """The same adaptive run from options and from a settings file's [adaptive] table: the same JSON (but
    for its times) and the same image, layer by layer, bit for bit."""
    import numpy as np

    from ssskit.io import read_exr
    from ssskit.pipeline import AdaptivePass, RenderSettings

    scene = ["--scene", "slab", "--size", "24x16", "--limit-spp", "32"] if moving else ["--scene", gbuffer_file]
    opts = ["--frames", "3", "--sigma0", "0.01", "--kappa", "0.6", "--budget", "4:16", "--sampler", "xie",
            "--c", "2.6", "--no-mips", "--seed", "3", "--no-perceptual", "--backend", "numba"]
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    code, out, err = run("render", "--pass", "burley-adaptive", *scene, *opts, "--out", a, "--json")
    assert code == 0, err
    from_options = json.loads(out)
    member = AdaptivePass(frames=3, sigma0_sq=0.01**2, kappa=0.6, b_min=4, b_max=16, sampler="xie", c=2.6, mips=False,
                          limit_spp=32 if moving else None)
    s = RenderSettings(seed=3, perceptual=False, backend="numba", pass_=member,
                       **({"width": 24, "height": 16} if moving else {}))
    path = tmp_path / "run.toml"
    s.save(path)
    assert "[adaptive]" in path.read_text()
    code, out, err = run("render", "--scene", "slab" if moving else gbuffer_file, "--settings", path, "--out", b,
                         "--json")
    assert code == 0, err
    from_file = json.loads(out)
    assert _untimed(from_file) == _untimed(from_options)
    layers_a, layers_b = read_exr(a)[1], read_exr(b)[1]
    assert set(layers_a) == set(layers_b)
    for name in layers_a:
        np.testing.assert_array_equal(layers_b[name], layers_a[name])
