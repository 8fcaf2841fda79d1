"""Bad input: exactly one stderr line ``ssskit: error: ...``, exit status 2, nothing on stdout, nothing
written, no traceback -- and every check happens before any work starts."""

import os
import re
import subprocess
import sys

import pytest

#: files each test finds in its (empty, current) folder: a regular file, a file named like a G-buffer
#: (never read: every check below fails before the G-buffer is loaded) and a folder named x.exr
SETUP = {"f.txt": "not a folder", "g.exr": "not read", "m.json": '{"sigma_a": 0.01, "sigma_s": 1.0}',
         # materials outside every model's domain, or outside some (ssskit.profiles.domain)
         "eta4.json": '{"sigma_a": 0.1, "sigma_s": 1.0, "eta": 4}',
         "eta1e6.json": '{"sigma_a": 0.1, "sigma_s": 1.0, "eta": 1e6}',
         "huge.json": '{"sigma_a": 1e300, "sigma_s": 1e300}',
         "tiny.json": '{"sigma_a": 1e-300, "sigma_s": 1e-300}',
         "absorber.json": '{"sigma_a": [0.5, 0.6, 0.7], "sigma_s": 0, "name": "absorber"}',
         "absorbers.toml": "[[layers]]\nsigma_a = 0.1\nsigma_s = 0\nthickness_mm = 0.5\n[[layers]]\nsigma_a = 0.1\nsigma_s = 0\n"}


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    for name, text in SETUP.items():
        (tmp_path / name).write_text(text)
    (tmp_path / "x.exr").mkdir()
    return tmp_path


def _contents(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def one_error_line(run, folder, args, fragment):
    before = _contents(folder)
    code, out, err = run(*args)
    assert code == 2, err
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("ssskit: error: "), err
    assert fragment in err, err
    assert _contents(folder) == before  # nothing written
    return err


BAD = [
    # output folders that cannot be written: checked before any work
    (["figures", "fig2", "--model", "dipole", "--out", "f.txt/figs"], "'f.txt' is not a folder"),
    (["demo", "--photons", "5000", "--out", "f.txt/demo"], "'f.txt' is not a folder"),
    (["demo", "--out", "f.txt"], "is a file, not a folder"),
    (["profile", "--material", "skin1", "--out", "f.txt/p.csv"], "'f.txt' is not a folder"),
    (["profile", "--material", "skin1", "--plot", "f.txt/p.png"], "cannot write --plot 'f.txt/p.png'"),
    # materials
    (["simulate", "--material", ",,"], "no material given"),
    (["simulate", "--material", " , "], "no material given"),
    (["profile", "--material", ""], "the material name is empty"),
    (["render", "--scene", "slab", "--material", ""], "the material name is empty"),
    (["profile", "--model", "deon2007", "--material", "marble"], "takes no --material"),
    (["figures", "--model", "deon2007", "--material", "marble"], "takes no --material"),
    (["profile", "--material", "skin1", "--model", "dipole", "--photons", "5000"], "--photons applies to --model burley or montecarlo, not --model dipole"),
    (["profile", "--material", "skin1", "--model", "burley", "--gaussians", "3"], "--gaussians applies to --model gaussians, not --model burley"),
    (["profile", "--material", "skin1", "--model", "dipole", "--albedo-source", "dipole"], "--albedo-source applies to --model burley, not --model dipole"),
    (["profile", "--material", "skin1", "--model", "dipole", "--grid-fraction", "0.999"], "--grid-fraction applies to --model montecarlo, not --model dipole"),
    # accepted silently: the dipole's A runs no Monte Carlo, the GLSL engine no numba threads
    (["profile", "--material", "skin1", "--model", "burley", "--albedo-source", "dipole", "--photons", "5000"],
     "--photons applies to --albedo-source montecarlo, not --albedo-source dipole"),
    (["simulate", "--material", "skin1", "--backend", "gl", "--threads", "2"], "--threads applies to --backend numba, not --backend gl"),
    (["render", "--scene", "slab", "--reference", "--reference-rel-se", "0"], "--reference-rel-se"),
    (["render", "--scene", "slab", "--reference", "--reference-max-spp", "0"], "--reference-max-spp"),
    (["simulate", "--material", "skin1,marble", "--grid-fraction", "0.999"], "single material"),
    (["simulate", "--material", "skin1", "--grid-fraction", "1.5"], "--grid-fraction"),
    (["simulate", "--material", "skin1", "--roughness", "1.5"], "--roughness"),
    (["profile", "--material", "skin1", "--model", "dipole", "--roughness", "0.15"], "--roughness applies to --model montecarlo, not --model dipole"),
    # simulate
    (["simulate", "--material", "skin1", "--resume", "--restart"], "exclude each other"),
    (["simulate", "--material", "skin1", "--restart", "--no-cache"], "cannot be combined with --no-cache"),
    (["simulate", "--material", "skin1", "--seed", "-1"], "seed"),
    (["simulate", "--material", "skin1", "--photons", "999"], "--photons"),
    # photons: one range everywhere
    (["profile", "--material", "skin1", "--model", "montecarlo", "--photons", "100"], "1000<=x<=10000000000"),
    (["kernel", "--material", "skin1", "--method", "svd", "--photons", str(10**11)], "1000<=x<=10000000000"),
    (["demo", "--photons", "999"], "1000<=x<=10000000000"),
    # kernel methods and their parameters
    (["kernel", "--material", "skin1", "--method", "gaussians", "--rank", "3"], "--rank applies to --method svd or svd_l1 or preintegrated_svd, not --method gaussians"),
    # click >= 8.3 took an explicit default=None for a value: the missing --method became 'None'
    (["kernel", "--material", "skin1", "--out", "k.json"], "Missing option '--method'"),
    # a material that does not scatter has no profile (it failed late with NaN kernels, or exited 0)
    (["kernel", "--material", "absorber.json", "--method", "svd"], "sigma_s in channel R of 'absorber' must lie in (0, inf) mm^-1, got 0 (a scattering material"),
    (["render", "--scene", "slab", "--material", "absorber.json", "--pass", "burley"], "got 0 (a scattering material"),
    (["export", "--material", "absorber.json", "--format", "glsl-shader", "--pass", "transmission", "--out", "t.comp"],
     "the mcml transmission model's sigma_s in channel"),
    (["profile", "--material", "absorber.json", "--model", "dipole"], "the dipole model's sigma_s in channel"),
    # simulate exited 0 with 'total Rd = 0.00000 +- nan' and wrote the file (every backend, and in a sweep)
    (["simulate", "--material", "absorber.json", "--photons", "1000", "--out", "o.npz"],
     "the montecarlo model's sigma_s in channel R of 'absorber' must lie in (0, inf) mm^-1, got 0"),
    (["simulate", "--material", "absorbers.toml", "--photons", "1000", "--backend", "gl"],
     "the montecarlo model's sigma_s in channel"),
    (["simulate", "--material", "skin1,absorber.json", "--photons", "1000", "--jobs", "2"],
     "the montecarlo model's sigma_s in channel"),
    (["kernel", "--material", "skin1", "--method", "preintegrated", "--rank", "3"], "--rank applies to --method svd or svd_l1 or preintegrated_svd, not --method preintegrated"),
    (["kernel", "--material", "skin1", "--method", "svd:3", "--rank", "2"], "give the rank once"),
    (["kernel", "--material", "skin1", "--method", "guided", "--k", "9"], "--k: guide exponent"),
    (["kernel", "--material", "skin1", "--method", "svd", "--rank", "two"], "--rank: expected an integer"),
    (["kernel", "--method", "artist", "--preset", "nope"], "artist preset must be one of"),
    (["kernel", "--method", "artist:fit"], "needs a profile"),
    (["evaluate", "--material", "skin1", "--methods", ","], "no kernel method given"),
    (["evaluate", "--material", "skin1", "--methods", "svd:0"], "SVD rank"),
    # SSIM's 11-px window: refused before the profile and the kernels, not after the first method
    (["evaluate", "--material", "skin1", "--model", "dipole", "--size", "8"], "--size 8: SSIM needs images of at least 11 x 11"),
    # render: G-buffer files
    (["render", "--scene", "g.exr", "--size", "64x64"], "--size applies to a built-in scene"),
    (["render", "--scene", "g.exr", "--spp", "4"], "--spp applies to a built-in scene"),
    (["render", "--scene", "g.exr", "--out", "g.exr"], "--out 'g.exr' would overwrite the input 'g.exr'"),
    (["render", "--scene", "g.exr", "--out", "./sub/../g.exr"], "would overwrite the input"),
    (["render", "--scene", "g.exr", "--save-gbuffer", "g.exr"], "--save-gbuffer 'g.exr' would overwrite the input"),
    (["render", "--scene", "slab", "--out", "a.exr", "--save-gbuffer", "a.exr"], "--save-gbuffer 'a.exr' is also the --out file"),
    (["render", "--scene", "g.exr", "--reference"], "reference applies to a built-in or mesh scene, not a G-buffer (it has no scene"),
    (["kernel", "--material", "m.json", "--model", "dipole", "--method", "artist", "--out", "m.json"],
     "would overwrite the input 'm.json'"),
    (["render", "--scene", "x.exr"], "'x.exr' is a directory"),
    (["render", "--scene", "missing.exr"], "does not exist"),
    (["render", "--scene", "f.txt"], "scene 'f.txt': its format must be one of .obj, .ply, .glb, .gltf, .toml, .exr, got '.txt'"),
    (["render", "--scene", "teapot"], "unknown scene 'teapot'"),
    # render: settings, each checked by RenderSettings / PassSettings before any work
    (["render", "--scene", "slab", "--size", "0x0"], "--size: width must lie in [8, 8192] px, got 0"),
    (["render", "--scene", "slab", "--size", "100000x100000"], "--size: width must lie in [8, 8192] px, got 100000"),
    (["render", "--scene", "slab", "--size", "64x"], "must look like 256x192"),
    (["render", "--scene", "slab", "--jitter", "nan"], "--jitter: jitter must lie in [0, 1], got nan"),
    (["render", "--scene", "slab", "--jitter", "2"], "--jitter"),
    (["render", "--scene", "slab", "--kernel", "svd:0"], "SVD rank must lie in [1, 64], got 0"),
    (["render", "--scene", "slab", "--kernel", "guided:9"], "guide exponent k"),
    (["render", "--scene", "slab", "--kernel", "jimenez2012:11", "--taps", "7"], "give the number of taps once"),
    (["render", "--scene", "slab", "--taps", "6"], "--taps: taps must be an odd integer, got 6"),
    (["render", "--scene", "slab", "--taps", "0"], "--taps"),
    (["render", "--scene", "slab", "--spp", "0"], "--spp: spp must lie in"),
    (["render", "--scene", "slab", "--seed", "-1"], "--seed: seed must lie in"),
    (["render", "--scene", "slab", "--frame", "-1"], "--frame: frame must lie in"),
    (["render", "--scene", "slab", "--reference-spp", "0"], "--reference-spp"),
    (["render", "--scene", "slab", "--backend", "cuda"], "unknown backend 'cuda'"),
    (["render", "--scene", "slab", "--depth-mode", "sideways"], "'sideways' is not one of"),
    (["render", "--scene", "slab", "--tap-method", "random"], "'random' is not one of"),
    (["render", "--scene", "slab", "--model", "multipole"], "unknown profile model 'multipole'"),
    (["render", "--scene", "slab", "--settings", "f.txt"], "must end in .toml or .json"),
    (["render", "--scene", "slab", "--settings", "none.toml"], "does not exist"),
    (["figures", "fig99", "--model", "dipole"], "unknown figure 'fig99'"),
    # kept from the earlier kernel / evaluate / render tests
    (["kernel", "--method", "svd"], "--material is required for --method svd"),
    (["kernel", "--method", "nosuch", "--material", "skin1"], "unknown kernel method 'nosuch'"),
    (["kernel", "--method", "svd", "--material", "skin1", "--taps", "7"], "--taps applies to --method jimenez2012, not --method svd"),
    (["kernel", "--method", "svd", "--material", "skin1", "--size", "50"], "--size must be an odd integer, got 50"),
    (["kernel", "--method", "jimenez2012", "--taps", "10"], "odd"),
    (["kernel", "--method", "jimenez2012", "--out", "k.txt"], "must end in .npz or .json"),
    (["kernel", "--method", "jimenez2012", "--model", "dipole"], "--model applies to --method svd or svd_l1 or gaussians or preintegrated or preintegrated_svd or artist or guided or burley_fit, not --method jimenez2012"),
    (["evaluate", "--material", "skin1", "--signal", "plaid"], "unknown signal 'plaid'"),
    (["evaluate", "--material", "skin1", "--methods", "svd:x"], "integer"),
    (["evaluate", "--model", "dipole"], "--material is required"),
    (["render", "--scene", "slab", "--taps", "4"], "odd"),
    (["render", "--scene", "slab", "--size", "big"], "--size"),
    (["render", "--scene", "slab", "--kernel", "nope"], "unknown kernel method 'nope'"),
    (["render", "--scene", "slab", "--out", "x.tif"], "must end in .exr or .png"),
    (["render", "--scene", "slab", "--save-gbuffer", "x.png"], "must end in .exr"),
    # a material the built-in leaf (Apple, named by its file) would ignore: it rendered Apple labelled Marble
    (["render", "--scene", "leaf", "--material", "marble", "--size", "16x12", "--out", "leaf.exr"],
     "--material marble applies to no object of the scene 'leaf'"),
]


@pytest.mark.parametrize("args, fragment", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_input(run, workdir, args, fragment):
    one_error_line(run, workdir, args, fragment)


#: the inputs a newcomer's trial found still let through (issue 23), each failing before its fix
FIRST_HOUR = [
    # physically meaningless materials: each model's valid domain, named
    (["profile", "--material", "eta4.json", "--model", "dipole"], "the dipole model's relative index eta must lie in [1, 2.5]"),
    (["profile", "--material", "eta1e6.json", "--model", "gaussians"], "the gaussians (fitted to the dipole) model"),
    (["profile", "--material", "eta1e6.json", "--model", "montecarlo"], "the montecarlo model's relative index eta must lie in [1, 4]"),
    (["profile", "--material", "huge.json", "--out", "p.csv"], "the montecarlo model's transport mean free path"),
    (["profile", "--material", "tiny.json", "--model", "burley", "--out", "p.csv"], "the burley model's transport"),
    (["simulate", "--material", "huge.json"], "the montecarlo model's transport mean free path"),
    (["kernel", "--material", "tiny.json", "--model", "dipole", "--method", "svd"], "the dipole model's transport"),
    (["evaluate", "--material", "eta4.json", "--model", "dipole"], "the dipole model's relative index eta must lie in"),
    (["profile", "--material", "skin1", "--r-max", "1e308", "--out", "p.csv"], "--r-max must lie in (0, 1e+07] mm, got 1e+308 (10 times"),
    # options accepted and ignored, or computed twice
    (["kernel", "--method", "jimenez2012", "--material", "skin1"], "--material applies to --method svd or svd_l1 or gaussians or preintegrated or preintegrated_svd or artist or guided or burley_fit, not --method jimenez2012"),
    (["evaluate", "--material", "skin1", "--methods", "svd,svd:1"], "'svd:1' names the same kernel as 'svd'"),
    (["evaluate", "--material", "skin1", "--methods", "guided:0,preintegrated,guided:0"], "names the same kernel"),
    (["figures", "fig2", "fig2", "--model", "dipole"], "figure fig2 named more than once"),
    # paths
    (["figures", "fig2", "--model", "dipole", "--out", ""], "--out is empty"),
    (["demo", "--out", ""], "--out is empty"),
    # render: options accepted and ignored (the settings tree of issue 22)
    (["render", "--scene", "slab", "--model", "deon2007", "--material", "marble"], "--model deon2007 is a fixed preset"),
    (["render", "--scene", "slab", "--reference", "--reference-spp", "64", "--reference-max-spp", "32"],
     "--reference-max-spp: reference_max_spp must lie in [64, 1048576], got 32 (the reference renders at least "
     "reference_spp samples"),
    (["render", "--scene", "slab", "--model", "dipole", "--photons", "5000"], "--photons applies to --model burley or montecarlo, not --model dipole"),
    (["render", "--scene", "slab", "--reference-rel-se", "0.02"], "--reference-rel-se: reference_rel_se applies to reference true, not reference false"),
    (["render", "--scene", "slab", "--material", "eta4.json", "--model", "dipole"], "the dipole model's relative index eta must lie in"),
]


@pytest.mark.parametrize("args, fragment", FIRST_HOUR, ids=[" ".join(a) for a, _ in FIRST_HOUR])
def test_bad_input_of_the_first_hour(run, workdir, args, fragment):
    one_error_line(run, workdir, args, fragment)


@pytest.mark.parametrize("content, fragment", [
    ("taps = 8\n", "taps must be an odd integer, got 8"),
    ("tapz = 7\n", "unknown setting(s) tapz"),
    ("[sss]\njitter = 3\n", "jitter must lie in [0, 1], got 3"),
    ("kernel = 'svd:0'\n", "SVD rank"),
    ("reference = true\n", "reference applies to a built-in or mesh scene, not a G-buffer (it has no scene"),
    ("taps = \n", "malformed settings file"),
])
def test_bad_settings_file(run, workdir, content, fragment):
    (workdir / "s.toml").write_text(content)
    one_error_line(run, workdir, ["render", "--scene", "g.exr", "--settings", "s.toml"], fragment)


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes into read-only folders")
@pytest.mark.parametrize("command", [["figures", "fig2", "--model", "dipole"], ["demo", "--photons", "5000"],
                                     ["profile", "--material", "skin1"]])
def test_read_only_folder(run, workdir, command):
    ro = workdir / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        target = "ro/p.csv" if command[0] == "profile" else "ro/out"
        one_error_line(run, workdir, [*command, "--out", target], "Permission denied")
    finally:
        ro.chmod(0o700)


def _immutable(path):
    """Make the existing file ``path`` immutable (chattr +i: nobody, root included, may replace it); returns how
    to undo it, or skips where that cannot be done here (not root, or a filesystem without the flag)."""
    import shutil
    import subprocess

    if os.name != "posix" or os.geteuid() != 0 or shutil.which("chattr") is None:
        pytest.skip("chattr +i needs root and the chattr tool")
    if subprocess.run(["chattr", "+i", str(path)], capture_output=True).returncode:
        pytest.skip("chattr +i is not available on this filesystem")
    return lambda: subprocess.run(["chattr", "-i", str(path)], check=True)


@pytest.mark.parametrize("command, target", [(["profile", "--material", "skin1", "--model", "dipole"], "p.csv"),
                                             (["render", "--scene", "slab", "--backend", "numpy", "--size", "16x12"],
                                              "r.png")])
def test_an_existing_output_that_cannot_be_replaced_is_refused_before_any_work(run, workdir, command, target):
    """The trial's immutable render output was found only after the render: now before it, in one line."""
    path = workdir / target
    path.write_bytes(b"old")
    undo = _immutable(path)
    try:
        one_error_line(run, workdir, [*command, "--out", target], f"cannot write --out '{target}': the existing file "
                       "cannot be replaced (it is immutable")
        assert path.read_bytes() == b"old"
    finally:
        undo()


def test_a_read_only_output_is_replaced(run, workdir):
    """A read-only (0444) output in a writable folder is replaced, as the atomic write's rename allows: refusing
    it (an earlier version of the check above did) would refuse what works."""
    path = workdir / "p.csv"
    path.write_bytes(b"old")
    path.chmod(0o444)
    code, _, err = run("profile", "--material", "skin1", "--model", "dipole", "--out", "p.csv")
    assert code == 0, err
    assert path.read_bytes() != b"old"


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.path.isdir("/sys/kernel"),
                    reason="needs Linux's sysfs, where nobody (root included) may create files")
@pytest.mark.parametrize("command", [["figures", "fig2", "--model", "dipole"], ["demo", "--photons", "5000"]])
def test_unwritable_folder(run, workdir, command):
    one_error_line(run, workdir, [*command, "--out", "/sys/kernel/ssskit-out"], "cannot write --out")


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.path.isdir("/proc/self"),
                    reason="needs Linux's procfs, where creating a file fails with ENOENT")
def test_a_folder_that_exists_but_takes_no_files_is_named(run, workdir):
    """/proc exists, yet a file created in it fails with "No such file or directory": the message says the
    folder cannot be written, not that it is missing."""
    err = one_error_line(run, workdir, ["render", "--scene", "slab", "--backend", "numpy", "--out", "/proc/x.exr"],
                         "cannot write --out '/proc/x.exr': the folder '/proc' cannot be written")
    assert "No such file" not in err


def test_truncated_gbuffer_is_one_line(gbuffer_file, tmp_path, capfd):
    """A truncated EXR: one line, and none from OpenEXR's C++ library either (hence capfd)."""
    from ssskit.cli import main

    bad = tmp_path / "truncated.exr"
    bad.write_bytes(gbuffer_file.read_bytes()[:2000])
    code = main(["render", "--scene", str(bad), "--backend", "numpy", "--out", str(tmp_path / "o.png")])
    out, err = capfd.readouterr()
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("ssskit: error: ") and "truncated.exr" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["truncated.exr"]


def test_bad_input_in_a_subprocess_has_no_traceback(tmp_path):
    """The console script itself: one line, status 2, through a real process (C++ output included)."""
    proc = subprocess.run([sys.executable, "-m", "ssskit.cli", "render", "--scene", "slab", "--jitter", "nan"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("ssskit: error: --jitter")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_FSIZE as a stand-in for a full disk")
def test_a_full_disk_names_the_file_and_leaves_no_partial_output(tmp_path):
    """A write that fails half-way (here RLIMIT_FSIZE: fig2's PNG of ~50 KB fits under 100 KB, fig4's
    ~140 KB does not) is one error line naming the file, and no figure is left (fig2 was before)."""
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))  # Python ignores SIGXFSZ: writes fail

    env = dict(os.environ, SSSKIT_CACHE_DIR=str(tmp_path / "cache"))
    proc = subprocess.run([sys.executable, "-m", "ssskit.cli", "figures", "fig2", "fig4", "--model", "dipole",
                           "--out", "figs"], capture_output=True, text=True, cwd=tmp_path, env=env, preexec_fn=limit)
    lines = proc.stderr.splitlines()
    assert proc.returncode == 2 and proc.stdout == "", proc.stderr
    assert lines[-1].startswith("ssskit: error: cannot write 'figs/fig4_svd_ranks.png': "), proc.stderr
    assert all(line.startswith("  ") for line in lines[:-1])  # the rest is progress
    assert [p.name for p in tmp_path.iterdir() if p.name != "cache"] == []


def test_an_interrupted_simulation_speaks_the_command_lines_terms(run, workdir, monkeypatch):
    """Ctrl-C in ``simulate``: the message names ``ssskit simulate`` and --resume, not the library's
    ``resume (CLI --resume)``."""
    from ssskit.profiles.montecarlo import engine_numba

    real, calls = engine_numba.run_batches, []

    def interrupted(*args):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args)

    monkeypatch.setattr(engine_numba, "run_batches", interrupted)
    code, out, err = run("simulate", "--material", "skin1", "--photons", "40000", "--batch-size", "1000",
                         "--threads", "1")
    line = err.splitlines()[-1]
    assert code == 130 and out == ""
    assert line.startswith("ssskit: Skin1 R: simulation interrupted after 2000 of 40000 photons; they are kept: "
                           "run ssskit simulate with the same material, photons and seed and --resume"), err
    assert "CLI" not in err and "=True" not in err


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
@pytest.mark.parametrize("option, name, fragment", [
    ("--material", "m.toml", "material file 'm.toml' is a FIFO"), ("--material", "pipe", "is a FIFO"),
    ("--scene", "g2.exr", "G-buffer file 'g2.exr' is a FIFO"), ("--settings", "s.toml", "settings file 's.toml' is a FIFO")])
def test_a_fifo_is_refused_not_read(tmp_path, option, name, fragment):
    """A named pipe as an input blocked forever on open (nobody writes to it); now one line, at once
    (a subprocess with a time limit, so the old behaviour fails instead of hanging the suite)."""
    os.mkfifo(tmp_path / name)
    args = ["render", "--scene", "slab"] if option != "--scene" else ["render"]
    if option == "--material":
        args = ["profile"]
    proc = subprocess.run([sys.executable, "-m", "ssskit.cli", *args, option, name], capture_output=True, text=True,
                          cwd=tmp_path, timeout=60, env=dict(os.environ, SSSKIT_CACHE_DIR=str(tmp_path / "cache")))
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("ssskit: error: ") and fragment in proc.stderr


def test_help_lists_the_kernel_methods(run):
    """The README says --help lists the choices: --methods, --method and --kernel name every method."""
    from ssskit.kernels import METHODS

    for command in ("evaluate", "kernel", "render", "export"):
        code, out, _ = run(command, "--help")
        flat = " ".join(out.split())
        assert code == 0 and all(m in flat for m in METHODS.names()), (command, out)


def test_json_is_strict_json(run, workdir):
    """One batch has no standard error (NaN): strict parsers reject NaN, so the JSON says null."""
    import json

    code, out, _ = run("simulate", "--material", "skin1", "--photons", "1000", "--batch-size", "1000000", "--json",
                       "--no-cache")

    def refuse(name):
        raise ValueError(f"not JSON: {name}")

    data = json.loads(out, parse_constant=refuse)
    assert code == 0 and data["channels"]["R"]["total_Rd_se"] is None and data["channels"]["R"]["total_Rd"] > 0


def test_the_kernel_header_names_the_preset_built(run):
    """``kernel --method artist --preset production`` was labelled 'fit'."""
    code, out, _ = run("kernel", "--method", "artist", "--preset", "production")
    header = out.splitlines()[0]
    assert code == 0 and header.startswith("# artist:production kernel"), header
    code, out, _ = run("kernel", "--method", "svd", "--material", "skin1", "--model", "dipole")
    assert out.startswith("# svd:1 kernel"), out


@pytest.mark.parametrize("content, fragment", [
    ("width = 64\nheight = 48\n", "applies to a built-in scene, not a G-buffer file"),
    ("method = 'separable'\n[burley]\nspp = 8\n", "the [burley] table's spp applies to method burley, not method separable"),
])
def test_settings_a_gbuffer_render_would_ignore(run, workdir, gbuffer_file, content, fragment):
    """A settings file's width/height with a G-buffer, and a [burley] table under method = separable, were ignored."""
    (workdir / "s.toml").write_text(content)
    one_error_line(run, workdir, ["render", "--scene", str(gbuffer_file), "--settings", "s.toml"], fragment)


def _gbuffer_variant(path, **changes):
    from ssskit.screenspace import load_gbuffer

    load_gbuffer(path).with_layers(**changes).save(path.parent / "variant.exr")
    return path.parent / "variant.exr"


@pytest.mark.parametrize("changes, fragment", [
    ({"profile_id": "zeros"}, "has no SSS pixel"),
    ({"materials": ("NoSuchMaterial",)}, "names material 'NoSuchMaterial' for profile id 1"),
])
def test_gbuffers_a_render_cannot_use(run, tmp_path, gbuffer_file, changes, fragment):
    """A G-buffer with no SSS pixel exited 0 with no metrics; one naming an unknown material was accepted."""
    import numpy as np

    from ssskit.screenspace import load_gbuffer

    local = tmp_path / "g.exr"
    local.write_bytes(gbuffer_file.read_bytes())
    if changes.get("profile_id") == "zeros":
        changes = {"profile_id": np.zeros_like(load_gbuffer(local).profile_id)}
    variant = _gbuffer_variant(local, **changes)
    code, out, err = run("render", "--scene", variant, "--backend", "numpy", "--out", tmp_path / "o.png")
    assert code == 2 and out == "" and err.count("\n") == 1 and fragment in err, err
    assert not (tmp_path / "o.png").exists()


def test_a_results_json_says_the_frames_size(run, gbuffer_file):
    """The G-buffer JSON's settings said 256x192 (the default) for a 32x24 file."""
    import json

    code, out, _ = run("render", "--scene", gbuffer_file, "--backend", "numpy", "--no-perceptual", "--json")
    data = json.loads(out)
    assert code == 0 and data["size"] == [32, 24]
    assert (data["settings"]["width"], data["settings"]["height"]) == (32, 24)


def test_render_json_keeps_its_progress(run, gbuffer_file):
    """--json dropped the progress lines of render: they go to stderr in every mode."""
    code, out, err = run("render", "--scene", gbuffer_file, "--backend", "numpy", "--no-perceptual", "--json")
    assert code == 0 and "separable pass" in err and out.count("\n") == 1


@pytest.mark.skipif(os.name != "posix", reason="signals")
@pytest.mark.parametrize("how", ["SIGTERM to the process", "SIGINT to its group"])
def test_a_terminated_demo_leaves_no_partial_folder(tmp_path, how):
    """kill (SIGTERM) in the middle of ``ssskit demo``: handled as Ctrl-C, so the staging folder goes too
    (a trial's Ctrl-C left 23-26 PNGs and no index.html); and Ctrl-C in a terminal (SIGINT to the whole
    process group). The demo's worker processes (two by default) end with it: none is left writing.

    The signal goes once the workers run their first section (their progress line on stderr), not after a
    fixed wait, and the waits after it are guards against a hang only: at a load of 5-12 the test's former
    120 s wait ran out on a demo that was merely slow."""
    import signal
    import threading

    hang_s = 1800  # a guard against a hang, never a measure of speed
    env = dict(os.environ, SSSKIT_CACHE_DIR=str(tmp_path / "cache"), SSSKIT_PROGRESS="lines")
    proc = subprocess.Popen([sys.executable, "-m", "ssskit.cli", "demo", "--photons", "5000", "--out", "d"],
                            cwd=tmp_path, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    hung: list[bool] = []
    guard = threading.Timer(hang_s, lambda: (hung.append(True), os.killpg(proc.pid, signal.SIGKILL)))
    guard.start()
    try:
        lines = []
        for text in proc.stderr:  # until a worker runs a section (or the demo ends, which fails below)
            lines.append(text)
            if re.search(r"\[\d+/\d+\] section ", text):
                break
        assert any(p.name.startswith(".d.partial-") for p in tmp_path.iterdir()), "".join(lines)
        if how.startswith("SIGTERM"):
            proc.send_signal(signal.SIGTERM)
        else:
            os.killpg(proc.pid, signal.SIGINT)
        _, rest = proc.communicate()
        err = "".join(lines) + rest
        assert proc.returncode == 130 and "ssskit: interrupted" in err, err
        assert "Traceback" not in err, err
        while True:  # every process of the demo's group ends with it (the guard ends a hang)
            try:
                os.killpg(proc.pid, 0)
            except ProcessLookupError:
                break
            threading.Event().wait(0.2)
    finally:
        guard.cancel()
    assert not hung, "the demo or one of its workers hung"
    assert [p.name for p in tmp_path.iterdir() if p.name != "cache"] == [], err
