"""Bad input: exactly one stderr line ``ssskit: error: ...``, exit status 2, nothing on stdout, nothing
written, no traceback -- and every check happens before any work starts."""

import os
import subprocess
import sys

import pytest

#: files each test finds in its (empty, current) folder: a regular file, a file named like a G-buffer
#: (never read: every check below fails before the G-buffer is loaded) and a folder named x.exr
SETUP = {"f.txt": "not a folder", "g.exr": "not read", "m.json": '{"sigma_a": 0.01, "sigma_s": 1.0}'}


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
    (["profile", "--material", "skin1", "--photons", "5000"], "--photons does not apply to --model dipole"),
    (["profile", "--material", "skin1", "--model", "burley", "--gaussians", "3"], "--gaussians does not apply"),
    (["profile", "--material", "skin1", "--model", "dipole", "--albedo-source", "dipole"], "--albedo-source does not apply"),
    (["profile", "--material", "skin1", "--model", "dipole", "--grid-fraction", "0.999"], "--grid-fraction does not apply"),
    (["render", "--scene", "slab", "--reference", "--reference-rel-se", "0"], "--reference-rel-se"),
    (["render", "--scene", "slab", "--reference", "--reference-max-spp", "0"], "--reference-max-spp"),
    (["simulate", "--material", "skin1,marble", "--grid-fraction", "0.999"], "single material"),
    (["simulate", "--material", "skin1", "--grid-fraction", "1.5"], "--grid-fraction"),
    (["simulate", "--material", "skin1", "--roughness", "1.5"], "--roughness"),
    (["profile", "--material", "skin1", "--model", "dipole", "--roughness", "0.15"], "--roughness does not apply"),
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
    (["kernel", "--material", "skin1", "--method", "gaussians", "--rank", "3"], "its parameter is --count"),
    (["kernel", "--material", "skin1", "--method", "preintegrated", "--rank", "3"], "takes no parameter"),
    (["kernel", "--material", "skin1", "--method", "svd:3", "--rank", "2"], "give the rank once"),
    (["kernel", "--material", "skin1", "--method", "guided", "--k", "9"], "--k: guide exponent"),
    (["kernel", "--material", "skin1", "--method", "svd", "--rank", "two"], "--rank: expected an integer"),
    (["kernel", "--method", "artist", "--preset", "nope"], "unknown artist preset"),
    (["kernel", "--method", "artist:fit"], "needs a profile"),
    (["evaluate", "--material", "skin1", "--methods", ","], "no kernel method given"),
    (["evaluate", "--material", "skin1", "--methods", "svd:0"], "SVD rank"),
    # render: G-buffer files
    (["render", "--scene", "g.exr", "--size", "64x64"], "--size applies to a built-in scene"),
    (["render", "--scene", "g.exr", "--spp", "4"], "--spp applies to a built-in scene"),
    (["render", "--scene", "g.exr", "--out", "g.exr"], "--out 'g.exr' would overwrite the input 'g.exr'"),
    (["render", "--scene", "g.exr", "--out", "./sub/../g.exr"], "would overwrite the input"),
    (["render", "--scene", "g.exr", "--save-gbuffer", "g.exr"], "--save-gbuffer 'g.exr' would overwrite the input"),
    (["render", "--scene", "slab", "--out", "a.exr", "--save-gbuffer", "a.exr"], "--save-gbuffer 'a.exr' is also the --out file"),
    (["render", "--scene", "g.exr", "--reference"], "--reference needs a built-in scene"),
    (["kernel", "--material", "m.json", "--model", "dipole", "--method", "artist", "--out", "m.json"],
     "would overwrite the input 'm.json'"),
    (["render", "--scene", "x.exr"], "'x.exr' is a directory"),
    (["render", "--scene", "missing.exr"], "does not exist"),
    (["render", "--scene", "f.txt"], "unknown format '.txt' (a mesh .obj, .ply, .glb, .gltf, a scene .toml or a G-buffer .exr)"),
    (["render", "--scene", "teapot"], "unknown scene 'teapot'"),
    # render: settings, each checked by RenderSettings / PassSettings before any work
    (["render", "--scene", "slab", "--size", "0x0"], "the width must lie in 8..8192"),
    (["render", "--scene", "slab", "--size", "100000x100000"], "the width must lie in 8..8192"),
    (["render", "--scene", "slab", "--size", "64x"], "must look like 256x192"),
    (["render", "--scene", "slab", "--jitter", "nan"], "--jitter: jitter must be a finite number in [0, 1]"),
    (["render", "--scene", "slab", "--jitter", "2"], "--jitter"),
    (["render", "--scene", "slab", "--kernel", "svd:0"], "SVD rank must lie in 1..64"),
    (["render", "--scene", "slab", "--kernel", "guided:9"], "guide exponent k"),
    (["render", "--scene", "slab", "--kernel", "jimenez2012:11", "--taps", "7"], "give the number of taps once"),
    (["render", "--scene", "slab", "--taps", "6"], "--taps: taps must be odd"),
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
    (["kernel", "--method", "svd", "--material", "skin1", "--taps", "7"], "--taps does not apply to --method svd"),
    (["kernel", "--method", "svd", "--material", "skin1", "--size", "50"], "--size must be odd"),
    (["kernel", "--method", "jimenez2012", "--taps", "10"], "odd"),
    (["kernel", "--method", "jimenez2012", "--out", "k.txt"], "must end in .npz or .json"),
    (["kernel", "--method", "jimenez2012", "--model", "dipole"], "need a --material"),
    (["evaluate", "--material", "skin1", "--signal", "plaid"], "unknown signal 'plaid'"),
    (["evaluate", "--material", "skin1", "--methods", "svd:x"], "integer"),
    (["evaluate", "--model", "dipole"], "--material is required"),
    (["render", "--scene", "slab", "--taps", "4"], "odd"),
    (["render", "--scene", "slab", "--size", "big"], "--size"),
    (["render", "--scene", "slab", "--kernel", "nope"], "unknown kernel method 'nope'"),
    (["render", "--scene", "slab", "--out", "x.tif"], "must end in .exr or .png"),
    (["render", "--scene", "slab", "--save-gbuffer", "x.png"], "must end in .exr"),
]


@pytest.mark.parametrize("args, fragment", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_input(run, workdir, args, fragment):
    one_error_line(run, workdir, args, fragment)


@pytest.mark.parametrize("content, fragment", [
    ("taps = 8\n", "taps must be odd"),
    ("tapz = 7\n", "unknown setting(s) tapz"),
    ("[sss]\njitter = 3\n", "jitter must be a finite number"),
    ("kernel = 'svd:0'\n", "SVD rank"),
    ("reference = true\n", "--reference needs a built-in scene"),
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


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.path.isdir("/sys/kernel"),
                    reason="needs Linux's sysfs, where nobody (root included) may create files")
@pytest.mark.parametrize("command", [["figures", "fig2", "--model", "dipole"], ["demo", "--photons", "5000"]])
def test_unwritable_folder(run, workdir, command):
    one_error_line(run, workdir, [*command, "--out", "/sys/kernel/ssskit-out"], "cannot write --out")


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
