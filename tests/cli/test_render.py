"""``ssskit render``: outputs, G-buffer files, engine tap kernels and settings files (small sizes)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest


def render_json(run, *args):
    code, out, err = run("render", *args, "--json")
    assert code == 0, err
    return json.loads(out)


def test_render_outputs(run, tmp_path):
    import OpenEXR

    from ssskit.screenspace import load_gbuffer

    png, exr, gbf = tmp_path / "a.png", tmp_path / "a.exr", tmp_path / "g.exr"
    data = render_json(run, "--scene", "slab", "--size", "48x36", "--spp", "2", "--out", exr, "--save-gbuffer", gbf)
    assert data["settings"]["taps"] == 7 and data["metrics"]["exact_2d"]["psnr"] > 30
    assert data["size"] == [48, 36]
    with OpenEXR.File(str(exr)) as f:
        chans = set(f.channels())
    assert {"RGB", "sss", "exact"} <= chans
    assert load_gbuffer(gbf).shape == (36, 48)
    code, _, err = run("render", "--scene", gbf, "--kernel", "artist", "--out", png)
    assert code == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_engine_tap_kernel_uses_taps(run, gbuffer_file):
    """--kernel jimenez2012 --taps 7 renders 7 taps (it used to render the preset's 11 silently)."""
    data = render_json(run, "--scene", gbuffer_file, "--kernel", "jimenez2012", "--taps", "7", "--backend", "numpy")
    assert data["taps"] == 7
    data = render_json(run, "--scene", gbuffer_file, "--kernel", "jimenez2012:17", "--backend", "numpy")
    assert data["taps"] == 17 and data["settings"]["taps"] == 17
    data = render_json(run, "--scene", gbuffer_file, "--kernel", "jimenez2012:9", "--taps", "9", "--backend", "numpy")
    assert data["taps"] == 9


@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_settings_file_and_overrides(run, tmp_path, gbuffer_file, suffix):
    from ssskit.pipeline import RenderSettings, SeparablePass

    settings = RenderSettings(kernel="svd:2", taps=9, perceptual=False, backend="numpy", pass_=SeparablePass(jitter=0.3))
    path = tmp_path / f"frame{suffix}"
    settings.save(path)
    data = render_json(run, "--scene", gbuffer_file, "--settings", path)
    # the settings the frame was rendered with: the G-buffer's own size (32x24), not the default 256x192
    assert data["settings"] == settings.replace(width=32, height=24).to_dict()
    # options given on the command line override the file; the others keep the file's values
    data = render_json(run, "--scene", gbuffer_file, "--settings", path, "--taps", "5", "--jitter", "0", "--seed", "3")
    expected = settings.replace(taps=5, seed=3, pass_=SeparablePass(jitter=0.0), width=32, height=24)
    assert data["settings"] == expected.to_dict()
    assert "flip" not in data["metrics"]["exact_2d"]


def test_backend_option(run, gbuffer_file):
    from ssskit.backends import backend_status

    for name, status in backend_status().items():
        if status["available"]:
            data = render_json(run, "--scene", gbuffer_file, "--backend", name, "--no-exact")
            assert data["settings"]["backend"] == name


def test_method_is_a_deprecated_alias_of_pass(run, gbuffer_file):
    code, out, err = run("render", "--scene", gbuffer_file, "--method", "burley", "--spp", "4", "--backend", "numpy",
                         "--no-perceptual", "--json")
    assert code == 0, err
    assert json.loads(out)["pass"] == "burley"
    assert err.count("--method is deprecated") == 1 and "use --pass" in err
    code, out, err = run("render", "--scene", gbuffer_file, "--method", "burley", "--pass", "separable")
    assert code == 2 and "--pass separable and --method burley disagree" in err


def test_an_old_settings_file_runs_as_the_tree_says_so_once(run, gbuffer_file, tmp_path):
    """Yesterday's layout (method, [sss] with frame/seed/backend) gives the same frame as the same settings
    in today's layout, with one warning line naming the file."""
    from ssskit.pipeline import RenderSettings, SeparablePass

    old = tmp_path / "old.toml"
    old.write_text('kernel = "svd:2"\nperceptual = false\nmethod = "separable"\n\n[sss]\njitter = 0.3\nseed = 2\n'
                   'backend = "numpy"\n')
    new = tmp_path / "new.toml"
    RenderSettings(kernel="svd:2", perceptual=False, seed=2, backend="numpy", pass_=SeparablePass(jitter=0.3)).save(new)
    code, out, err = run("render", "--scene", gbuffer_file, "--settings", old, "--json")
    assert code == 0, err
    assert err.count("ssskit: warning: --settings") == 1 and "old settings layout" in err
    code2, out2, err2 = run("render", "--scene", gbuffer_file, "--settings", new, "--json")
    assert code2 == 0 and "warning" not in err2
    assert json.loads(out)["metrics"] == json.loads(out2)["metrics"]
    assert json.loads(out)["settings"] == json.loads(out2)["settings"]


@pytest.mark.slow  # ~4 s each (a process's start)
@pytest.mark.skipif(os.name != "posix", reason="signals")
@pytest.mark.parametrize("reference", [False, True], ids=["gbuffer", "reference"])
def test_sigterm_while_mitsuba_renders_ends_the_process_at_once(tmp_path, reference):
    """SIGTERM (kill, a CI timeout) while Mitsuba renders a large image: the process ends within a second or
    two with 'ssskit: interrupted' (SIGTERM is handled as Ctrl-C) and status 130, writing nothing (a trial's render
    kept on for 8.5 minutes after SIGTERM: Python's handler waited for the C++ render to return). The G-buffer's render and the path-traced
    reference's chunks (after the G-buffer at 1 spp)."""
    import signal
    import threading
    import time

    import ssskit

    env = dict(os.environ, SSSKIT_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=str(Path(ssskit.__file__).resolve().parents[1]))
    args = ["--spp", "1", "--reference", "--reference-spp", "4096", "--reference-max-spp", "4096"] if reference else ["--spp", "4096"]
    proc = subprocess.Popen([sys.executable, "-m", "ssskit", "render", "--scene", "sphere", "--size", "512x384",
                             "--backend", "numpy", "--out", "x.png", *args], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(iter(proc.stderr.readline, "")), daemon=True)
    reader.start()
    started = "path tracing" if reference else "rendering the sphere G-buffer"
    deadline = time.monotonic() + 120
    while not any(started in line for line in lines) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert proc.poll() is None, "".join(lines)
    time.sleep(1.0)  # into the render
    proc.send_signal(signal.SIGTERM)
    try:  # a hang guard, not a timing: the render itself runs for minutes (without the cancel it ran to its end)
        proc.wait(timeout=60)
    finally:
        proc.kill()  # (when it did not end)
    out = proc.stdout.read()
    reader.join(5)
    err = "".join(lines)
    assert proc.returncode == 130 and err.rstrip().endswith("ssskit: interrupted"), err
    assert "Traceback" not in err and out == ""
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "cache") == []
