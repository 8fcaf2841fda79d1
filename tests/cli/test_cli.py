"""``ssskit``: commands, help, JSON output and the one-line errors of the original commands.

Bad input of every kind added since is in test_bad_input.py; the README's commands in test_readme.py
(which also runs the demo, once for the whole suite).
"""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from ssskit.cli import cli, main


def run(capsys, *args):
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_help_lists_every_command(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0
    listed = out.split("Commands:")[1]
    for name in cli.commands:
        assert f"  {name} " in listed
    assert {"materials", "backends", "profile", "simulate", "xie-c", "kernel", "evaluate", "render", "figures",
            "demo"} <= set(cli.commands)


@pytest.mark.parametrize("name", sorted(cli.commands))
def test_every_command_help_has_an_example(capsys, name):
    code, out, _ = run(capsys, name, "--help")
    assert code == 0
    examples = out.split("Examples:")[1].strip().splitlines()
    assert examples and all(line.strip().startswith(f"ssskit {name}") for line in examples)


@pytest.mark.parametrize("name", sorted(cli.commands))
def test_help_defaults_are_plain_values(capsys, name):
    """Every ``[default: ...]`` shows a value, not click's parenthesised show_default text (render's
    --sigma0 read ``[default: (0.0316 (sigma0^2 = 1e-3))]``)."""
    code, out, _ = run(capsys, name, "--help")
    assert code == 0
    assert "[default: (" not in " ".join(out.split())


def test_figures_help_lists_every_figure(capsys):
    """The README: "the figure names come from the registries, so --help lists what is installed"."""
    from ssskit.figures import FIGURES

    code, out, _ = run(capsys, "figures", "--help")
    assert code == 0
    listed = out.split("Figures (NAME):")[1].split("Options:")[0]
    assert [n.strip() for n in " ".join(listed.split()).split(",")] == list(FIGURES.names())


def test_backends_lists_every_backend(capsys):
    from ssskit.backends import BACKENDS

    code, out, _ = run(capsys, "backends", "--json")
    assert code == 0
    data = json.loads(out)
    assert set(data["backends"]) == set(BACKENDS.names()) and data["default"] in data["backends"]
    for status in data["backends"].values():
        assert isinstance(status["available"], bool) and isinstance(status["details"], str)
        assert status["description"]
    assert data["backends"]["numpy"]["available"]
    code, out, _ = run(capsys, "backends")
    assert code == 0
    for name, status in data["backends"].items():
        line = next(x for x in out.splitlines() if x.startswith(name))
        assert ("not available" in line) == (not status["available"])


def test_kernel_method_options_come_from_the_registry(capsys):
    """Each method's primary parameter is an option of `ssskit kernel`, applying to that method only."""
    from ssskit.kernels import METHODS

    _, out, _ = run(capsys, "kernel", "--help")
    for _, m in METHODS.items():
        if m.primary:
            assert f"--{m.primary.replace('_', '-')} " in out
    code, out, _ = run(capsys, "kernel", "--method", "jimenez2012", "--taps", "17", "--json")
    assert code == 0 and len(json.loads(out)["weights"]) == 17
    code, inline, _ = run(capsys, "kernel", "--method", "jimenez2012:17", "--json")
    assert code == 0 and inline == out


def test_materials_json(capsys):
    code, out, err = run(capsys, "materials", "--json")
    assert code == 0
    data = json.loads(out)  # exactly one JSON object
    assert len(data["materials"]) == 11
    assert data["materials"]["Skin1"]["sigma_a"] == [0.032, 0.17, 0.48]
    assert data["artist_presets"]["production"]["weight"] == 0.6


def test_profile_json_shape(capsys):
    code, out, _ = run(capsys, "profile", "--material", "SKIN1", "--model", "dipole", "--json", "--points", "50")
    assert code == 0
    data = json.loads(out)
    assert len(data["r_mm"]) == 50
    for ch in "RGB":
        assert len(data["channels"][ch]["Rd"]) == 50
        assert data["channels"][ch]["total_Rd"] > 0
    assert data["channels"]["R"]["total_Rd"] == pytest.approx(0.4359563596, rel=1e-9)


def test_profile_from_material_file(capsys, tmp_path):
    f = tmp_path / "jelly.toml"
    f.write_text("sigma_a = 0.01\nsigma_s = 1.0\neta = 1.33\n")
    code, out, _ = run(capsys, "profile", "--material", str(f), "--model", "burley", "--albedo-source", "dipole", "--json")
    assert code == 0
    assert json.loads(out)["name"] == "jelly"


def test_profile_outputs(capsys, tmp_path):
    csv, npz, png = tmp_path / "p.csv", tmp_path / "p.npz", tmp_path / "p.png"
    assert run(capsys, "profile", "--material", "marble", "--out", str(csv), "--plot", str(png))[0] == 0
    table = np.loadtxt(csv, delimiter=",")
    assert table.shape == (256, 4)
    assert png.stat().st_size > 10_000
    assert run(capsys, "profile", "--material", "marble", "--model", "gaussians", "--out", str(npz))[0] == 0
    with np.load(npz) as z:
        assert z["Rd"].shape == (256, 3)
        assert json.loads(str(z["meta"]))["model"] == "gaussians"
    assert not list(tmp_path.glob(".*tmp*"))  # no temporary files left behind


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["profile", "--material", "jade"], "unknown material 'jade'"),
        (["profile", "--material", "skin1", "--model", "multipole"], "Invalid value for '--model'"),
        (["profile", "--model", "dipole"], "--material is required"),
        (["profile", "--material", "skin1", "--out", "x.txt"], "must end in .csv or .npz"),
        (["profile", "--material", "skin1", "--plot", "x.bmp"], "must end in .png"),
        (["profile", "--material", "skin1", "--r-max", "-3"], "--r-max"),
        (["profile", "--material", "skin1", "--model", "burley", "--configuration", "x"], "Burley configuration must be one of"),
        (["materials", "--bogus"], "No such option"),
        (["nonsense"], "No such command"),
    ],
)
def test_bad_input_one_line_exit_2(capsys, tmp_path, monkeypatch, args, fragment):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, *args)
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("ssskit: error: ") and fragment in err
    assert list(tmp_path.iterdir()) == []  # nothing written


@pytest.mark.parametrize(
    "content, fragment",
    [
        ('{"sigma_a": -1, "sigma_s": 1}', "sigma_a must lie in [0, inf) mm^-1, got -1"),
        ('{"sigma_a": 1, "sigma_s": 1, "g": 1.5}', "g must lie in (-1, 1), got 1.5"),
        ('{"sigma_a": 1, "sigma_s": 1, "eta": 0.7}', "eta must lie in [1, inf), got 0.7"),
        ("{not json", "malformed material file"),
    ],
)
def test_bad_material_file(capsys, tmp_path, content, fragment):
    f = tmp_path / "bad.json"
    f.write_text(content)
    out_csv = tmp_path / "out.csv"
    code, out, err = run(capsys, "profile", "--material", str(f), "--out", str(out_csv))
    assert code == 2 and fragment in err and err.count("\n") == 1
    assert not out_csv.exists()


def test_xie_c_json(capsys):
    code, out, _ = run(capsys, "xie-c", "--json", "--points", "20000")
    data = json.loads(out)
    assert data["least_squares"]["c"] == pytest.approx(2.5715, abs=2e-4)
    assert data["minimax"]["max_cdf_error"] < data["least_squares"]["max_cdf_error"]


def test_console_script_error_has_no_traceback():
    proc = subprocess.run(
        [sys.executable, "-c", "import sys; from ssskit.cli import main; sys.exit(main())", "profile", "--material", "nope"],
        capture_output=True, text=True,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and proc.stderr.startswith("ssskit: error:")


def test_only_the_process_own_command_line_freezes_its_objects(monkeypatch, capsys):
    """main() without argv (the ssskit script, python -m ssskit: the process exits next) moves its objects to the
    collector's permanent generation, so the shutdown does not walk them; main(argv) (a caller that goes on)
    leaves the collector alone, errors and all."""
    import gc

    frozen = []
    monkeypatch.setattr(gc, "freeze", lambda: frozen.append(True))
    assert main(["materials"]) == 0 and main(["profile", "--material", "nope"]) == 2 and frozen == []
    monkeypatch.setattr(sys, "argv", ["ssskit", "profile", "--material", "nope"])
    assert main() == 2 and frozen == [True]
    capsys.readouterr()


def test_import_is_light():
    """import ssskit loads no heavy dependency (scipy, matplotlib, numba) and compiles nothing."""
    code = "import sys, ssskit; print(sorted(m for m in ('scipy', 'matplotlib', 'numba', 'click') if m in sys.modules))"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip() == "[]"


def test_simulate_json_and_sweep_identity(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    code, out, _ = run(capsys, "simulate", "--material", "ketchup", "--photons", "20000", "--json", "--no-cache")
    assert code == 0
    single = json.loads(out)
    for key in ("r_mm", "channels", "photons", "seconds", "photons_per_second"):
        assert key in single
    for ch in "RGB":
        c = single["channels"][ch]
        assert len(c["Rd"]) == len(single["r_mm"]) == len(c["Rd_se"])
        assert c["Rsp"] == pytest.approx(((1.3 - 1) / 2.3) ** 2)
        assert c["total_Rd_se"] > 0
    # a two-process sweep gives the same numbers as the single-process run
    code, out, err = run(capsys, "simulate", "--material", "ketchup,skin1", "--photons", "20000", "--jobs", "2", "--json")
    assert code == 0
    # progress on stderr with --json too: the sweep says each material as it finishes
    assert "sweep (2 processes): " in err and "2 of 2 materials" in err, err
    sweep = json.loads(out)["materials"]
    assert sweep["Ketchup"]["channels"]["G"]["Rd"] == single["channels"]["G"]["Rd"]
    npz = tmp_path / "k.npz"
    assert run(capsys, "simulate", "--material", "ketchup", "--photons", "20000", "--out", str(npz))[0] == 0
    with np.load(npz) as z:
        assert z["Rd"].shape == (len(single["r_mm"]), 3)
        assert z["total_Rd"][1] == pytest.approx(single["channels"]["G"]["total_Rd"])


def test_simulate_of_one_batch_says_it_has_no_standard_error(capsys, tmp_path, monkeypatch):
    """1,000 photons in batches of 10,000: one batch, no spread between batches: the text said '± nan'."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    code, out, _ = run(capsys, "simulate", "--material", "skin1", "--channel", "R", "--photons", "1000")
    assert code == 0 and "nan" not in out
    assert "± n/a (one batch: give --photons > --batch-size)" in out
    code, out, _ = run(capsys, "simulate", "--material", "skin1", "--channel", "R", "--photons", "2000",
                       "--batch-size", "1000", "--json")
    assert json.loads(out)["channels"]["R"]["total_Rd_se"] > 0  # two batches: a standard error


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["simulate", "--material", "skin1", "--photons", "0"], "--photons"),
        (["simulate", "--material", "skin1", "--channel", "X"], "--channel"),
        (["simulate", "--material", "skin1", "--out", "x.csv"], "must end in .npz"),
        (["simulate", "--material", "nope"], "unknown material"),
        (["simulate", "--material", "skin1,apple", "--out", "x.npz"], "single material"),
        (["simulate", "--material", "skin1,apple", "--threads", "1"], "--threads applies to a single material, not a sweep"),
        (["simulate", "--material", "skin1", "--threads", "999"], "threads must lie in [1, "),
        (["simulate", "--material", "skin1,apple", "--backend", "gl"], "--backend applies to a single material, not a sweep"),
        (["simulate", "--material", "skin1", "--backend", "cuda"], "--backend"),
    ],
)
def test_simulate_bad_input(capsys, tmp_path, monkeypatch, args, fragment):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, *args)
    assert code == 2 and out == "" and fragment in err and err.count("\n") == 1


def test_simulate_backend_gl_selects_the_glsl_engine(capsys, tmp_path, monkeypatch):
    """``--backend gl``: the GLSL engine's run (its own streams: not numba's numbers; cached apart); with
    no OpenGL 4.3 context it is one line on stderr and exit status 2, before any work."""
    from ssskit.profiles.montecarlo import engine_gl

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    args = ("simulate", "--material", "skin1", "--channel", "R", "--photons", "20000", "--json")
    ok, _ = engine_gl.available()
    if not ok:
        code, out, err = run(capsys, *args, "--backend", "gl")
        assert code == 2 and out == "" and "gl Monte Carlo engine cannot run here" in err and err.count("\n") == 1
        pytest.skip("gl engine not available: the error path was checked")
    code, out, _ = run(capsys, *args, "--backend", "gl")
    assert code == 0
    gl = json.loads(out)["channels"]["R"]
    code, out, _ = run(capsys, *args)
    numba = json.loads(out)["channels"]["R"]
    assert gl["total_Rd"] != numba["total_Rd"]
    assert abs(gl["total_Rd"] - numba["total_Rd"]) <= 4 * math.hypot(gl["total_Rd_se"], numba["total_Rd_se"])
    assert json.loads(run(capsys, *args, "--backend", "gl")[1])["channels"]["R"]["total_Rd"] == gl["total_Rd"]


def test_the_group_lists_commands_without_importing_them():
    """``ssskit --help`` lists every command from ssskit.cli.COMMANDS without importing a command module (no
    numpy, no pipeline: it starts in a few tens of ms), and the listed texts are the commands' own."""
    import click

    from ssskit.cli import COMMANDS, LazyCommands

    code = ("import sys; from ssskit.cli import main; main(['--help']); "
            "print(sorted(m for m in ('numpy', 'ssskit.pipeline', 'ssskit.cli.render', 'numba') if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip().splitlines()[-1] == "[]"
    lazy = LazyCommands(COMMANDS)
    for name in COMMANDS:
        cmd = cli.commands[name]
        assert cmd.name == name
        for limit in (40, 70, 100):
            assert lazy.short_help(name, limit) == cmd.get_short_help_str(limit), name
    ctx = click.Context(cli)
    assert set(cli.list_commands(ctx)) == set(COMMANDS)


@pytest.mark.parametrize("preset", [None, "2"])
def test_commands_run_one_library_thread_unless_told(preset):
    """The CLI sets OpenBLAS, MKL and OpenMP to one thread before numpy loads, unless the user set a count:
    ssskit's small matrices and FLIP's test signals ran 1.7-2.4x slower on two threads
    (ssskit.compute.workers.one_library_thread). Where numpy's bundled OpenBLAS names its thread count, the
    loaded library says so too."""
    import ast
    import os

    code = ("import ctypes, os\n"
            "from ssskit.cli import main\n"
            "main(['materials', '--json'])\n"
            "import numpy\n"
            "libs = {l.split()[-1] for l in open('/proc/self/maps') if 'openblas' in l.lower()} "
            "if os.path.exists('/proc/self/maps') else set()\n"
            "found = [getattr(ctypes.CDLL(p), n)() for p in libs for n in ('scipy_openblas_get_num_threads64_',"
            " 'openblas_get_num_threads') if hasattr(ctypes.CDLL(p), n)]\n"
            "print(os.environ['OPENBLAS_NUM_THREADS'], os.environ['MKL_NUM_THREADS'], os.environ['OMP_NUM_THREADS'],"
            " found)\n")
    from ssskit.compute.workers import LIBRARY_THREADS

    env = {k: v for k, v in os.environ.items() if k not in LIBRARY_THREADS}
    if preset is not None:
        env["OPENBLAS_NUM_THREADS"] = preset
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    blas, mkl, omp, found = out.strip().splitlines()[-1].split(" ", 3)
    assert (blas, mkl, omp) == (preset or "1", "1", "1")
    if preset is None and found != "[]":
        assert set(ast.literal_eval(found)) == {1}  # the loaded OpenBLAS runs one thread


def _option_helps():
    for name, command in sorted(cli.commands.items()):
        for param in command.params:
            yield name, param.name, getattr(param, "help", None) or ""


def test_help_pointers_resolve():
    """An option's help that sends the reader to a section names the file that holds it: ``docs/X.md, 'text'``
    where docs/X.md has that text, ``'Section' in the README`` where the README has that heading (render's
    --scene pointed at a README section 'G-buffer EXR' that lives in docs/commands.md; kernel's --method at a
    README section 'Methods' that does not exist)."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    readme_headings = {line.lstrip("#").strip() for line in (root / "README.md").read_text().splitlines()
                       if line.startswith("#")}
    seen = 0
    for command, option, text in _option_helps():
        for doc, quoted in re.findall(r"(docs/[\w.-]+\.md), '([^']+)'", text):
            seen += 1
            assert (root / doc).is_file() and quoted in (root / doc).read_text(), (command, option, doc, quoted)
        for quoted in re.findall(r"'([^']+)' in the README", text):
            assert quoted in readme_headings, (command, option, quoted)
    assert seen >= 2  # render's --scene and kernel's --method
