"""Fixtures of the CLI tests: run ``ssskit`` in-process, and a small G-buffer file."""

import pytest

from ssskit.cli import main
from tests.conftest import without_heartbeats


@pytest.fixture
def run(capsys):
    """run(*args) -> (exit status, stdout, stderr) of ``ssskit ARGS`` through :func:`ssskit.cli.main`."""

    def go(*args):
        code = main([str(a) for a in args])
        out, err = capsys.readouterr()
        return code, out, without_heartbeats(err)

    return go


@pytest.fixture(scope="session")
def gbuffer_file(tmp_path_factory):
    """A 32x24 slab G-buffer written by ``ssskit render --save-gbuffer`` (1 spp, numpy backend)."""
    path = tmp_path_factory.mktemp("gbuffer") / "slab.exr"
    code = main(["render", "--scene", "slab", "--size", "32x24", "--spp", "1", "--backend", "numpy", "--no-exact",
                 "--no-perceptual", "--save-gbuffer", str(path), "--json"])
    assert code == 0 and path.is_file()
    return path
