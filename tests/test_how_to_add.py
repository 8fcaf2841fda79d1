"""The recipes of docs/architecture.md ("How to add a kernel method / a backend / a command"), carried out
once at run time: what the page says is enough is enough (the new entry reaches the library, the
settings and the command line with no other edit)."""

import json

import numpy as np
import pytest

from ssskit.cli import main


@pytest.fixture
def registries(monkeypatch):
    """Registries and caches restored after the test (entries added here do not leak)."""
    from ssskit import backends, kernels

    monkeypatch.setattr(kernels.METHODS, "_entries", dict(kernels.METHODS._entries))
    monkeypatch.setattr(kernels, "PARAM_CHECKS", dict(kernels.PARAM_CHECKS))
    monkeypatch.setattr(backends.BACKENDS, "_entries", dict(backends.BACKENDS._entries))
    monkeypatch.setattr(backends, "_INSTANCES", dict(backends._INSTANCES))


def test_a_kernel_method_needs_only_its_registration(registries, capsys):
    """Step 2 of the recipe: a KernelMethod in METHODS (here a rank-N SVD under a new name) and its range
    check; then build_kernel, RenderSettings and `ssskit kernel --method name:value` take it (step 3)."""
    from ssskit import kernels
    from ssskit.pipeline import RenderSettings
    from ssskit.profiles import profile_for_material

    svd = kernels.METHODS.get("svd")
    kernels.METHODS.register("svd_twin", kernels.KernelMethod("svd_twin", svd.builder, "rank", svd.parse,
                                                              "the rank-N SVD again (a recipe test)"))
    kernels.PARAM_CHECKS[("svd_twin", "rank")] = kernels.PARAM_CHECKS[("svd", "rank")]
    prof = profile_for_material("skin1", "dipole")
    cell, n = kernels.default_grid(prof)
    twin, ref = kernels.build_kernel("svd_twin", prof, cell, n, rank=2), kernels.build_kernel("svd", prof, cell, n, rank=2)
    np.testing.assert_array_equal(twin.components, ref.components)
    assert RenderSettings(kernel="svd_twin:2").kernel == "svd_twin:2"
    with pytest.raises(Exception, match="rank"):
        kernels.parse_method_spec("svd_twin:0")  # the range check applies before any work
    assert main(["kernel", "--material", "skin1", "--model", "dipole", "--method", "svd_twin:2", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["channels"]["R"]["components"]) == 2  # a rank-2 kernel, as the twin of svd builds it


def test_a_backend_needs_only_its_registration(registries, capsys):
    """Steps 1-2: a Backend subclass and a factory in BACKENDS; then RenderSettings, the passes and
    `ssskit backends` take it (the parity fixture parametrises over BACKENDS.names() the same way)."""
    from ssskit.backends import BACKENDS
    from ssskit.backends.numpy_backend import NumpyBackend
    from ssskit.pipeline import RenderSettings
    from ssskit.screenspace import BurleyParams, Camera, GBuffer, burley_sss

    class Twin(NumpyBackend):
        name = "numpy_twin"
        description = "the numpy oracle again (a recipe test)"

    BACKENDS.register("numpy_twin", Twin)
    assert RenderSettings(backend="numpy_twin").backend == "numpy_twin"
    h, w = 12, 16
    gb = GBuffer(diffuse=np.random.default_rng(3).random((h, w, 3)).astype(np.float32),
                 albedo=np.ones((h, w, 3), np.float32), depth=np.full((h, w), 300.0, np.float32),
                 profile_id=np.ones((h, w), np.uint32), camera=Camera(w, h, 400.0, 400.0, w / 2, h / 2))
    params = BurleyParams.from_dmfp(0.6, (2.0, 1.0, 0.5))
    np.testing.assert_array_equal(burley_sss(gb, params, spp=8, mips=False, backend="numpy_twin"),
                                  burley_sss(gb, params, spp=8, mips=False, backend="numpy"))
    assert main(["backends", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["backends"]["numpy_twin"]["available"] is True


def test_a_command_needs_only_its_module_and_its_place_in_the_group(monkeypatch, capsys):
    """Steps 1-2: a click command registered in the group; main() runs it and turns its user errors into
    one line and exit status 2."""
    import click

    from ssskit.cli import cli
    from ssskit.errors import SsskitError

    @click.command("twice")
    @click.option("--n", type=int, required=True)
    def twice(n: int) -> None:
        if n < 0:
            raise SsskitError(f"--n must be >= 0, got {n}")
        click.echo(json.dumps({"twice": 2 * n}))

    monkeypatch.setattr(cli, "commands", dict(cli.commands))
    cli.add_command(twice)
    assert main(["twice", "--n", "21"]) == 0 and json.loads(capsys.readouterr().out) == {"twice": 42}
    assert main(["twice", "--n", "-1"]) == 2
    assert capsys.readouterr().err == "ssskit: error: --n must be >= 0, got -1\n"


def test_an_engine_format_needs_only_its_registration(monkeypatch, tmp_path, capsys):
    """docs/architecture.md, "How to add an engine format", steps 1-3: a toy engine (a JSON holding Burley's A and
    d in its own .toy file) registered in FORMATS is written by export() and `ssskit export --format toy`, its
    files are read back as --material by export and profile, and an option it does not take is refused in the
    one wording."""
    import numpy as np

    from ssskit.export import FORMATS, ExportSettings, Format, export, fit_burley
    from ssskit.export.readers import EngineSource

    monkeypatch.setattr(FORMATS, "_entries", dict(FORMATS._entries))

    def write(job):  # step 1: the engine's parameters from Burley's (A, d)
        a, d = fit_burley(job.source.profile())
        job.summary["parameters"] = {"A": a.tolist(), "d_mm": d.tolist()}
        return json.dumps({"toy": 1, "name": job.source.name or job.request.material, "A": a.tolist(),
                           "d_mm": d.tolist()})

    def read(path):  # and its reader
        data = json.loads(path.read_text())
        return EngineSource("toy", data["name"], np.array(data["A"]), np.array(data["d_mm"]))

    FORMATS.register("toy", Format("toy", (".toy",), "engine", (), write, "a toy engine (a recipe test)", read))
    summary = export(ExportSettings(format="toy", out=str(tmp_path / "a.toy"), material="skin1"))
    assert summary["format"] == "toy" and len(summary["parameters"]["A"]) == 3
    monkeypatch.chdir(tmp_path)
    assert main(["export", "--material", "skin1", "--format", "toy", "--out", "b.toy"]) == 0
    assert (tmp_path / "a.toy").read_text() == (tmp_path / "b.toy").read_text()
    assert main(["export", "--material", "b.toy", "--format", "blender", "--out", "b.json"]) == 0
    a, d = (np.array(json.loads((tmp_path / "b.toy").read_text())[k]) for k in ("A", "d_mm"))
    blender = json.loads((tmp_path / "b.json").read_text())
    np.testing.assert_allclose(blender["base_color"], a, rtol=1e-12)  # the toy's A, through its reader
    assert main(["profile", "--material", "b.toy", "--model", "dipole", "--json"]) == 0
    capsys.readouterr()
    assert main(["export", "--material", "skin1", "--format", "toy", "--standard-surface", "--out", "c.toy"]) == 2
    assert capsys.readouterr().err == "ssskit: error: --standard-surface applies to --format materialx, not --format toy\n"
    assert not (tmp_path / "c.toy").exists()
