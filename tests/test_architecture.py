"""The architecture of docs/architecture.md, enforced: the import-linter contracts of pyproject.toml
(``[tool.importlinter]``: the layers, backends built on the contract and never on each other, a numpy
oracle without numba) hold for the source tree, and they can fail.

import-linter (the ``dev`` extra) runs in a subprocess on ``src/`` of this checkout, whatever copy of
ssskit is installed; every import counts, lazy ones inside functions included. ``lint-imports``
runs the same contracts by hand.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = ROOT / "pyproject.toml"
SRC = ROOT / "src"
DOC = ROOT / "docs" / "architecture.md"

_LINT = ("import sys; from importlinter.cli import lint_imports; "
         "sys.exit(lint_imports(config_filename=sys.argv[1], no_cache=True, no_logo=True))")


def _lint(src: Path) -> subprocess.CompletedProcess:
    """import-linter's contracts from pyproject.toml on the ``ssskit`` package under ``src``."""
    if importlib.util.find_spec("importlinter") is None:
        pytest.fail("import-linter is not installed: pip install '.[dev]'")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(src), os.environ.get("PYTHONPATH")) if p),
           "COLUMNS": "200", "NO_COLOR": "1"}
    return subprocess.run([sys.executable, "-c", _LINT, str(PYPROJECT)], cwd=src, env=env, capture_output=True,
                          text=True, timeout=600)


def _contract(contract_id: str) -> dict:
    config = tomllib.loads(PYPROJECT.read_text(encoding="utf-8"))["tool"]["importlinter"]
    return next(c for c in config["contracts"] if c["id"] == contract_id)


def test_import_contracts_hold():
    proc = _lint(SRC)
    assert proc.returncode == 0, f"import-linter contracts broken:\n{proc.stdout}\n{proc.stderr}"
    assert "0 broken" in proc.stdout


def _scratch(tmp_path: Path) -> Path:
    """A copy of src/ssskit to break."""
    dst = tmp_path / "src"
    shutil.copytree(SRC / "ssskit", dst / "ssskit", ignore=shutil.ignore_patterns("__pycache__"))
    return dst


def test_an_upward_lazy_import_breaks_the_layers(tmp_path):
    src = _scratch(tmp_path)
    with open(src / "ssskit" / "materials.py", "a", encoding="utf-8") as f:
        f.write("\n\ndef _upward():\n    from .pipeline import render\n\n    return render\n")
    proc = _lint(src)
    assert proc.returncode != 0
    assert re.search(r"ssskit\.materials -> ssskit\.pipeline", proc.stdout), proc.stdout


def test_importing_the_lab_breaks_its_contract(tmp_path):
    """The product never imports experiments/lab, even lazily."""
    src = _scratch(tmp_path)
    with open(src / "ssskit" / "truth.py", "a", encoding="utf-8") as f:
        f.write("\n\ndef _lab():\n    import lab.attribution\n\n    return lab.attribution\n")
    proc = _lint(src)
    assert proc.returncode != 0
    assert "product never imports the lab" in proc.stdout and re.search(r"ssskit\.truth -> lab", proc.stdout), proc.stdout


#: the import graph's cycles (lazy imports included): strongly connected components of grimp's graph
_CYCLES = r"""
import json, sys
import grimp
sys.setrecursionlimit(10000)
g = grimp.build_graph("ssskit", include_external_packages=False)
adj = {m: [x for x in g.find_modules_directly_imported_by(m) if x.startswith("ssskit")] for m in g.modules}
index, low, stack, on, out, n = {}, {}, [], set(), [], [0]
def visit(v):
    index[v] = low[v] = n[0]; n[0] += 1; stack.append(v); on.add(v)
    for w in adj[v]:
        if w not in index:
            visit(w); low[v] = min(low[v], low[w])
        elif w in on:
            low[v] = min(low[v], index[w])
    if low[v] == index[v]:
        comp = []
        while True:
            w = stack.pop(); on.discard(w); comp.append(w)
            if w == v:
                break
        if len(comp) > 1:
            out.append(sorted(comp))
for m in sorted(adj):
    if m not in index:
        visit(m)
print(json.dumps(out))
"""


def _cycles(src: Path) -> list[list[str]]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(src), os.environ.get("PYTHONPATH")) if p)}
    proc = subprocess.run([sys.executable, "-c", _CYCLES], cwd=src, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_no_import_cycles():
    """No two modules import each other, directly or through others, even lazily inside functions."""
    assert _cycles(SRC) == []


def test_a_cycle_is_found(tmp_path):
    src = _scratch(tmp_path)
    with open(src / "ssskit" / "registry.py", "a", encoding="utf-8") as f:
        f.write("\n\ndef _back():\n    from . import cache\n\n    return cache\n")
    with open(src / "ssskit" / "cache.py", "a", encoding="utf-8") as f:
        f.write("\n\ndef _forth():\n    from . import registry\n\n    return registry\n")
    assert ["ssskit.cache", "ssskit.registry"] in _cycles(src)


def test_a_module_outside_the_layers_breaks_the_contract(tmp_path):
    src = _scratch(tmp_path)
    (src / "ssskit" / "unplaced.py").write_text('"""A new module nobody placed in a layer."""\n', encoding="utf-8")
    proc = _lint(src)
    assert proc.returncode != 0 and "unplaced" in proc.stdout, proc.stdout


def test_docs_list_the_contract_layers():
    """docs/architecture.md's layer table names the layers of the contract, high to low."""
    text = DOC.read_text(encoding="utf-8")
    block = re.search(r"<!-- layers -->\s*```text\n(.*?)```", text, re.S)
    assert block, "docs/architecture.md: no ```text block after <!-- layers -->"
    doc_layers = [re.split(r"\s{2,}", line.strip())[0] for line in block.group(1).splitlines() if line.strip()]
    assert doc_layers == _contract("layers")["layers"]


def test_docs_name_files_that_exist():
    paths = set(re.findall(r"`((?:src|tests|docs|benchmarks)/[\w./-]+?)`", DOC.read_text(encoding="utf-8")))
    assert paths, "docs/architecture.md names no files"
    missing = sorted(p for p in paths if not (ROOT / p).exists())
    assert not missing, f"docs/architecture.md names files that do not exist: {missing}"


def test_star_imports_give_the_public_names_only():
    """``from ssskit import *`` gives the pipeline's entry points (not annotations, importlib, Any); the modules a
    user imports from directly (materials, truth, metrics, errors) declare __all__, each name defined there and
    every public function and class of the module listed."""
    import importlib
    import inspect

    names: dict[str, object] = {}
    exec("from ssskit import *", names)
    assert sorted(k for k in names if k != "__builtins__") == ["RenderResult", "RenderSettings", "render"]
    for mod_name in ("materials", "truth", "metrics", "errors"):
        module = importlib.import_module(f"ssskit.{mod_name}")
        assert all(hasattr(module, n) for n in module.__all__), mod_name
        own = {n for n, v in vars(module).items() if not n.startswith("_") and (inspect.isfunction(v) or inspect.isclass(v))
               and v.__module__ == module.__name__}
        assert own <= set(module.__all__), (mod_name, own - set(module.__all__))
