"""The package's shape at run time: every module reachable lazily from ``import ssskit``, which stays
light. The import layering itself (lazy imports included) is import-linter's: tests/test_architecture.py."""

import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import ssskit
from tests.conftest import without_heartbeats

SRC = Path(ssskit.__file__).parent


def _top_modules() -> set[str]:
    """The package's top-level modules but ``__main__`` (``python -m ssskit``: it runs the CLI when imported)."""
    return {m.name for m in pkgutil.iter_modules([str(SRC)]) if m.name != "__main__"}


def test_python_m_ssskit_is_the_command():
    proc = subprocess.run([sys.executable, "-m", "ssskit", "--version"], capture_output=True, text=True)
    assert proc.returncode == 0 and "ssskit" in proc.stdout, proc.stderr
    proc = subprocess.run([sys.executable, "-m", "ssskit", "render", "--scene", "teapot"], capture_output=True,
                          text=True)
    err = without_heartbeats(proc.stderr)
    assert proc.returncode == 2 and err.startswith("ssskit: error: ") and err.count("\n") == 1


def test_every_module_is_a_lazy_attribute():
    top = _top_modules()
    assert top <= set(ssskit._SUBMODULES), f"missing from ssskit._SUBMODULES: {sorted(top - set(ssskit._SUBMODULES))}"
    assert set(ssskit._SUBMODULES) <= top, "ssskit._SUBMODULES names modules that do not exist"
    assert callable(ssskit.render) and ssskit.RenderSettings().taps == 7
    with pytest.raises(AttributeError):
        ssskit.nope  # noqa: B018


def test_import_is_light():
    code = ("import sys, ssskit; print(sorted(m for m in ('scipy', 'matplotlib', 'numba', 'mitsuba', 'OpenEXR') "
            "if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip() == "[]"
