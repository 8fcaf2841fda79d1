"""The package's shape: every module reachable lazily from ``import ssskit``, which stays light, and
imports that only flow down the layers (including imports inside functions)."""

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import ssskit

SRC = Path(ssskit.__file__).parent

#: the layers, bottom first; a module may import its own layer and those below, never above
LAYERS = (
    {"errors", "registry", "cache", "settings", "io"},
    {"materials"},
    {"profiles"},
    {"kernels"},
    {"sampling"},
    {"backends"},
    {"screenspace"},
    {"scenes", "truth", "metrics"},
    {"pipeline", "evaluate"},
    {"figures", "report", "export"},
    {"cli"},
)
LEVEL = {name: i for i, layer in enumerate(LAYERS) for name in layer}


def _top_modules() -> set[str]:
    return {m.name for m in pkgutil.iter_modules([str(SRC)])}


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


def _imports(path: Path, package: list[str]):
    """(line, absolute module) of every import in the file, at any depth (functions included);
    ``package``: the parts of the package the file belongs to."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if not node.level:
                yield node.lineno, node.module or ""
                continue
            base = package[: len(package) - node.level + 1]
            if node.module is None:  # from . import a, b
                for alias in node.names:
                    yield node.lineno, ".".join(base + [alias.name])
            else:
                yield node.lineno, ".".join(base + [node.module])


def test_imports_flow_down_the_layers():
    assert _top_modules() <= set(LEVEL), f"place these modules in LAYERS: {sorted(_top_modules() - set(LEVEL))}"
    bad = []
    for path in sorted(SRC.rglob("*.py")):
        parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
        if parts == ["ssskit", "__init__"]:
            continue  # the lazy attribute table names every module by string
        own = parts[1]
        for line, mod in _imports(path, parts[:-1]):
            names = mod.split(".")
            if names[0] != "ssskit" or len(names) < 2:
                continue
            if names[1] in LEVEL and LEVEL[names[1]] > LEVEL[own]:
                bad.append(f"{'/'.join(parts)}.py:{line} ({own}) imports {mod} ({names[1]})")
    assert not bad, "imports against the layers:\n" + "\n".join(bad)
