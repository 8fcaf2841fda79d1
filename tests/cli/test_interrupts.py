"""SIGINT at each stage of ``ssskit render``: exit status 130 with nothing written and nothing cached; and, inherited
as ignored (a script's background job), a run that completes with the result of an uninterrupted one (issue 34).

The in-process tests send the signal from the command's own progress line of a stage (for a Mitsuba stage: from
inside the render that follows it, when Mitsuba logs "Starting render job"), so they hold on any machine at any
load. The subprocess test sends real signals to a real process group, found by its stderr lines; its only time
limit is a hang guard."""

import contextlib
import os
import re
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest

from ssskit import progress as progress_module
from ssskit.cli import main
from tests.scenes.test_interrupts import sigint_handled_by, sigint_inside_renders

pytestmark = pytest.mark.skipif(os.name != "posix", reason="signals")

HANG_S = 1800  # a guard against a hang, never a measure of speed

SMALL = ["render", "--scene", "slab", "--size", "48x36", "--spp", "4"]
ADAPTIVE = ["render", "--scene", "slab", "--size", "48x36", "--pass", "burley-adaptive", "--frames", "2",
            "--budget", "2:4", "--limit-spp", "8"]
REFERENCE = ["--reference", "--reference-spp", "8", "--reference-max-spp", "16"]

# (arguments, the progress line that starts the stage, whether a Mitsuba render follows it)
STAGES = {
    "gbuffer": ([*SMALL, "--no-exact"], r"rendering the slab G-buffer", True),
    "separable pass": ([*SMALL, "--no-exact"], r"separable pass:", False),
    "burley pass": ([*SMALL, "--pass", "burley", "--no-exact"], r"Burley pass:", False),
    "reference": ([*SMALL, "--no-exact", *REFERENCE], r"path tracing slab \(", True),
    "adaptive gbuffer": (ADAPTIVE, r"G-buffer slab frame 1", True),
    "adaptive reference": (ADAPTIVE, r"reference 1/", False),
    "adaptive frame": (ADAPTIVE, r"adaptive frame 2/", False),  # frame 1's PNGs were written into --frames-dir
}


@contextlib.contextmanager
def sigint_at(line, in_render):
    """Within the block, the progress line (:func:`ssskit.progress.noted`: every line the CLI prints) matching
    ``line`` sends SIGINT to this process: at once, or from inside the Mitsuba render that follows
    (``in_render``). Yields the list of lines it fired at."""
    fired = []
    renders = contextlib.ExitStack()

    def at(msg):
        if not fired and re.search(line, msg):
            fired.append(msg)
            if in_render:
                renders.enter_context(sigint_inside_renders())
            else:
                os.kill(os.getpid(), signal.SIGINT)

    with renders, progress_lines_call(at):
        yield fired


@contextlib.contextmanager
def progress_lines_call(fn):
    """Within the block each progress line is also passed to ``fn`` (in the thread that prints it)."""
    real = progress_module.noted

    def noted(msg):
        real(msg)
        fn(msg)

    progress_module.noted = noted
    try:
        yield
    finally:
        progress_module.noted = real


@pytest.mark.parametrize("stage", list(STAGES))
def test_sigint_at_each_stage_exits_130_with_nothing_written(stage, tmp_path, monkeypatch, capsys):
    args, line, in_render = STAGES[stage]
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    with sigint_handled_by(signal.default_int_handler), sigint_at(line, in_render) as fired:
        code = main([*args, "--out", "out.exr", "--json"]
                    + (["--frames-dir", "frames"] if "adaptive" in stage else ["--save-gbuffer", "gb.exr"]))
    out, err = capsys.readouterr()
    assert fired, err  # the stage came
    assert code == 130 and out == "" and err.rstrip().endswith("ssskit: interrupted"), err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "cache") == []
    cached = [p for p in (tmp_path / "cache").rglob("*") if p.is_file()] if (tmp_path / "cache").exists() else []
    if stage == "reference":
        assert not [p for p in cached if "reference" in p.parts], cached


def _exr_layers(path):
    from ssskit.io import read_exr

    _, layers = read_exr(path)
    return layers


def test_an_ignored_sigint_inside_every_stage_changes_nothing(tmp_path, monkeypatch, capsys):
    """SIGINT ignored (as a script's background job inherits it), sent from inside the G-buffer and reference
    renders and the separable pass of one run: exit status 0 and the images of an uninterrupted run."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    args = [*SMALL, "--no-exact", *REFERENCE]
    assert main([*args, "--out", str(tmp_path / "clean.exr")]) == 0
    for p in (tmp_path / "cache").rglob("*.npz"):
        p.unlink()  # the reference renders again
    capsys.readouterr()

    def at(msg):  # a signal at every stage's line, and inside the first three renders
        if re.search(r"rendering the|separable pass|path tracing slab \(", msg):
            os.kill(os.getpid(), signal.SIGINT)

    with sigint_handled_by(signal.SIG_IGN), sigint_inside_renders(times=3) as hits, progress_lines_call(at):
        code = main([*args, "--out", str(tmp_path / "hit.exr")])
    err = capsys.readouterr().err
    assert code == 0 and len(hits) == 3, err
    clean, hit = _exr_layers(tmp_path / "clean.exr"), _exr_layers(tmp_path / "hit.exr")
    assert sorted(clean) == sorted(hit)
    for name in clean:
        np.testing.assert_allclose(hit[name], clean[name], rtol=1e-6, atol=1e-7, err_msg=name)


def _run_signalled(args, cwd, env, line, ignore):
    """``ssskit ARGS`` in a process group of its own, SIGINT to the group once the stderr line ``line`` appears
    (ignored: SIGINT set to ignored before exec, as a shell does for a background job, and sent every 0.1 s from
    then on until the process ends). Returns (exit status, stderr)."""
    proc = subprocess.Popen([sys.executable, "-m", "ssskit.cli", *args], cwd=cwd, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=(lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if ignore else None)
    guard = threading.Timer(HANG_S, lambda: os.killpg(proc.pid, signal.SIGKILL))
    guard.start()

    def keep_sending():
        while proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGINT)
            threading.Event().wait(0.1)

    err, fired = [], False
    try:
        for text in proc.stderr:
            err.append(text)
            if not fired and re.search(line, text):
                fired = True
                if ignore:
                    threading.Thread(target=keep_sending, daemon=True).start()
                else:
                    os.killpg(proc.pid, signal.SIGINT)
        code = proc.wait()
    finally:
        guard.cancel()
    assert fired, "".join(err)
    return code, "".join(err)


def test_real_sigint_as_ctrl_c_and_as_a_background_job(tmp_path):
    """Real signals to a real process group. Ctrl-C (SIGINT to the group) during the G-buffer: 130, nothing
    written. The same run started with SIGINT ignored and signalled every 0.1 s from its G-buffer to its end
    (Mitsuba logged "Received interrupt signal, winding down.." and ssskit wrote the partial image with exit 0):
    exit 0, no wind-down, and the image of an uninterrupted run."""
    env = dict(os.environ, SSSKIT_CACHE_DIR=str(tmp_path / "cache"), SSSKIT_PROGRESS="lines")
    args = [*SMALL[:4], "128x96", "--spp", "64", "--no-exact", *REFERENCE]
    assert main([*args, "--out", str(tmp_path / "clean.exr")]) == 0
    for p in (tmp_path / "cache").rglob("*.npz"):
        p.unlink()
    code, err = _run_signalled([*args, "--out", "ctrl-c.exr"], tmp_path, env, r"rendering the slab G-buffer", False)
    assert code == 130 and "ssskit: interrupted" in err and "Traceback" not in err, err
    assert not (tmp_path / "ctrl-c.exr").exists() and not list((tmp_path / "cache").rglob("*.npz"))
    code, err = _run_signalled([*args, "--out", "job.exr"], tmp_path, env, r"rendering the slab G-buffer", True)
    assert code == 0 and "winding down" not in err and "Traceback" not in err, err
    clean, job = _exr_layers(tmp_path / "clean.exr"), _exr_layers(tmp_path / "job.exr")
    for name in clean:
        np.testing.assert_allclose(job[name], clean[name], rtol=1e-6, atol=1e-7, err_msg=name)


DEMO_STAGES = {"gbuffer": (r"rendering the sphere G-buffer", True), "separable pass": (r"separable pass:", False),
               "reference": (r"path tracing sphere \(", True)}


@pytest.mark.parametrize("stage", list(DEMO_STAGES))
def test_sigint_in_each_stage_of_a_demo_section(stage, tmp_path, monkeypatch, capsys):
    """``ssskit demo`` (its screen-space section alone, in-process) interrupted in the section's G-buffer render,
    its separable pass and its path-traced reference: 130, no output or staging folder, and neither the section
    nor the reference cached. (Its worker processes meet real signals in test_bad_input's demo test and in
    benchmarks/sigint_matrix.py.)"""
    from ssskit import report

    line, in_render = DEMO_STAGES[stage]
    monkeypatch.setattr(report, "SECTIONS", [s for s in report.SECTIONS if s[0] == "screenspace"])
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    with sigint_handled_by(signal.default_int_handler), sigint_at(line, in_render) as fired:
        code = main(["demo", "--jobs", "1", "--material", "skin1", "--out", "d"])
    err = capsys.readouterr().err
    assert fired, err
    assert code == 130 and err.rstrip().endswith("ssskit: interrupted") and "Traceback" not in err, err
    assert [p.name for p in tmp_path.iterdir() if p.name != "cache"] == []
    cached = [p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file()]
    assert not [p for p in cached if "demo" in p.parts or "reference" in p.parts], cached
