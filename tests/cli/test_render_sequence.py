"""``ssskit render --method burley-adaptive`` along a scene's camera and light paths: per-frame JSON
(mean_spp, psnr, psnr_taa, ms), the fixed-count baseline through the same loop and TAA, per-frame images
and heatmaps, ``--static``, ``--taa/--no-taa``, and the bad inputs (one line, exit status 2)."""

import json
import math

import pytest

from tests.cli.test_bad_input import one_error_line, workdir  # noqa: F401  (fixture)

SMALL = ["--scene", "slab", "--pass", "burley-adaptive", "--size", "24x16", "--limit-spp", "64", "--no-perceptual"]


def run_json(run, *args):
    code, out, err = run("render", *SMALL, *args, "--json")
    assert code == 0, err
    return json.loads(out)


def test_moving_sequence_json_and_frames(run, workdir):  # noqa: F811
    data = run_json(run, "--frames", "5", "--budget", "4:16", "--frames-dir", "seq")
    assert data["static"] is False and data["taa"]["alpha"] == pytest.approx(0.1)
    rows = data["frames"]
    assert [r["frame"] for r in rows] == list(range(5))
    for r in rows:
        assert 4 <= r["mean_spp"] <= 16
        # the pass's, the guiding phase's and the whole loop's time: one finite figure each (no order asserted)
        assert all(math.isfinite(r[k]) and r[k] >= 0 for k in ("ms", "ms_update", "ms_frame"))
        assert math.isfinite(r["psnr"]) and math.isfinite(r["psnr_taa"])
    assert rows[0]["mean_spp"] == 4  # no history on the first frame: b_min (Eqs. 16-17)
    assert data["adaptive"]["disocclusion_spp"] == 4
    assert rows[0]["psnr_taa"] == pytest.approx(rows[0]["psnr"])  # TAA's first frame is the frame itself
    fixed = data["fixed"]
    assert fixed["spp"] == 16 and all(r["mean_spp"] == 16 for r in fixed["frames"])
    assert all(r["ms_update"] == 0 for r in fixed["frames"]) and fixed["total_ms_frame"] > 0  # no guiding phase
    assert fixed["total_samples"] == 16 * 24 * 16 * 5  # the slab fills the small frame
    assert data["total_samples"] == pytest.approx(sum(r["mean_spp"] for r in rows) * 24 * 16)
    assert data["reference"]["spp"] == 64 and data["reference"]["mips"] is False
    names = sorted(p.name for p in (workdir / "seq").iterdir())
    for f in range(5):
        assert {f"frame_{f:04d}.png", f"frame_{f:04d}_taa.png", f"counts_{f:04d}.png"} <= set(names)


def test_taa_off_leaves_the_sampler_unchanged(run, workdir):  # noqa: F811
    on = run_json(run, "--frames", "4")
    off = run_json(run, "--frames", "4", "--no-taa")
    assert off["taa"] is None and all(r["psnr_taa"] is None for r in off["frames"])
    # the adaptive sampler reads the pre-TAA output only: same counts and frames with TAA on or off
    assert [r["mean_spp"] for r in on["frames"]] == [r["mean_spp"] for r in off["frames"]]
    assert [r["psnr"] for r in on["frames"]] == pytest.approx([r["psnr"] for r in off["frames"]])


def test_disocclusion_spp_sets_the_first_frame(run, workdir):  # noqa: F811
    data = run_json(run, "--frames", "2", "--budget", "4:16", "--disocclusion-spp", "16")
    assert data["adaptive"]["disocclusion_spp"] == 16 and data["frames"][0]["mean_spp"] == 16


def test_static_flag_keeps_the_camera(run, workdir):  # noqa: F811
    code, out, err = run("render", *[a for a in SMALL if a not in ("--limit-spp", "64")], "--frames", "3", "--static",
                         "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["static"] is True and data["taa"] is not None
    assert all(math.isfinite(r["psnr_taa"]) for r in data["frames"])


def test_text_output(run, workdir):  # noqa: F811
    code, out, err = run("render", *SMALL, "--frames", "3")
    assert code == 0, err
    assert "along the camera/light path, frames 0..2" in out and "samples: fixed / adaptive = " in out


BAD = [
    (["--limit-spp", "1"], "--limit-spp: limit_spp must lie in [2, 131072], got 1"),
    (["--static", "--limit-spp", "128"], "--limit-spp: limit_spp applies to camera moving, not camera static"),
    (["--save-gbuffer", "g.exr"], "--save-gbuffer applies to one frame; add --static"),
    (["--reference"], "--reference applies to one frame; add --static"),
    (["--frames-dir", "notes.txt"], "is a file, not a folder"),
    (["--disocclusion-spp", "65"], "--disocclusion-spp: disocclusion_spp must lie in [8, 64], got 65"),
    (["--static", "--disocclusion-spp", "64"], "--disocclusion-spp: disocclusion_spp applies to camera moving, not camera static"),
    # the one-frame comparisons' options would be silently unused on a moving run
    (["--reference-spp", "128"], "--reference-spp: reference_spp applies to reference true, not reference false"),
    (["--reference-max-spp", "128"], "--reference-max-spp: reference_max_spp applies to reference true, not reference false"),
    (["--reference-rel-se", "0.5"], "--reference-rel-se: reference_rel_se applies to reference true, not reference false"),
    (["--no-exact"], "--no-exact applies to one frame; add --static"),
    (["--out", "a.png", "--frames-dir", "a.png"], "--frames-dir 'a.png' is also the --out file"),
    (["--out", "fd/frame_0001_taa.png", "--frames-dir", "fd"], "is one of the frame files --frames-dir writes"),
]


@pytest.mark.parametrize("args,fragment", BAD)
def test_bad_sequence_input(run, workdir, args, fragment):  # noqa: F811
    (workdir / "notes.txt").write_text("x")
    one_error_line(run, workdir, ["render", *SMALL, "--frames", "2", *args], fragment)


@pytest.mark.parametrize("method", [[], ["--pass", "burley"]])
@pytest.mark.parametrize("args,flag", [(["--static"], "--static"), (["--no-taa"], "--taa/--no-taa"),
                                       (["--frames-dir", "d"], "--frames-dir"), (["--limit-spp", "64"], "--limit-spp")])
def test_sequence_options_refused_elsewhere(run, workdir, method, args, flag):  # noqa: F811
    one_error_line(run, workdir, ["render", "--scene", "slab", *method, *args],
                   f"{flag} applies to --pass burley-adaptive")
